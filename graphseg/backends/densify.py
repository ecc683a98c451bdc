"""Kept for one release: ``graphseg.backends.densify`` moved to :mod:`graphseg.backends.lifters.densify`.

This module only re-exports the public names of the new one; import them from
there (patch functions there too: this module's names are the same objects,
but the backends look them up in their own module). It will be removed in the
next release.

Examples
--------
>>> from graphseg.backends.lifters import densify
>>> fill_depth_by_regions is densify.fill_depth_by_regions
True
"""

from .lifters.densify import color_regions, fill_depth_by_regions

__all__ = ["fill_depth_by_regions", "color_regions"]
