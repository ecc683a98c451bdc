"""The outcome of a GraphSeg run: consistent labels, object clouds, graphs, config.

Examples
--------
>>> from graphseg.method.segment import segment
>>> from graphseg.testing.scenes import two_boxes_scene
>>> r = segment(*two_boxes_scene())
>>> r.num_objects, r.labels[0].dtype
(2, dtype('int32'))
>>> r.object_of(0, 0) in (1, 2)
True
>>> [sorted(set(g.node_attr["object"].tolist())) for g in r.graphs]
[[1, 2], [1, 2]]
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from os import PathLike
from typing import Any

import numpy as np

from .config import Config
from .graphs import CorrespondenceGraph, PointSets, load_native, save_native

__all__ = ["Result"]


@dataclass
class Result:
    """Everything a run produced.

    Attributes
    ----------
    labels : list of int32 ``[H, W]``
        Per view: 0 = background / no object, ``1..K`` objects (same id in every view).
    mask_view, mask_id, mask_object : int64 ``[M]``
        Every surviving input mask and the object it belongs to.
    object_points : PointSets
        CSR per-object world points ``[P, 3]`` and colours (node ``k`` = object ``k + 1``).
    graphs : list of CorrespondenceGraph
        One per stage (any number), with that stage's edges: ``graphs[0]`` is
        the mask graph, ``graphs[k]`` the super graph after stage ``k - 1``'s
        contraction. Every node carries its final object id in the node column
        ``object`` (``1..K``). ``graph_2d`` / ``graph_3d`` are ``graphs[0]`` /
        ``graphs[1]``.
    config : Config
    view_names : list of str
    background : list of bool ``[H, W]`` or None
    info : dict
        Diagnostics: background plane, per-stage edge counts and thresholds, timings.
    """

    labels: list[np.ndarray]
    mask_view: np.ndarray
    mask_id: np.ndarray
    mask_object: np.ndarray
    object_points: PointSets
    graphs: list[CorrespondenceGraph]
    config: Config
    view_names: list[str]
    background: list[np.ndarray] | None = None
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def num_objects(self) -> int:
        return self.object_points.num_nodes

    @property
    def num_stages(self) -> int:
        return len(self.graphs)

    @property
    def graph_2d(self) -> CorrespondenceGraph:
        """``graphs[0]``: the mask graph with the first stage's edges."""
        return self.graphs[0]

    @property
    def graph_3d(self) -> CorrespondenceGraph | None:
        """``graphs[1]`` (None with a single stage)."""
        return self.graphs[1] if len(self.graphs) > 1 else None

    def _view_index(self, view: int | str) -> int:
        if isinstance(view, str):
            if view not in self.view_names:
                raise KeyError(f"unknown view {view!r}; views: {', '.join(self.view_names)}")
            return self.view_names.index(view)
        if not 0 <= view < len(self.view_names):
            raise IndexError(f"view {view} out of range [0, {len(self.view_names)})")
        return int(view)

    def object_of(self, view: int | str, mask_id: int) -> int:
        """Object id (``1..K``) of input mask ``mask_id`` of ``view``; 0 if the mask was dropped."""
        v = self._view_index(view)
        hit = np.flatnonzero((self.mask_view == v) & (self.mask_id == mask_id))
        return int(self.mask_object[hit[0]]) if hit.size else 0

    def members(self, obj: int) -> list[tuple[int, int]]:
        """The ``(view, mask_id)`` masks forming object ``obj``."""
        sel = self.mask_object == obj
        return list(zip(self.mask_view[sel].tolist(), self.mask_id[sel].tolist()))

    def object_map(self) -> dict[int, list[tuple[int, int]]]:
        """Object id -> member masks."""
        return {k: self.members(k) for k in range(1, self.num_objects + 1)}

    def object_cloud(self, obj: int) -> tuple[np.ndarray, np.ndarray | None]:
        """World points ``[P, 3]`` and colours ``[P, 3]`` (uint8) of object ``obj``."""
        if not 1 <= obj <= self.num_objects:
            raise IndexError(f"object {obj} out of range [1, {self.num_objects}]")
        a, b = int(self.object_points.ptr[obj - 1]), int(self.object_points.ptr[obj])
        cols = None if self.object_points.colors is None else self.object_points.colors[a:b]
        return self.object_points.points[a:b], cols

    # ----------------------------------------------------------------- files
    def save(self, path: str | PathLike[str]) -> None:
        """Write the result as one native graph file (``.npz``; see :mod:`graphseg.graphs.native`)."""
        arrays: dict[str, np.ndarray] = {
            "mask_view": self.mask_view,
            "mask_id": self.mask_id,
            "mask_object": self.mask_object,
            "object_points": self.object_points.points.astype(np.float32),
            "object_ptr": self.object_points.ptr,
        }
        if self.object_points.colors is not None:
            arrays["object_colors"] = self.object_points.colors
        for v, lab in enumerate(self.labels):
            arrays[f"labels_{v}"] = lab.astype(np.uint16 if lab.max(initial=0) < 2**16 else np.int32)
        if self.background is not None:
            for v, bg in enumerate(self.background):
                arrays[f"background_{v}"] = bg
        meta = {
            "kind": "graphseg-result",
            "config": self.config.to_dict(),
            "view_names": self.view_names,
            "info": json.loads(json.dumps(self.info, default=_jsonable)),
            "num_stages": len(self.graphs),
        }
        save_native(path, {f"stage{s}": g for s, g in enumerate(self.graphs)}, arrays, meta)

    @classmethod
    def load(cls, path: str | PathLike[str]) -> Result:
        """Read a file written by :meth:`save`."""
        f = load_native(path)
        if f.meta.get("kind") != "graphseg-result":
            raise ValueError(f"{path}: not a graphseg result file")
        n_views = len(f.meta["view_names"])
        a = f.arrays
        bg = [a[f"background_{v}"].astype(bool) for v in range(n_views)] if "background_0" in a else None
        return cls(
            labels=[a[f"labels_{v}"].astype(np.int32) for v in range(n_views)],
            mask_view=a["mask_view"],
            mask_id=a["mask_id"],
            mask_object=a["mask_object"],
            object_points=PointSets(a["object_points"].astype(np.float64), a["object_ptr"], a.get("object_colors")),
            graphs=[f.graphs[f"stage{s}"] for s in range(f.meta["num_stages"])],
            config=Config.model_validate(f.meta["config"]),
            view_names=list(f.meta["view_names"]),
            background=bg,
            info=f.meta.get("info", {}),
        )


def _jsonable(x: Any) -> Any:
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    return str(x)
