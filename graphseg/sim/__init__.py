"""Synthetic scenes with exact ground truth.

* :mod:`graphseg.sim.boxes`: a dependency-free ray caster for boxes on a table.
* :mod:`graphseg.sim.pybullet_scenes`: physics-dropped objects rendered with
  pybullet's CPU TinyRenderer (extra ``sim``): pybullet's bundled objects or
  procedural textured shapes, table textures and lighting as options.
* :mod:`graphseg.sim.families`: the fixed scene list of the RGB-only benchmark,
  split once into a tune half and a check half.
* :mod:`graphseg.sim.strip`: the RGB-only version of a scene (depth, poses and
  optionally intrinsics removed).

Importing this package needs no pybullet; rendering does.
"""

from .boxes import Box, Rendering, intrinsics, look_at, render_boxes
from .families import SCENES, SceneSpec, make_scene, rgb_only_scene
from .pybullet_scenes import synthesize
from .strip import rgb_only

__all__ = ["Box", "Rendering", "look_at", "intrinsics", "render_boxes", "synthesize", "SceneSpec", "SCENES", "make_scene", "rgb_only_scene", "rgb_only"]
