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

__all__ = ["Result", "jsonable"]


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
    objects_graph : CorrespondenceGraph or None
        The last graph of the run (:class:`~graphseg.graphs.lineage.Lineage`):
        mask fragments as nodes, with the steps after the last contraction
        (split, joins, snap, minimum support) as edges and cuts, and each
        node's ``object``. Its live components painted with its masks
        (:func:`~graphseg.graphs.lineage.paint_objects`) are ``labels``
        except the pixels the pixel refiners moved
        (``info["refiners"]``). None for results written before it existed.
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
    objects_graph: CorrespondenceGraph | None = None

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
        """Write the result as one native graph file (``.npz``; see :mod:`graphseg.graphs.native`).

        The file leaves out the wall-clock timings of ``info`` (``timings``,
        ``seconds``; ``run.json`` of an output folder keeps them), so the same
        result gives the same bytes.
        """
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
            "info": _without_timings(json.loads(json.dumps(self.info, default=jsonable))),
            "num_stages": len(self.graphs),
            "objects_graph": self.objects_graph is not None,
        }
        graphs = {f"stage{s}": g for s, g in enumerate(self.graphs)}
        if self.objects_graph is not None:
            graphs["objects"] = self.objects_graph
        save_native(path, graphs, arrays, meta)

    @classmethod
    def load(cls, path: str | PathLike[str]) -> Result:
        """Read a file written by :meth:`save`.

        Declared array sizes are checked against the file size, a cap and the
        zip-bomb rule (:func:`graphseg.graphs.native.check_npz_sizes`) before
        anything is decompressed or allocated; a corrupt, tampered or
        bomb-like file raises one :class:`~graphseg.scene.SceneError` naming
        the file and the entry.
        """
        from .graphs import GraphValidationError
        from .scene import SceneError

        where = str(path)
        try:
            f = load_native(path)
        except GraphValidationError as err:
            msg = str(err)
            prefix = f"{path}: "
            msg = msg[len(prefix):] if msg.startswith(prefix) else msg
            field, _, rest = msg.partition(": ")
            raise SceneError(rest or msg, where=where, field=field if rest else "file") from err
        field = "meta"
        try:
            if f.meta.get("kind") != "graphseg-result":
                raise SceneError("not a graphseg result file", where=where, field="kind")
            field = "view_names"
            names = f.meta["view_names"]
            if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
                raise SceneError("expected a list of strings", where=where, field=field)
            n_views = len(names)
            a = f.arrays
            for field in ("mask_view", "mask_id", "mask_object", "object_points", "object_ptr"):
                if field not in a:
                    raise SceneError("missing", where=where, field=field)
            m = a["mask_view"].shape
            field = "mask_view"
            if len(m) != 1 or a[field].dtype.kind not in "iu" or (a[field].size and not 0 <= int(a[field].min()) <= int(a[field].max()) < n_views):
                raise SceneError(f"expected int [M] of view indices in [0, {n_views})", where=where, field=field)
            for field in ("mask_id", "mask_object"):
                if a[field].shape != m or a[field].ndim != 1 or a[field].dtype.kind not in "iu":
                    raise SceneError(f"expected int [{m[0] if m else '?'}] like mask_view (got {a[field].dtype} {list(a[field].shape)})", where=where, field=field)
            field = "object_points"
            pts, ptr = a["object_points"], a["object_ptr"]
            if pts.ndim != 2 or pts.shape[1:] != (3,) or pts.dtype.kind != "f":
                raise SceneError(f"expected float [P, 3] (got {pts.dtype} {list(pts.shape)})", where=where, field=field)
            field = "object_ptr"
            if ptr.ndim != 1 or ptr.size < 1 or ptr.dtype.kind not in "iu" or ptr[0] != 0 or ptr[-1] != len(pts) or (np.diff(ptr) < 0).any():
                raise SceneError(f"expected a non-decreasing int [K + 1] from 0 to {len(pts)}", where=where, field=field)
            field = "mask_object"
            if a[field].size and not 0 <= int(a[field].min()) <= int(a[field].max()) <= ptr.size - 1:
                raise SceneError(f"expected object ids in [0, {ptr.size - 1}]", where=where, field=field)
            cols = a.get("object_colors")
            if cols is not None and (cols.shape != pts.shape or cols.dtype != np.uint8):
                raise SceneError(f"expected uint8 {list(pts.shape)} (got {cols.dtype} {list(cols.shape)})", where=where, field="object_colors")
            labels = []
            for v in range(n_views):
                field = f"labels_{v}"
                lab = a[field]
                if lab.ndim != 2 or lab.dtype.kind not in "iu":
                    raise SceneError(f"expected an int label image [H, W] (got {lab.dtype} {list(lab.shape)})", where=where, field=field)
                if lab.size and int(lab.max()) > ptr.size - 1:
                    raise SceneError(f"object id {int(lab.max())} > number of objects {ptr.size - 1}", where=where, field=field)
                labels.append(lab.astype(np.int32))
            bg = None
            if "background_0" in a:
                bg = []
                for v in range(n_views):
                    field = f"background_{v}"
                    if a[field].shape != labels[v].shape:
                        raise SceneError(f"expected {list(labels[v].shape)} like labels_{v} (got {list(a[field].shape)})", where=where, field=field)
                    bg.append(a[field].astype(bool))
            field = "num_stages"
            num_stages = f.meta["num_stages"]
            if not isinstance(num_stages, int) or not 1 <= num_stages <= len(f.graphs):
                raise SceneError(f"expected 1..{len(f.graphs)} (got {num_stages!r})", where=where, field=field)
            graphs = []
            for s in range(num_stages):
                field = f"stage{s}"
                g = f.graphs[field]
                if g.masks is not None and [lab.shape for lab in g.masks] != [lab.shape for lab in labels]:
                    raise SceneError(f"expected {n_views} mask images of the label images' sizes (got {[list(lab.shape) for lab in g.masks]})", where=where, field=field)
                if graphs and g.members["node"].shape != graphs[0].members["node"].shape:
                    raise SceneError(f"expected members for the {graphs[0].members['node'].shape[0]} masks of stage0 (got {g.members['node'].shape[0]})", where=where, field=field)
                graphs.append(g)
            field = "objects"
            objects_graph = f.graphs[field] if f.meta.get("objects_graph") is True else None
            if objects_graph is not None and (objects_graph.masks is None or [lab.shape for lab in objects_graph.masks] != [lab.shape for lab in labels]):
                raise SceneError("expected fragment masks of the label images' sizes", where=where, field=field)
            field = "config"
            try:
                config = Config.model_validate(f.meta["config"])
            except ValueError as err:  # pydantic's ValidationError: name a plugin that is not installed here
                missing = missing_plugin(f.meta["config"])
                if missing:
                    raise SceneError(missing, where=where, field=field) from err
                raise
            field = "info"
            info = f.meta.get("info", {})
            if not isinstance(info, dict):
                raise SceneError("expected an object", where=where, field=field)
            bad = _bad_info(info)
            if bad:
                raise SceneError(f"unexpected {bad[1]}", where=where, field=f"info.{bad[0]}")
        except SceneError:
            raise
        except (KeyError, ValueError, TypeError, IndexError) as err:
            text = str(err).splitlines()[0] if str(err) else type(err).__name__
            raise SceneError(f"corrupt or tampered result file ({type(err).__name__}: {text})", where=where, field=field) from err
        return cls(
            labels=labels,
            mask_view=a["mask_view"].astype(np.int64),
            mask_id=a["mask_id"].astype(np.int64),
            mask_object=a["mask_object"].astype(np.int64),
            object_points=PointSets(pts.astype(np.float64), ptr.astype(np.int64), cols),
            graphs=graphs,
            config=config,
            view_names=list(names),
            background=bg,
            objects_graph=objects_graph,
            info=info,
        )


