"""Kept for one release: ``graphseg.backends.stereo`` moved to :mod:`graphseg.backends.lifters.stereo`.

This module only re-exports the public names of the new one; import them from
there (patch functions there too: this module's names are the same objects,
but the backends look them up in their own module). It will be removed in the
next release.

Examples
--------
>>> from graphseg.backends.lifters import stereo
>>> stereo_depths is stereo.stereo_depths
True
"""

from .lifters.stereo import (
    fuse_depths,
    pair_points,
    select_neighbours,
    sparse_point_maps,
    stereo_depths,
    view_consistency,
)

__all__ = ["pair_points", "stereo_depths", "fuse_depths", "sparse_point_maps", "select_neighbours", "view_consistency"]
