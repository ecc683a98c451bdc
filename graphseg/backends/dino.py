"""Kept for one release: ``graphseg.backends.dino`` moved to :mod:`graphseg.backends.features.dino`.

This module only re-exports the public names of the new one; import them from
there (patch functions there too: this module's names are the same objects,
but the backends look them up in their own module). It will be removed in the
next release.

Examples
--------
>>> from graphseg.backends.features import dino
>>> DINOv2Features is dino.DINOv2Features
True
"""

from .features.dino import DINOv2Features, build_dinov2, dinov2_arch, patch_grid

__all__ = ["DINOv2Features", "dinov2_arch", "patch_grid", "build_dinov2"]
