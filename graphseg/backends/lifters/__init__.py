"""Lifters: give every pixel a world point (``scene -> scene`` with ``points``, ``confidence``, cameras).

One module per lifter, with the geometry the learned ones share beside them:

* ``rgbd`` (:mod:`.rgbd`): metric depth + intrinsics + poses -> world point maps.
* ``precomputed-points`` (:mod:`.precomputed`): point maps computed elsewhere
  (``--points DIR``, docs/formats.md).
* ``sfm`` (:mod:`.sfm`): classical; COLMAP cameras, then stereo depth
  (:mod:`.stereo`) with holes filled per colour region (:mod:`.densify`).
* ``dust3r`` (:mod:`.dust3r`) and ``da3`` (:mod:`.da3`): learned, from the
  user's checkpoint or ONNX export; their pairwise or per-view predictions are
  aligned into one metric frame by :mod:`.align`.

This package re-exports the public names of the old
``graphseg.backends.lifters`` module and every lifter class.

Examples
--------
>>> import numpy as np
>>> from graphseg.scene import Scene, View
>>> v = View("0", np.zeros((2, 2, 3), np.uint8), depth=np.ones((2, 2), np.float32), K=np.eye(3), cam_to_world=np.eye(4))
>>> RGBDLifter()(Scene([v])).views[0].points[1, 1].tolist()
[1.0, 1.0, 1.0]
"""

from .da3 import DA3Lifter
from .dust3r import DUSt3RLifter
from .precomputed import PrecomputedLifter
from .rgbd import NO_DEPTH_MESSAGE, RGBDLifter
from .sfm import SfmLifter

__all__ = ["RGBDLifter", "NO_DEPTH_MESSAGE", "PrecomputedLifter", "SfmLifter", "DUSt3RLifter", "DA3Lifter"]
