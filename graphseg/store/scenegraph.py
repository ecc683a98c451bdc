"""SceneGraph: a persistent correspondence graph that grows view by view.

A robot takes its photos one at a time. :meth:`SceneGraph.add` segments and
lifts only the new views, matches each against the views the pair rule
(``config.pairs``) selects, adds their nodes and edges, re-contracts, and
recomputes 3D evidence only for the clusters that changed
(:func:`graphseg.store.incremental.update`). Objects keep their ids from one add
to the next; merges and splits are reported with the edges that decided them
(:mod:`graphseg.store.ids`). The store is a folder (:mod:`graphseg.store.layout`):
a killed add leaves it as it was, and two writers are refused.

Examples
--------
>>> import tempfile, os
>>> from graphseg.testing.scenes import box_scene, TWO_BOXES
>>> scene = box_scene(TWO_BOXES, views=3, shape=(48, 64))
>>> d = tempfile.mkdtemp()
>>> sg = SceneGraph.open(os.path.join(d, "store"))
>>> sg.add(scene.views[:2]).generation
1
>>> report = sg.add(scene.views[2])
>>> sg.view_names, sg.object_ids == list(range(1, sg.result().num_objects + 1))
(['000', '001', '002'], True)
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..config import Config
from ..parallel import backend_map
from ..result import Result
from ..scene import Matches, Scene, SceneError, View
from .ids import assign_ids, deciding_edges, operation_edges
from .incremental import MASK_BITS, Snapshot, ViewData, prepare_view, update
from .layout import (
    StoreError,
    StoreLock,
    collect_garbage,
    commit,
    create_store,
    is_store,
    pair_key,
    read_pairs,
    read_pointer,
    read_state,
    read_view,
    write_file,
    write_json,
    write_pairs,
    write_view,
    written,
)

__all__ = ["SceneGraph", "AddReport", "PER_VIEW_LIFTERS", "renumber_result"]

#: Lifters that lift each view from that view alone: a new view is lifted, the others are kept.
#: Any other lifter (``sfm``, ``dust3r``, ``da3``) estimates all views together, so every add
#: lifts every view again; views whose points changed are segmented, matched and added anew.
PER_VIEW_LIFTERS = frozenset({"given", "rgbd", "precomputed-points", "precomputed"})


@dataclass
class AddReport:
    """What :meth:`SceneGraph.add` did.

    Attributes
    ----------
    generation : int
        The store's generation after the add.
    added, skipped, replaced : list of str
        Views added; views already in the store with the same content (not
        added again); views whose points a scene-level lifter changed (added anew).
    events : list of dict
        Merges, splits, new and dropped objects (see :mod:`graphseg.store.ids`),
        with ``edges`` (the deciding edges) or ``reason``.
    num_objects : int
    matched : list of (str, str)
        The view pairs matched by this add.
    recomputed : dict
        Per stage and criterion: edges reused from the last generation and edges computed.
    timings : dict
        Seconds per step.
    warnings : list of str
    """

    generation: int
    added: list[str]
    skipped: list[str]
    replaced: list[str]
    events: list[dict[str, Any]]
    num_objects: int
    matched: list[tuple[str, str]] = field(default_factory=list)
    recomputed: dict[str, Any] = field(default_factory=dict)
    timings: dict[str, float] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)


def renumber_result(result: Result, new_of_old: np.ndarray, object_ids: Sequence[int]) -> Result:
    """``result`` with object ``k`` renamed ``new_of_old[k]`` (a permutation of ``1..K``; 0 stays 0).

    ``object_ids`` (the persistent id of every new compact id) is stored in
    ``info["object_ids"]``. Labels, masks, clouds and the graphs' ``object``
    columns are renumbered; the inputs are not modified.

    Examples
    --------
    >>> from graphseg.method.segment import segment
    >>> from graphseg.testing.scenes import two_boxes_scene
    >>> r = segment(*two_boxes_scene())
    >>> s = renumber_result(r, np.array([0, 2, 1]), [5, 7])
    >>> [int(np.sum(s.labels[0] == 2)) == int(np.sum(r.labels[0] == 1)), s.info["object_ids"]]
    [True, [5, 7]]
    """
    from ..graphs import PointSets

    lut = np.asarray(new_of_old, np.int64)
    k = result.num_objects
    old_of_new = np.zeros(k + 1, np.int64)
    old_of_new[lut[1:]] = np.arange(1, k + 1)
    ps = result.object_points
    sizes = ps.sizes()
    pts, cols, ptr = [], [], [0]
    for j in range(1, k + 1):
        o = old_of_new[j] - 1
        pts.append(ps.points[ps.ptr[o] : ps.ptr[o + 1]])
        if ps.colors is not None:
            cols.append(ps.colors[ps.ptr[o] : ps.ptr[o + 1]])
        ptr.append(ptr[-1] + int(sizes[o]))
    points = np.concatenate(pts) if pts else ps.points[:0]
    colors = (np.concatenate(cols) if cols else ps.colors[:0]) if ps.colors is not None else None
    graphs = []
    for g in result.graphs:
        h = g.copy()
        if "object" in h.node_attr:
            h.node_attr["object"] = lut[np.asarray(h.node_attr["object"], np.int64)]
        graphs.append(h)
    info = dict(result.info)
    info["object_ids"] = [int(x) for x in object_ids]
    return Result(
        labels=[lut[np.asarray(lab, np.int64)].astype(np.int32) for lab in result.labels],
        mask_view=result.mask_view.copy(),
        mask_id=result.mask_id.copy(),
        mask_object=lut[result.mask_object],
        object_points=PointSets(points, np.asarray(ptr, np.int64), colors),
        graphs=graphs,
        config=result.config,
        view_names=list(result.view_names),
        background=result.background,
        info=info,
    )


def _content_key(view: View) -> str:
    """A digest of what a view holds (its images, depth, points, camera)."""
    import hashlib

    h = hashlib.sha1()
    for a in (view.rgb, view.depth, view.points, view.K, view.cam_to_world):
        if a is None:
            h.update(b"-")
        else:
            arr = np.ascontiguousarray(np.asarray(a))
            h.update(str((arr.dtype.str, arr.shape)).encode())
            h.update(arr.tobytes())
    return h.hexdigest()


def _as_views(item: Any, *, views: Any = None, step: Any = None, num_views: Any = None) -> tuple[list[View], dict[int, str], list[str]]:
    """Views from a Scene, a View, a list of them, a scene folder or a photo; their objects; their inputs."""
    if isinstance(item, Scene):
        return list(item.views), dict(item.objects), []
    if isinstance(item, View):
        return [item], {}, []
    if isinstance(item, (str, os.PathLike)):
        p = Path(item)
        if p.is_file():
            from ..io.images import read_rgb

            return [View(p.stem, read_rgb(p))], {}, [str(p)]
        from ..io import detect_format, load_scene

        scene = load_scene(p, format=detect_format(p), views=views, step=step, num_views=num_views)
        return list(scene.views), dict(scene.objects), [str(p)]
    if isinstance(item, (list, tuple)):
        out: list[View] = []
        objects: dict[int, str] = {}
        inputs: list[str] = []
        for x in item:
            v, o, i = _as_views(x, views=views, step=step, num_views=num_views)
            out += v
            objects.update(o)
            inputs += i
        return out, objects, inputs
    raise TypeError(f"expected a Scene, a View, a list of them, a scene folder or an image file (got {type(item).__name__})")


class _LazyMatches(Mapping[tuple[int, int], Matches]):
    """Matches keyed by index pairs ``(i, j)``, ``i < j``, read from the store only when a criterion asks.

    A local criterion reads the matches of the new pairs only, so an add does
    not load the matches of every old pair.
    """

    def __init__(self, keys: dict[tuple[int, int], tuple[tuple[int, int], bool]], fetch: Any) -> None:
        self._keys = keys
        self._fetch = fetch
        self._cache: dict[tuple[int, int], Matches] = {}

    def __getitem__(self, pair: tuple[int, int]) -> Matches:
        if pair not in self._cache:
            key, swap = self._keys[pair]
            m = self._fetch(key)
            self._cache[pair] = Matches(m.xy_j, m.xy_i, m.certainty) if swap else m
        return self._cache[pair]

    def __iter__(self) -> Iterator[tuple[int, int]]:
        return iter(self._keys)

    def __len__(self) -> int:
        return len(self._keys)


def _name_of(spec: Any, default: str) -> str:
    if spec is None:
        return default
    return spec if isinstance(spec, str) else str(getattr(spec, "name", None) or type(spec).__name__)


@dataclass
class _Add:
    """What one :meth:`SceneGraph.add` carries from step to step."""

    progress: bool = False
    timings: dict[str, float] = field(default_factory=dict)
    gt_names: dict[int, str] = field(default_factory=dict)
    inputs: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    entries: dict[str, Any] = field(default_factory=dict)
    keys: dict[str, str] = field(default_factory=dict)
    recorded_lifter: str = ""
    cfg: Any = None
    backends: dict[str, Any] = field(default_factory=dict)
    old_order: list[str] = field(default_factory=list)
    old_data: dict[str, ViewData] = field(default_factory=dict)
    lifted: list[View] = field(default_factory=list)
    replaced: list[str] = field(default_factory=list)
    relifted: list[View] = field(default_factory=list)
    prepared: dict[str, ViewData] = field(default_factory=dict)
    next_uid: int = 0
    all_data: list[ViewData] = field(default_factory=list)
    old_pairs: dict[tuple[int, int], Any] = field(default_factory=dict)
    new_pairs: dict[tuple[int, int], Matches] = field(default_factory=dict)
    active: list[tuple[int, int]] = field(default_factory=list)
    matched: list[tuple[str, str]] = field(default_factory=list)
    num_matches: int = 0
    evidence: Mapping[tuple[int, int], Matches] = field(default_factory=dict)
    previous: Snapshot | None = None
    up: Any = None


@contextmanager
def _timed(job: _Add, step: str) -> Iterator[None]:
    t = time.perf_counter()
    yield
    job.timings[step] = time.perf_counter() - t


class SceneGraph:
    """A persistent scene: views, their masks, points and matches, the graph, the objects and their ids.

    Open (or create) one with :meth:`open`; :meth:`add` adds views; :meth:`result`
    is the current :class:`~graphseg.result.Result`. See the module docstring and
    ``docs/store.md``.
    """

    def __init__(self, root: Path, pointer: dict[str, Any], state: dict[str, Any]) -> None:
        self.root = root
        self._pointer = pointer
        self._state = state
        self._views: dict[int, ViewData] = {}
        self._pairs: dict[str, dict[str, Matches]] = {}
        self._result: Result | None = None

    # ------------------------------------------------------------------ opening
    @classmethod
    def open(cls, path: str | os.PathLike[str], config: Config | None = None, *, create: bool = True, inputs: Sequence[str | os.PathLike[str]] = ()) -> SceneGraph:
        """Open the store at ``path``, or create an empty one.

        Parameters
        ----------
        path : path-like
            A store folder, or (``create``) a path that does not exist.
        config : Config, optional
            For a new store (default ``Config()``); for an existing
            one it must equal the store's configuration.
        create : bool, keyword-only
        inputs : list of path-like, keyword-only
            Inputs of the command: a new store may not lie in one.

        Raises
        ------
        StoreError
            One line: no store there, an existing folder that is no store, a
            format version this graphseg does not read, another configuration.
        """
        from ..output import read_marker

        p = Path(os.path.abspath(path))
        where = str(path)
        if is_store(p):
            marker = read_marker(p)
            if marker is None or marker.get("kind") != "store":
                raise StoreError("has a store.json but no graphseg store marker (.graphseg-output); refusing to use it", where=where, field="store")
            pointer = read_pointer(p)
            state = read_state(p, pointer)
            sg = cls(p, pointer, state)
            if config is not None:
                want = config.to_dict()
                if want != state["config"]:
                    diff = sorted(k for k in set(want) | set(state["config"]) if want.get(k) != state["config"].get(k))
                    raise StoreError(f"was created with another configuration (differs in {', '.join(diff)}); open it without one or use a new store", where=where, field="config")
            return sg
        if os.path.lexists(p):
            raise StoreError("exists and is not a graphseg store (choose a new folder)", where=where, field="store")
        if not create:
            raise StoreError("no such store", where=where, field="store")
        cfg = config or Config()
        root = create_store(p, cfg.to_dict(), inputs=inputs)
        pointer = read_pointer(root)
        return cls(root, pointer, read_state(root, pointer))

    # ------------------------------------------------------------------ state
    @property
    def config(self) -> Config:
        """The store's configuration (fixed when it was created)."""
        try:
            return Config.model_validate(self._state["config"])
        except ValueError as err:  # pydantic's ValidationError: name a plugin that is not installed here
            from ..result import missing_plugin

            missing = missing_plugin(self._state["config"])
            if missing:
                raise StoreError(missing, where=str(self.root), field="config") from err
            raise

    @property
    def generation(self) -> int:
        """How many adds the store has committed."""
        return int(self._state["generation"])

    @property
    def name(self) -> str:
        return str(self._state.get("name") or self.root.name)

    @property
    def view_names(self) -> list[str]:
        """The views, in the order they were added."""
        return [str(v["name"]) for v in self._state["views"]]

    @property
    def object_ids(self) -> list[int]:
        """The persistent id of every object of :meth:`result` (object ``k`` has ``object_ids[k - 1]``)."""
        return [int(x) for x in self._state.get("object_ids", [])]

    @property
    def objects(self) -> dict[int, list[tuple[str, int]]]:
        """Persistent object id -> its masks ``(view name, mask id)``."""
        names = {int(v["uid"]): str(v["name"]) for v in self._state["views"]}
        out: dict[int, list[tuple[str, int]]] = {int(p): [] for p in self.object_ids}
        for uid, pid in zip(self._state["mask_uid"], self._state["mask_pid"]):
            if pid:
                out.setdefault(int(pid), []).append((names[int(uid) >> MASK_BITS], int(uid) & ((1 << MASK_BITS) - 1)))
        return out

    @property
    def history(self) -> list[dict[str, Any]]:
        """One entry per add: its generation, the views added, and its events (merges, splits, ...)."""
        return list(self._state["history"])

    @property
    def lifter(self) -> str | None:
        """The lifter of the store's views (``given`` when they came with points; None before the first add)."""
        value = self._state.get("lifter")
        return None if value is None else str(value)

    @property
    def pairs(self) -> list[tuple[str, str]]:
        """The view pairs whose matches count now (the pair rule's selection), in the order they were matched."""
        names = {int(v["uid"]): str(v["name"]) for v in self._state["views"]}
        return [(names[int(p["a"])], names[int(p["b"])]) for p in self._state["pairs"] if p.get("active")]

    def __repr__(self) -> str:
        return f"SceneGraph({str(self.root)!r}, generation={self.generation}, views={len(self._state['views'])}, objects={len(self.object_ids)})"

    @property
    def ground_truth_names(self) -> dict[int, str]:
        """Ground-truth object names of the views added (from their scenes)."""
        return {int(k): str(v) for k, v in (self._state.get("objects") or {}).items()}

    def _reload(self) -> None:
        pointer = read_pointer(self.root)
        if pointer["generation"] != self._pointer["generation"] or pointer["state"] != self._pointer["state"]:
            self._pointer = pointer
            self._state = read_state(self.root, pointer)
            self._result = None

    def view_data(self, name: str, *, masks: bool = False, full: bool = False) -> ViewData:
        """The stored data of one view.

        By default without the segmenter's masks (``masks``) and without the
        view's depth and ground truth (``full``), which an add does not read;
        those views are kept in memory for the next add.
        """
        for entry in self._state["views"]:
            if entry["name"] == name:
                uid = int(entry["uid"])
                if masks or full or uid not in self._views:
                    data = read_view(self.root, entry["file"], masks=masks, full=full)
                    if not (masks or full):
                        self._views[uid] = data
                    return data
                return self._views[uid]
        raise KeyError(f"no view {name!r} in the store; views: {', '.join(self.view_names) or 'none'}")

    def scene(self) -> Scene:
        """The stored views as a :class:`~graphseg.scene.Scene` (points, depth and ground truth, as stored)."""
        views = [self.view_data(n, full=True).view for n in self.view_names]
        if not views:
            raise StoreError("the store has no views yet", where=str(self.root), field="views")
        return Scene(views, self.ground_truth_names, self.name, {"source": str(self.root), "format": "store", "lifter": self._state.get("lifter")})

    def matches(self) -> dict[tuple[str, str], Matches]:
        """The stored matches of every active pair, keyed by the two view names in the order they were matched."""
        names = {int(v["uid"]): str(v["name"]) for v in self._state["views"]}
        out = {}
        for p in self._state["pairs"]:
            if p.get("active"):
                out[(names[int(p["a"])], names[int(p["b"])])] = self._pair(p)
        return out

    def _pair(self, entry: dict[str, Any]) -> Matches:
        rel, key = str(entry["file"]), str(entry["key"])
        if rel not in self._pairs:
            self._pairs[rel] = read_pairs(self.root, rel)
        if key not in self._pairs[rel]:
            raise StoreError(f"no matches {key} (the store is incomplete)", where=str(self.root / rel), field="pairs")
        return self._pairs[rel][key]

    def result(self) -> Result:
        """The current :class:`~graphseg.result.Result` (objects numbered ``1..K`` in the order of their persistent ids).

        ``info["object_ids"]`` lists the persistent ids, ``info["store"]`` the
        generation and the events of the last add.

        Raises
        ------
        StoreError
            When the store has no views yet.
        """
        if self._result is None:
            rel = self._pointer.get("result")
            if not rel:
                raise StoreError("the store has no views yet (graphseg add STORE SCENE)", where=str(self.root), field="views")
            from .layout import _inside

            path = _inside(self.root, str(rel), str(self.root), "result")
            if not path.is_file():
                raise StoreError("file not found (the store is incomplete)", where=str(path), field="result")
            r = Result.load(path)
            r.info["object_ids"] = self.object_ids
            r.info["store"] = {"path": str(self.root), "generation": self.generation, "events": (self.history[-1]["events"] if self.history else [])}
            self._result = r
        return self._result

    def suggest(self, candidates: Any = None, *, num_candidates: int = 24, seed: Any = None, **options: Any) -> list[Any]:
        """Rank candidate camera poses for the next view (:func:`graphseg.nbv.suggest_views` on the store).

        Parameters
        ----------
        candidates : array_like ``[C, 4, 4]``, optional
            ``cam_to_world`` poses; default: sampled around the scene.
        num_candidates : int, keyword-only
        seed : keyword-only
        **options
            Further keywords of :func:`~graphseg.nbv.suggest_views` (``weights``, ``band``, ...).

        Returns
        -------
        list of graphseg.nbv.ViewScore
            Best first.
        """
        from ..nbv import suggest_views

        return suggest_views(self.scene(), self.result(), candidates, num_candidates=num_candidates, seed=seed, **options)

    # ------------------------------------------------------------------ adding
    def add(
        self,
        views: Any,
        *,
        segmenter: Any = None,
        matcher: Any = None,
        lifter: Any = None,
        features: Any = None,
        masks: Sequence[Any] | None = None,
        select: dict[str, Any] | None = None,
        progress: bool = False,
    ) -> AddReport:
        """Add views: segment and lift only them, match them against the pairs the rule selects, update the graph.

        Parameters
        ----------
        views : Scene, View, list of View, scene folder or image file (or a list of paths)
        segmenter, matcher, lifter, features : name, class, instance or callable, optional, keyword-only
            Default to the store's ``config.backends``. A per-view lifter
            (``rgbd``, precomputed points, or views with ``points``) lifts only
            the new views; any other lifter lifts every view again.
        masks : list, optional, keyword-only
            The new views' masks instead of the segmenter (one entry per view).
        select : dict, optional, keyword-only
            ``views`` / ``step`` / ``num_views`` for a scene folder.
        progress : bool, keyword-only

        Returns
        -------
        AddReport

        Raises
        ------
        StoreLockedError
            When another process is writing the store.
        SceneError
            For bad views (a name already in the store with other content, no
            depth for the rgbd lifter, ...); the store is unchanged.

        Notes
        -----
        The cost of segmenting and lifting the new views, matching the new
        pairs, one background fit per new view, the criteria on what changed
        (:func:`~graphseg.store.incremental.update`), O(total pixels) for the
        contraction bookkeeping and support rules, and writing the new files.
        """
        with StoreLock(self.root):
            self._reload()
            return self._add(views, segmenter=segmenter, matcher=matcher, lifter=lifter, features=features, masks=masks, select=select or {}, progress=progress)

    def _add(self, items: Any, *, segmenter: Any, matcher: Any, lifter: Any, features: Any, masks: Sequence[Any] | None, select: dict[str, Any], progress: bool) -> AddReport:
        """The add's steps in order: incoming views, lift, segment, match, graph, ids, commit."""
        t0 = time.perf_counter()
        job = _Add(progress=progress)
        new_views, masks = self._incoming(job, items, masks, select)
        if not new_views:
            return AddReport(self.generation, [], job.skipped, [], [], len(self.object_ids), warnings=[f"already in the store: {', '.join(job.skipped)}"])
        with _timed(job, "lift"):
            self._lift(job, new_views, segmenter=segmenter, matcher=matcher, lifter=lifter)
        with _timed(job, "segment"):
            self._segment(job, masks, features)
        with _timed(job, "match"):
            self._match(job)
        with _timed(job, "graph"):
            self._update_graph(job)
        with _timed(job, "ids"):
            res, mask_pid, object_ids, next_pid, events = self._stable_ids(job)
        with _timed(job, "write"):
            gen = self._commit(job, res, mask_pid, object_ids, next_pid, events)
        res.info["store"] = {"path": str(self.root), "generation": gen, "events": events}
        self._result = res
        job.timings["total"] = time.perf_counter() - t0
        warnings = [*res.info.get("warnings", [])]
        if job.skipped:
            warnings.append(f"already in the store: {', '.join(job.skipped)}")
        return AddReport(gen, [v.name for v in job.lifted], job.skipped, job.replaced, events, res.num_objects, job.matched, job.up.recomputed, job.timings, warnings)

    def _incoming(self, job: _Add, items: Any, masks: Sequence[Any] | None, select: dict[str, Any]) -> tuple[list[View], list[Any] | None]:
        """The views to add, checked, without those already stored with the same content."""
        new_views, job.gt_names, job.inputs = _as_views(items, **select)
        if masks is not None and len(masks) != len(new_views):
            raise SceneError(f"expected one mask set per view ({len(new_views)}) (got {len(masks)})", where=str(self.root), field="masks")
        if not new_views:
            raise SceneError("no views to add", where=str(self.root), field="views")
        names = [v.name for v in new_views]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise SceneError(f"view name {dup[0]!r} appears twice among the views to add", where=str(self.root), field="views")
        for v in new_views:
            v.validate()
        job.entries = {str(e["name"]): e for e in self._state["views"]}
        keep_new: list[int] = []
        for i, v in enumerate(new_views):
            e = job.entries.get(v.name)
            if e is None:
                keep_new.append(i)
            elif e.get("key") == _content_key(v):
                job.skipped.append(v.name)
            else:
                raise SceneError("a view of this name with other content is already in the store; rename it", where=v.name, field="name")
        new_views = [new_views[i] for i in keep_new]
        job.keys = {v.name: _content_key(v) for v in new_views}
        return new_views, ([masks[i] for i in keep_new] if masks is not None else None)

    def _lift(self, job: _Add, new_views: list[View], *, segmenter: Any, matcher: Any, lifter: Any) -> None:
        """Lift only the new views for a per-view lifter, every view for a scene-level one."""
        from ..pipeline import backends_for_lifter, lift, resolve_backends

        cfg = self.config
        sub = Scene(new_views, name=self.name)
        if lifter is None and sub.has_points:
            lifter_name = "given"
        else:
            default = cfg.backends.lifter
            if lifter is None and default == "rgbd" and not sub.has_depth:
                default = "sfm"
            lifter_name = _name_of(lifter, default)
        old_lifter = self._state.get("lifter")
        if old_lifter is not None and old_lifter != lifter_name and not (old_lifter in PER_VIEW_LIFTERS and lifter_name in PER_VIEW_LIFTERS):
            raise SceneError(f"the store's views were lifted by {old_lifter!r}; views lifted by {lifter_name!r} cannot join them", where=str(self.root), field="lifter")
        need_lifter = lifter_name != "given"
        backends = resolve_backends(cfg, segmenter=segmenter, matcher=matcher, lifter=(lifter or (lifter_name if need_lifter else None)), need_lifter=need_lifter)
        job.old_order = self.view_names
        job.old_data = {n: self.view_data(n) for n in job.old_order}
        job.recorded_lifter = old_lifter if lifter_name == "given" and old_lifter else lifter_name  # what the state records
        if lifter_name == "given":
            job.lifted = new_views
        elif lifter_name in PER_VIEW_LIFTERS:
            job.lifted = lift(sub, backends["lifter"], cfg).views
        else:  # scene-level lifter: every view is lifted again, together
            raw = [self.view_data(n, full=True).view.replace(points=None, confidence=None) for n in job.old_order] + new_views
            got = {v.name: v for v in lift(Scene(raw, name=self.name), backends["lifter"], cfg).views}
            missing = [v.name for v in raw if v.name not in got]
            if missing:
                raise SceneError(f"the lifter could not place view(s) {', '.join(missing)}; nothing was added", where=str(self.root), field="lifter")
            job.replaced = [n for n in job.old_order if not np.array_equal(np.asarray(got[n].points), np.asarray(job.old_data[n].view.points), equal_nan=True)]
            job.relifted = [got[n] for n in job.replaced]
            job.lifted = [got[v.name] for v in new_views]
        job.cfg = cfg.for_lifter(lifter_name)
        job.backends = backends_for_lifter(backends, cfg, lifter_name, segmenter=segmenter, matcher=matcher)

    def _segment(self, job: _Add, masks: list[Any] | None, features: Any) -> None:
        """Segment and prepare the new (and replaced) views, each with a new mask uid."""
        from ..pipeline import progress_bar, resolve_backend

        todo = [*job.lifted, *job.relifted]
        todo_masks: list[Any] = [*(masks if masks is not None else [None] * len(job.lifted)), *([None] * len(job.relifted))]
        feats = None
        if "features" in job.cfg.requires():
            feats = resolve_backend("features", features or job.cfg.backends.features, job.cfg)
        job.next_uid = int(self._state["next_uid"])
        seg = job.backends["segmenter"]
        need = [i for i, m in enumerate(todo_masks) if m is None]
        segmented = backend_map(seg, seg, [todo[i] for i in need], wrap=lambda it: progress_bar(it, "segment", job.progress, total=len(need)))  # a classical segmenter: on several processes
        for i, m in zip(need, segmented):
            todo_masks[i] = m
        for v, m in zip(todo, todo_masks):
            job.prepared[v.name] = prepare_view(v, m, job.cfg, uid=job.next_uid, features=None if feats is None else np.asarray(feats(v)))
            job.next_uid += 1
        order = job.old_order + [v.name for v in job.lifted]
        data = [job.prepared.get(n, job.old_data.get(n)) for n in order]
        job.all_data = [d for d in data if d is not None]
        assert len(job.all_data) == len(data)

    def _match(self, job: _Add) -> None:
        """The pair rule over all views; match the pairs not matched yet; the evidence, read lazily."""
        from ..geometry import scene_scale, select_pairs
        from ..pipeline import progress_bar

        all_data = job.all_data
        uids = {d.uid for d in all_data}
        job.old_pairs = {(int(p["a"]), int(p["b"])): p for p in self._state["pairs"] if int(p["a"]) in uids and int(p["b"]) in uids}
        if "matches" not in job.cfg.requires():
            return
        by_set = {frozenset(k): k for k in job.old_pairs}
        poses = [d.view.cam_to_world for d in all_data]
        scale = scene_scale([d.view.points for d in all_data], poses) if all(p is not None for p in poses) else None
        pc = job.cfg.pairs
        idx_pairs = select_pairs(poses, mode=pc.mode, max_rotation=pc.max_rotation, max_translation=pc.max_translation, translation_scale=pc.translation_scale, scale=scale, auto_max_views=pc.auto_max_views)
        todo_pairs = []
        for i, j in idx_pairs:
            a, b = (i, j) if all_data[i].name <= all_data[j].name else (j, i)
            key = (all_data[a].uid, all_data[b].uid)
            if frozenset(key) in by_set:
                key = by_set[frozenset(key)]
            else:
                todo_pairs.append((a, b, key))
            job.active.append(key)
        matcher = job.backends["matcher"]
        one = lambda t: matcher(all_data[t[0]].view, all_data[t[1]].view)  # noqa: E731
        got = backend_map(matcher, one, todo_pairs, wrap=lambda it: progress_bar(it, "match", job.progress, total=len(todo_pairs)))
        for (a, b, key), m in zip(todo_pairs, got):
            job.new_pairs[key] = m
            job.matched.append((all_data[a].name, all_data[b].name))
        index = {d.uid: i for i, d in enumerate(all_data)}
        pair_index: dict[tuple[int, int], tuple[tuple[int, int], bool]] = {}
        for key in job.active:
            i, j = index[key[0]], index[key[1]]
            pair_index[(i, j) if i < j else (j, i)] = (key, i > j)
            job.num_matches += len(job.new_pairs[key]) if key in job.new_pairs else int(job.old_pairs[key].get("n", -1))
        new_pairs, old_pairs = job.new_pairs, job.old_pairs

        def fetch(key: tuple[int, int]) -> Matches:
            return new_pairs[key] if key in new_pairs else self._pair(old_pairs[key])

        job.evidence = _LazyMatches(pair_index, fetch)

    def _update_graph(self, job: _Add) -> None:
        """The graph, reusing what did not change (:func:`~graphseg.store.incremental.update`)."""
        job.previous = self._snapshot()
        was_active = {(int(p["a"]), int(p["b"])) for p in self._state["pairs"] if p.get("active")}
        changed = was_active ^ set(job.active)
        known = all(int(job.old_pairs[k].get("n", -1)) >= 0 for k in job.active if k not in job.new_pairs)
        job.up = update(job.all_data, job.evidence, job.cfg, previous=job.previous, changed_pairs=changed, name=self.name, num_matches=job.num_matches if known else None)

    def _stable_ids(self, job: _Add) -> tuple[Result, np.ndarray, list[int], int, list[dict[str, Any]]]:
        """Stable object ids, the result renumbered to them, and the merge and split events explained."""
        res = job.up.result
        old_uid = np.asarray(self._state["mask_uid"], np.int64)
        old_pid = np.asarray(self._state["mask_pid"], np.int64)
        pid, events, next_pid = assign_ids(old_uid, old_pid, job.up.mask_uid, res.mask_object, int(self._state["next_pid"]), res.num_objects)
        rank = np.zeros(pid.size, np.int64)
        order_k = np.argsort(pid[1:], kind="stable") + 1
        rank[order_k] = np.arange(1, pid.size)
        object_ids = [int(x) for x in pid[order_k]]
        res = renumber_result(res, rank, object_ids)
        mask_pid = pid[np.asarray(job.up.result.mask_object, np.int64)]  # before renumbering: compact ids of update()
        self._explain(events, res, job.up, mask_pid, old_uid, old_pid, job.previous, [d.name for d in job.all_data])
        return res, mask_pid, object_ids, next_pid, events

    def _commit(self, job: _Add, res: Result, mask_pid: np.ndarray, object_ids: list[int], next_pid: int, events: list[dict[str, Any]]) -> int:
        """Write the new files, then switch the pointer (the commit); collect what no generation needs."""
        state = self._state
        gen = self.generation + 1
        with written(self.root) as files:
            view_entries = []
            for d in job.all_data:
                if d.name in job.prepared:
                    files.append(write_view(self.root, d))
                    view_entries.append({"name": d.name, "uid": d.uid, "file": files[-1], "key": job.keys.get(d.name) or _content_key(d.view)})
                else:
                    view_entries.append(job.entries[d.name])
            active = set(job.active)
            kept = {d.uid for d in job.all_data}
            pair_entries = [{**p, "active": key in active} for key, p in job.old_pairs.items() if key[0] in kept and key[1] in kept]
            if job.new_pairs:
                files.append(write_pairs(self.root, gen, job.new_pairs))
                pair_entries += [{"a": k[0], "b": k[1], "file": files[-1], "key": pair_key(*k), "n": len(m), "active": True} for k, m in job.new_pairs.items()]
            result_rel = f"generations/{gen:06d}.result.npz"
            write_file(self.root / result_rel, res.save)
            files.append(result_rel)
            entry = {"generation": gen, "added": [v.name for v in job.lifted], "replaced": job.replaced, "matched": [list(p) for p in job.matched], "events": events}
            new_state = {
                **state,
                "generation": gen,
                "views": view_entries,
                "pairs": pair_entries,
                "mask_uid": job.up.mask_uid.tolist(),
                "mask_pid": mask_pid.tolist(),
                "object_ids": object_ids,
                "next_uid": job.next_uid,
                "next_pid": next_pid,
                "lifter": job.recorded_lifter,
                "objects": {**(state.get("objects") or {}), **{str(k): v for k, v in job.gt_names.items()}},
                "history": [*state["history"], entry],
                "inputs": job.inputs,
            }
            state_rel = f"generations/{gen:06d}.state.json"
            write_json(self.root / state_rel, new_state)
            files.append(state_rel)
        commit(self.root, gen, state_rel, result_rel)
        old_state, old_pointer = self._state, self._pointer
        self._state = new_state
        self._pointer = read_pointer(self.root)
        keep = self._references(new_state) | self._references(old_state) | {str(old_pointer["state"])}
        if old_pointer.get("result"):
            keep.add(str(old_pointer["result"]))
        collect_garbage(self.root, keep)
        for d in job.all_data:  # kept for the next add, without what it does not read
            self._views[d.uid] = replace(d, masks=None, view=d.view.replace(depth=None, instances=None))
        if job.new_pairs:
            self._pairs[f"pairs/M{gen:06d}.npz"] = {pair_key(*key): m for key, m in job.new_pairs.items()}
        return gen

    @staticmethod
    def _references(state: dict[str, Any]) -> set[str]:
        refs = {str(v["file"]) for v in state["views"]} | {str(p["file"]) for p in state["pairs"]}
        g = int(state["generation"])
        refs |= {f"generations/{g:06d}.state.json", f"generations/{g:06d}.result.npz"}
        return refs

    def _snapshot(self) -> Snapshot | None:
        if not self._state["views"] or not self._pointer.get("result"):
            return None
        r = self.result()
        uids = np.array([int(v["uid"]) for v in self._state["views"]], np.int64)
        return Snapshot(r.graphs, uids, [(int(p["a"]), int(p["b"])) for p in self._state["pairs"] if p.get("active")])

    def _explain(self, events: list[dict[str, Any]], res: Result, up: Any, mask_pid: np.ndarray, old_uid: np.ndarray, old_pid: np.ndarray, previous: Snapshot | None, names_now: list[str]) -> None:
        """Add the deciding edges (or the reason) to merge and split events."""
        old_of = dict(zip(old_uid.tolist(), old_pid.tolist()))
        new_of = dict(zip(up.mask_uid.tolist(), mask_pid.tolist()))
        old_names = self.view_names
        for ev in events:
            if ev["event"] == "merge":
                members = [u for u, p in new_of.items() if p == ev["id"]]
                group = {u: (old_of[u] if old_of.get(u, 0) > 0 else -u - 1) for u in members}
                targets = [ev["id"], *[i for i in ev["ids"] if i != ev["id"]]]
                graphs = [*res.graphs, *operation_edges(res.objects_graph, len(res.graphs))]  # the graph operations' joins too
                edges = deciding_edges(graphs, up.snapshot.view_uids, group, targets, names_now)
            elif ev["event"] == "split" and previous is not None:
                members = [u for u, p in old_of.items() if p == ev["id"]]
                group = {u: (new_of[u] if new_of.get(u, 0) > 0 else -u - 1) for u in members}
                mine = next((p for p in ev["into"] if p == ev["id"]), ev["into"][0])
                targets = [mine, *[i for i in ev["into"] if i != mine]]
                edges = deciding_edges(previous.graphs, previous.view_uids, group, targets, old_names)
            else:
                continue
            if edges is None:
                ev["reason"] = "support: joined or parted by the minimum-support rules (objects.merge_seen / fragments) or by pixels a graph operation moved, not by edges"
            else:
                ev["edges"] = edges
                ev["reason"] = "edges" if ev["event"] == "merge" else "edges of the last generation that joined the parts no longer hold"
