"""The ``precomputed-points`` lifter (CLI ``--points DIR``): world point maps computed elsewhere.

Point maps (and confidences, cameras) are read from ``folder/VIEW.npz``
(format: :mod:`graphseg.io.precomputed`).

Examples
--------
>>> import tempfile, numpy as np
>>> from graphseg.scene import Scene, View
>>> from graphseg.io.precomputed import write_point_map
>>> with tempfile.TemporaryDirectory() as d:
...     _ = write_point_map(d, "a", np.ones((2, 2, 3), np.float32))
...     lifted = PrecomputedLifter(folder=d)(Scene([View("a", np.zeros((4, 4, 3), np.uint8))]))
>>> lifted.views[0].points.shape
(4, 4, 3)
"""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from ...io.precomputed import apply_point_maps
from ...scene import Scene
from ..options import Backend
from ..precomputed_folders import precomputed_folder

__all__ = ["PrecomputedLifter"]


class PrecomputedLifter(Backend):
    """The ``precomputed-points`` lifter: point maps read from ``folder`` (see :func:`~graphseg.io.precomputed.read_point_map`)."""

    name = "precomputed-points"

    class Options(BaseModel):
        model_config = ConfigDict(extra="forbid")
        folder: str | None = Field(None, description="the point-map folder (required)")

    def __init__(self, options: Any = None, /, **kwargs: Any) -> None:
        super().__init__(options, **kwargs)
        self.folder = precomputed_folder(self.options.folder, "lifter", "points")

    def __call__(self, scene: Scene) -> Scene:
        return apply_point_maps(scene, self.folder)
