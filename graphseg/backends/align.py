"""Kept for one release: ``graphseg.backends.align`` moved to :mod:`graphseg.backends.lifters.align`.

This module only re-exports the public names of the new one; import them from
there (patch functions there too: this module's names are the same objects,
but the backends look them up in their own module). It will be removed in the
next release.

Examples
--------
>>> from graphseg.backends.lifters import align
>>> global_align is align.global_align
True
"""

from .lifters.align import (
    NOMINAL_WORKING_DISTANCE,
    Alignment,
    PairPointMaps,
    apply_similarity,
    estimate_focal,
    finish_lift,
    global_align,
    lift_from_alignment,
    metric_scale,
    similarity_to_known_poses,
    umeyama,
)

__all__ = ["umeyama", "PairPointMaps", "Alignment", "global_align", "estimate_focal", "similarity_to_known_poses", "apply_similarity", "metric_scale", "NOMINAL_WORKING_DISTANCE", "finish_lift", "lift_from_alignment"]
