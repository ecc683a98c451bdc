"""The ``rgbd`` lifter: metric depth + intrinsics + poses -> world point maps.

Confidence is 1 where depth is valid and 0 elsewhere. A scene without depth needs a learned
lifter with the user's weights (``sfm``, ``dust3r``, ``da3``; see docs/models.md)
or point maps computed elsewhere (``--points DIR``, docs/formats.md).

Examples
--------
>>> import numpy as np
>>> from graphseg.scene import Scene, View
>>> v = View("0", np.zeros((2, 2, 3), np.uint8), depth=np.ones((2, 2), np.float32), K=np.eye(3), cam_to_world=np.eye(4))
>>> RGBDLifter()(Scene([v])).views[0].points[1, 1].tolist()
[1.0, 1.0, 1.0]
"""

from __future__ import annotations

import numpy as np

from ...scene import Scene, SceneError, backproject
from ..options import Backend

__all__ = ["RGBDLifter", "NO_DEPTH_MESSAGE"]

NO_DEPTH_MESSAGE = (
    "this scene has no depth; choose a lifter: --lifter sfm (classical), --lifter dust3r or --lifter da3 "
    "(your checkpoint: --backend-option dust3r.encoder=PATH / da3.checkpoint=PATH, see docs/models.md), "
    "or --points DIR with precomputed point maps (docs/formats.md), or give depth with intrinsics and poses"
)


class RGBDLifter(Backend):
    """The ``rgbd`` lifter: ``points = cam_to_world * backproject(depth, K)`` (no options)."""

    name = "rgbd"

    def __call__(self, scene: Scene) -> Scene:
        views = []
        for v in scene.views:
            if v.depth is None:
                raise SceneError(NO_DEPTH_MESSAGE, where=v.name, field="depth")
            if v.K is None:
                raise SceneError("the rgbd lifter needs intrinsics", where=v.name, field="K")
            if v.cam_to_world is None:
                raise SceneError("the rgbd lifter needs a camera pose", where=v.name, field="cam_to_world")
            d = np.asarray(v.depth, np.float32)
            pts = backproject(d, v.K, v.cam_to_world)
            conf = (np.isfinite(d) & (d > 0)).astype(np.float32)
            views.append(v.replace(points=pts, confidence=conf))
        return Scene(views, dict(scene.objects), scene.name, dict(scene.meta))
