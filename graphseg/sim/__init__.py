"""Synthetic scenes with exact ground truth.

* :mod:`graphseg.sim.boxes`: a dependency-free ray caster for boxes on a table.
* :mod:`graphseg.sim.pybullet_scenes`: physics-dropped objects rendered with
  pybullet's CPU TinyRenderer (extra ``sim``).
"""

from .boxes import Box, Rendering, intrinsics, look_at, render_boxes

__all__ = ["Box", "Rendering", "look_at", "intrinsics", "render_boxes"]
