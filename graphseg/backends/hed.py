"""Kept for one release: ``graphseg.backends.hed`` moved to :mod:`graphseg.backends.segmenters.hed`.

This module only re-exports the public names of the new one; import them from
there (patch functions there too: this module's names are the same objects,
but the backends look them up in their own module). It will be removed in the
next release.

Examples
--------
>>> from graphseg.backends.segmenters import hed
>>> HEDEdges is hed.HEDEdges
True
"""

from .segmenters.hed import (
    HED_MEAN_BGR,
    HEDEdges,
    build_hed,
    bundled_weights,
    hed_edges,
    load_hed_weights,
)

__all__ = ["HED_MEAN_BGR", "bundled_weights", "build_hed", "load_hed_weights", "hed_edges", "HEDEdges"]