def missing_plugin(config: Any) -> str | None:
    """The first criterion or contractor of a saved ``config`` (a plain dict) that cannot be loaded here, as a message.

    A result or store written with a plugin (an entry point of
    ``graphseg.edge_adders`` or ``graphseg.contractors``) names it in its
    configuration; read where that plugin is not installed, the message says
    which plugin and how to get it. None when every plugin named loads.

    Examples
    --------
    >>> print(missing_plugin({"stages": [["pixel_match"], [{"probe_x": {"r": 1}}]], "contractor": "star"}))
    edge criterion 'probe_x' is not installed (a plugin: install the package that provides the graphseg.edge_adders entry point 'probe_x')
    >>> missing_plugin({"stages": [["pixel_match"]]}) is None
    True
    """
    from .graphs.registry import contractors, edge_adders
    from .registry import PluginNotFoundError

    if not isinstance(config, dict):
        return None

    def name_of(entry: Any) -> str | None:
        if isinstance(entry, str):
            return entry
        if isinstance(entry, dict) and len(entry) == 1 and isinstance(next(iter(entry)), str):
            return str(next(iter(entry)))
        return None

    wanted = []
    stages = config.get("stages")
    for stage in stages if isinstance(stages, list) else []:
        for entry in stage if isinstance(stage, list) else []:
            wanted.append((edge_adders, name_of(entry)))
    wanted.append((contractors, name_of(config.get("contractor"))))
    for registry, name in wanted:
        if name is None or name == "dino_similarity":  # the old name of dino (migrated when the config is read)
            continue
        try:
            registry.get(name)
        except PluginNotFoundError:
            return str(registry.missing_message(name))
    return None


