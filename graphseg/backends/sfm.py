"""Kept for one release: ``graphseg.backends.sfm`` moved to :mod:`graphseg.backends.lifters.sfm`.

This module only re-exports the public names of the new one; import them from
there (patch functions there too: this module's names are the same objects,
but the backends look them up in their own module). It will be removed in the
next release.

Examples
--------
>>> from graphseg.backends.lifters import sfm
>>> SfmLifter is sfm.SfmLifter
True
"""

from .lifters.sfm import (
    CAMERA_MODELS,
    NOMINAL_DISTANCE,
    SfmLifter,
    SfmReconstruction,
    not_registered_message,
    run_sfm,
    scale_reconstruction,
)

__all__ = ["SfmLifter", "SfmReconstruction", "run_sfm", "NOMINAL_DISTANCE", "CAMERA_MODELS", "not_registered_message", "scale_reconstruction"]
