"""Hide what an RGB-only camera would not give: depth, poses and (optionally) intrinsics.

Examples
--------
>>> import numpy as np
>>> from graphseg.scene import Scene, View
>>> v = View("0", np.zeros((2, 2, 3), np.uint8), depth=np.ones((2, 2), np.float32), K=np.eye(3), cam_to_world=np.eye(4))
>>> s = rgb_only(Scene([v]))
>>> s.has_depth, s.views[0].cam_to_world is None, s.views[0].K is not None
(False, True, True)
"""

from __future__ import annotations

from ..scene import Scene

__all__ = ["rgb_only"]


def rgb_only(scene: Scene, *, keep_intrinsics: bool = True) -> Scene:
    """A copy of ``scene`` without depth, point maps, confidence and poses (and ``K`` unless ``keep_intrinsics``).

    RGB, ground-truth instances, object names and ``meta`` are kept; the
    input is not changed. O(number of views).
    """
    views = [v.replace(depth=None, points=None, confidence=None, cam_to_world=None, K=v.K if keep_intrinsics else None) for v in scene.views]
    return Scene(views, dict(scene.objects), scene.name, {**scene.meta, "rgb_only": True})