def _bad_info(info: dict[str, Any]) -> tuple[str, str] | None:
    """The first diagnostic of ``info`` that graphseg reads back and that has the wrong shape, as ``(key, what)``.

    Examples
    --------
    >>> _bad_info({"background": {"plane": [0, 0, 1, 0]}, "warnings": ["w"]}) is None
    True
    >>> _bad_info({"background": {"plane": 3.5}})
    ('background.plane', 'float (expected 4 finite numbers or null)')
    """
    bg = info.get("background")
    if bg is not None and not isinstance(bg, dict):
        return "background", f"{type(bg).__name__} (expected an object)"
    plane = (bg or {}).get("plane")
    if plane is not None and not (
        isinstance(plane, list) and len(plane) == 4 and all(isinstance(x, (int, float)) and not isinstance(x, bool) and np.isfinite(x) for x in plane)
    ):
        return "background.plane", f"{type(plane).__name__} (expected 4 finite numbers or null)"
    for key, kind, words in (("warnings", list, "a list of strings"), ("stages", list, "a list of objects"), ("support", dict, "an object"), ("pipeline", dict, "an object")):
        val = info.get(key)
        if val is not None and not isinstance(val, kind):
            return key, f"{type(val).__name__} (expected {words})"
    if not all(isinstance(w, str) for w in info.get("warnings") or []):
        return "warnings", "entries (expected a list of strings)"
    if not all(isinstance(s, dict) for s in info.get("stages") or []):
        return "stages", "entries (expected a list of objects)"
    dropped = (info.get("support") or {}).get("dropped")
    if dropped is not None and not (isinstance(dropped, int) and not isinstance(dropped, bool)):
        return "support.dropped", f"{type(dropped).__name__} (expected an integer)"
    return None


def _without_timings(x: Any) -> Any:
    """``x`` (parsed JSON) without the keys ``timings`` and ``seconds`` at any depth.

    >>> _without_timings({"a": 1, "timings": {"x": 2}, "stages": [{"seconds": 0.1, "nodes": 3}]})
    {'a': 1, 'stages': [{'nodes': 3}]}
    """
    if isinstance(x, dict):
        return {k: _without_timings(v) for k, v in x.items() if k not in ("timings", "seconds")}
    if isinstance(x, list):
        return [_without_timings(v) for v in x]
    return x


def jsonable(x: Any) -> Any:
    """The ``default`` of :func:`json.dumps` for ``Result.info`` and the store's documents.

    numpy scalars become Python numbers, arrays lists, anything else its ``str``.

    Examples
    --------
    >>> json.dumps({"n": np.int64(3), "a": np.zeros(2), "p": Ellipsis}, default=jsonable)
    '{"n": 3, "a": [0.0, 0.0], "p": "Ellipsis"}'
    """
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    return str(x)
