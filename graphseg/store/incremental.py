"""The incremental update: views plus cached edges -> the stage graphs, partition and Result.

A store keeps, per view, what depends on that view alone (:class:`ViewData`:
its points, background, composed masks and node table) and, per stage, the
graph it built last time (:class:`Snapshot`). :func:`update` then builds the
same stage graphs as :func:`graphseg.method.segment.segment` would on all the
views, with the same functions (:func:`~graphseg.method.segment.run_stages`
for edge addition and contraction, and
:func:`~graphseg.method.segment.finish_segmentation` from the partition to the
objects), except that a criterion whose edges are *local* is run only where
something changed:

``pixel_match`` (absolute ``tau``, ``area`` or ``pair_hits`` normalisation) on the mask graph
    Its edges between two masks come from the matches of their two views
    only. Edges between masks of views that did not change (no new view, no
    match set added or removed) are copied from the last snapshot; the
    criterion runs on the matches of the view pairs that changed.
``chamfer_3d`` (no ``fragment_ratio``) on any stage
    Its edge between two nodes depends only on the points of their pixels.
    A node is identified by the set of masks it holds; edges between two
    nodes that both existed last time are copied, and the criterion runs on
    the new nodes and the nodes whose bounding box lies within ``sqrt(tau)``
    of one (no other node can be within ``tau`` of them).

Every other criterion (a percentile ``tau``, ``hits`` normalisation, features,
repulsion, ...) depends on the whole view set and runs on the whole stage
graph. Contraction, coarsening and the minimum-support rules always run on the
whole graph (they are cheap; the support rules look at every view). The
partition is the one a batch run over the same views gives, whatever order the
views came in (``tests/store/test_equivalence.py``), for a contractor whose
partition does not depend on the order of the edges (``star``,
``union_find``, ``scipy``: connected components).

Examples
--------
>>> from graphseg.testing.scenes import two_boxes_scene
>>> from graphseg.config import Config
>>> scene, masks, matches = two_boxes_scene()
>>> cfg = Config.preset("paper")
>>> views = [prepare_view(v, m, cfg, uid=i) for i, (v, m) in enumerate(zip(scene.views, masks))]
>>> out = update(views, matches, cfg)
>>> out.result.num_objects, [g.num_nodes for g in out.snapshot.graphs]
(2, [12, 7])
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..config import Config, CriterionSpec
from ..graphs import CorrespondenceGraph, Evidence, mask_node_table
from ..method.masks import compose_masks
from ..method.segment import (
    StageEdges,
    criterion_edges,
    evidence_fields,
    finish_segmentation,
    finite_points,
    run_stages,
    view_masks,
)
from ..published import TAU_3D_PAPER
from ..result import Result
from ..scene import Matches, SceneError, View
from .background import view_background

__all__ = ["ViewData", "Snapshot", "Update", "prepare_view", "node_keys", "local_rule", "update", "MASK_BITS"]

#: A base mask's uid is ``view_uid << MASK_BITS | mask_id``.
MASK_BITS = 24


@dataclass
class ViewData:
    """Everything of one view that depends on that view alone.

    Attributes
    ----------
    view : View
        With world ``points`` (non-finite coordinates set to NaN).
    uid : int
        The view's number in its store (never reused).
    masks : int ``[H, W]`` or bool ``[K, H, W]`` or None
        The segmenter's masks as given (None when read without them).
    background : bool ``[H, W]``
        :func:`~graphseg.store.background.view_background`.
    labels : int32 ``[H, W]``
        The composed masks, ``mask_id + 1`` (0 = none).
    nodes : dict of arrays
        :func:`~graphseg.graphs.graph.mask_node_table` of ``labels`` (``view`` column 0).
    info : dict
        ``compose`` (what :func:`compose_masks` dropped) and ``background``.
    features : float ``[h, w, D]`` or None
        Per-pixel features, when a criterion requires them.
    """

    view: View
    uid: int
    masks: np.ndarray | None
    background: np.ndarray
    labels: np.ndarray
    nodes: dict[str, np.ndarray]
    info: dict[str, Any] = field(default_factory=dict)
    features: np.ndarray | None = None

    @property
    def name(self) -> str:
        return self.view.name


@dataclass
class Snapshot:
    """The stage graphs of the last update and the uids of their views.

    Attributes
    ----------
    graphs : list of CorrespondenceGraph
        One per stage, with that stage's edges (``Result.graphs``).
    view_uids : int64 ``[V]``
        The uid of every view index of the graphs' ``members``.
    pairs : list of (uid_a, uid_b)
        The view pairs whose matches the mask graph's edges came from.
    """

    graphs: list[CorrespondenceGraph]
    view_uids: np.ndarray
    pairs: list[tuple[int, int]] = field(default_factory=list)


@dataclass
class Update:
    """What :func:`update` returns: the result, the new snapshot and what was recomputed."""

    result: Result
    snapshot: Snapshot
    mask_uid: np.ndarray
    recomputed: dict[str, Any]


def _stack(masks: Any, view: View) -> np.ndarray:
    """One view's masks as a label image or a bool stack (checked by :func:`view_masks`)."""
    checked = view_masks(masks, view)
    if isinstance(masks, np.ndarray):
        return masks  # a label image or a bool stack, as given
    out = [np.asarray(a).astype(bool) for a in checked]
    return np.stack(out) if out else np.zeros((0, *view.shape), bool)


def prepare_view(view: View, masks: Any, config: Config, *, uid: int, features: np.ndarray | None = None) -> ViewData:
    """Background, composed masks and node table of one view (what depends on it alone).

    Parameters
    ----------
    view : View
        With ``points``.
    masks : list of bool ``[H, W]``, bool ``[K, H, W]`` or int ``[H, W]``
        The segmenter's output for the view.
    config : Config
    uid : int, keyword-only
    features : optional, keyword-only

    Returns
    -------
    ViewData

    Raises
    ------
    SceneError
        For a view without points or masks of the wrong shape.

    Notes
    -----
    The cost of one view's background fit and mask composition: O(K H W).
    """
    if view.points is None:
        raise SceneError("no 3D point map; run a lifter first", where=view.name, field="points")
    view.validate()
    stack = _stack(masks, view)
    points = finite_points(np.asarray(view.points))
    center = view.camera_center if view.cam_to_world is not None else None
    bg, bg_info = view_background(points, center, config.background, seed=config.seed)
    m: Any = list(stack) if stack.ndim == 3 else stack
    if stack.ndim == 3 and stack.shape[0] == 0:
        m = np.zeros(view.shape, np.int32)
    labels, info = compose_masks(m, background=bg, max_overlap=config.background.max_overlap, min_area=config.masks.min_area)
    nodes = mask_node_table([labels], [points])
    return ViewData(view.replace(points=points), int(uid), stack, bg, labels, nodes, {"compose": info, "background": bg_info}, features)


def node_keys(graph: CorrespondenceGraph, view_uids: np.ndarray) -> list[bytes]:
    """The identity of every node: the sorted uids of the base masks it holds, as bytes.

    Two nodes of two updates with the same key hold the same masks, so the
    same pixels and points.

    Examples
    --------
    >>> g = CorrespondenceGraph(2, members={"view": [0, 1, 1], "mask_id": [0, 0, 1], "node": [1, 0, 1]}, level="super")
    >>> [np.frombuffer(k, np.int64).tolist() for k in node_keys(g, np.array([5, 7]))]
    [[117440512], [83886080, 117440513]]
    """
    mem = graph.members
    uid = (np.asarray(view_uids, np.int64)[mem["view"]] << MASK_BITS) | mem["mask_id"]
    order = np.lexsort((uid, mem["node"]))
    node, uid = mem["node"][order], uid[order]
    bounds = np.searchsorted(node, np.arange(graph.num_nodes + 1))
    return [uid[a:b].tobytes() for a, b in zip(bounds[:-1], bounds[1:])]


def local_rule(spec: CriterionSpec, stage: int) -> str | None:
    """How the edges of one configured criterion can be reused between updates.

    Returns
    -------
    {"matches", "points"} or None
        ``"matches"``: ``pixel_match`` with an absolute ``tau`` and ``area`` or
        ``pair_hits`` normalisation on the mask graph (stage 0): an edge depends
        on the matches of its two views. ``"points"``: ``chamfer_3d`` without
        ``fragment_ratio``: an edge depends on its two nodes' points. None: the
        criterion runs on the whole stage graph.

    Examples
    --------
    >>> local_rule(CriterionSpec.model_validate({"pixel_match": {"tau": 0.3}}), 0)
    'matches'
    >>> local_rule(CriterionSpec.model_validate("pixel_match"), 0) is None   # 78th percentile of all ratios
    True
    >>> local_rule(CriterionSpec.model_validate("chamfer_3d"), 1)
    'points'
    """
    from ..graphs.chamfer import Chamfer3D
    from ..graphs.pixel_match import PixelMatch

    plugin = spec.plugin()
    o = spec.options
    if plugin is PixelMatch and stage == 0 and o.get("tau") is not None and o.get("normalization") in ("area", "pair_hits"):
        return "matches"
    if plugin is Chamfer3D and o.get("fragment_ratio") is None:
        return "points"
    return None


def _evidence_fields(config: Config, views: Sequence[ViewData], matches: Mapping[tuple[int, int], Matches], points: list[np.ndarray], labels: list[np.ndarray], name: str) -> dict[str, Any]:
    """The evidence the configured criteria require, as :func:`segment` builds it (:func:`evidence_fields`)."""
    required = config.requires()
    if "features" in required and any(v.features is None for v in views):
        raise ValueError("a configured criterion requires features, and a view of the store has none")
    features = [v.features for v in views] if "features" in required else None
    return evidence_fields(required, [v.view for v in views], matches=matches, points=points, features=features, labels=labels, name=name)


def _old_rows(prev: CorrespondenceGraph | None, stage: int, name: str) -> np.ndarray:
    if prev is None or "stage" not in prev.edge_attr or "criterion" not in prev.edge_attr:
        return np.zeros(0, np.int64)
    return np.flatnonzero((np.asarray(prev.edge_attr["stage"]) == stage) & (np.asarray(prev.edge_attr["criterion"]).astype(str) == name))


def _near(bbox: np.ndarray, seeds: np.ndarray, margin: float) -> np.ndarray:
    """Nodes whose 3D box lies within ``margin`` of the box of a seed node (bool ``[N]``)."""
    near = np.zeros(len(bbox), bool)
    near[seeds] = True
    if not seeds.size or not len(bbox):
        return near
    lo, hi = bbox[:, :3], bbox[:, 3:]
    for s in seeds:
        if not np.isfinite(bbox[s]).all():
            continue
        gap = np.maximum(0.0, np.maximum(lo[s] - hi, lo - hi[s]))
        with np.errstate(invalid="ignore"):
            near |= np.einsum("ij,ij->i", gap, gap) <= margin * margin
    return near


def _sub_evidence(evidence: Evidence, keep: np.ndarray) -> tuple[Evidence, np.ndarray]:
    """Evidence whose node labels keep only the nodes in ``keep`` (renumbered ``0..k-1``)."""
    idx = np.flatnonzero(keep)
    lut = np.full(keep.size + 1, -1, np.int64)
    lut[idx + 1] = np.arange(idx.size)
    labels = [lut[np.asarray(lab) + 1] for lab in evidence.node_labels]
    return replace(evidence, node_labels=labels), idx


def _pair_codes(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """One int64 per unordered pair of view uids."""
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    return (lo << 32) | hi


def _criterion_edges(
    spec: CriterionSpec,
    stage: int,
    graph: CorrespondenceGraph,
    evidence: Evidence,
    keys: list[bytes],
    prev: CorrespondenceGraph | None,
    prev_keys: list[bytes] | None,
    known_views: set[int],
    changed_pairs: set[tuple[int, int]],
    view_uids: np.ndarray,
) -> StageEdges:
    """The edges of one criterion on one stage graph, reusing the last snapshot's where they are local."""
    rule = local_rule(spec, stage) if prev is not None and prev_keys is not None else None
    if rule is None:
        whole, info = criterion_edges(spec, stage, graph, evidence)
        n = int(whole[0][0].shape[1])
        return whole, {"edges": n, "computed": n, "reused": 0, **info}
    criterion = spec.build()
    assert prev is not None and prev_keys is not None
    where = {k: i for i, k in enumerate(keys)}
    rows = _old_rows(prev, stage, spec.name)
    ou, ov = (prev.edge_index[:, rows] if rows.size else np.zeros((2, 0), np.int64))
    nu = np.array([where.get(prev_keys[u], -1) for u in ou], np.int64)
    nv = np.array([where.get(prev_keys[v], -1) for v in ov], np.int64)
    ok = (nu >= 0) & (nv >= 0)
    changed = np.array(sorted(_pair_codes(np.array([a]), np.array([b]))[0] for a, b in changed_pairs), np.int64)
    if rule == "matches":
        # an edge of the mask graph comes from the matches of its two views: it holds
        # while both views and their pair are unchanged
        view_of = np.asarray(graph.node_attr["view"], np.int64)
        uid_of_node = view_uids[view_of]
        if ok.any():
            codes = _pair_codes(uid_of_node[nu[ok]], uid_of_node[nv[ok]])
            ok[ok] = ~np.isin(codes, changed)
        known = np.array(sorted(known_views), np.int64)
        pair_list = list(evidence.matches)
        redo = [p for p in pair_list if not (view_uids[p[0]] in known and view_uids[p[1]] in known) or _pair_codes(view_uids[[p[0]]], view_uids[[p[1]]])[0] in set(changed.tolist())]
        dirty_any = bool(redo)
    else:
        old = set(prev_keys)
        dirty = np.array([k not in old for k in keys], bool)
        if ok.any():
            ok[ok] &= ~(dirty[nu[ok]] | dirty[nv[ok]])
        dirty_any = bool(dirty.any())
    parts: list[tuple[np.ndarray, dict[str, np.ndarray]]] = []
    reused = int(ok.sum())
    if reused:
        attrs = {c: np.asarray(col)[rows[ok]] for c, col in prev.edge_attr.items()}
        parts.append((np.stack([nu[ok], nv[ok]]), attrs))
    computed = 0
    if dirty_any:
        if rule == "matches":
            es = criterion(graph, replace(evidence, matches={p: evidence.matches[p] for p in redo}))
            ei, attrs = es.edge_index, dict(es.edge_attr)
        else:
            o = spec.options
            margin = np.inf if o.get("spacing_factor") is not None else float(np.sqrt(o.get("tau", TAU_3D_PAPER))) * (1 + 1e-6) + 1e-9
            bbox = np.asarray(graph.node_attr.get("bbox_3d", np.full((graph.num_nodes, 6), np.nan)), np.float64)
            keep = np.ones(graph.num_nodes, bool) if not np.isfinite(margin) else _near(bbox, np.flatnonzero(dirty), margin)
            ev, idx = _sub_evidence(evidence, keep)
            sub_graph = CorrespondenceGraph(idx.size, node_attr={c: np.asarray(v)[idx] for c, v in graph.node_attr.items()})
            es = criterion(sub_graph, ev)
            ei = idx[es.edge_index]
            new = dirty[ei[0]] | dirty[ei[1]] if ei.size else np.zeros(0, bool)
            ei, attrs = ei[:, new], {c: np.asarray(v)[new] for c, v in es.edge_attr.items()}
        computed = int(ei.shape[1])
        parts.append((ei, attrs))
    return parts, {"edges": reused + computed, "reused": reused, "computed": computed}


def _background_info(views: Sequence[ViewData]) -> dict[str, Any]:
    """``segment``'s background info (one ``plane``, one ``max_distance``: the medians over the
    views' own fits), plus each view's fit (``planes``, ``max_distances``) and ``rule: "per-view"``."""
    fits = [v.info.get("background") or {} for v in views]
    planes = [f.get("plane") for f in fits]
    dists = [f.get("max_distance") for f in fits]
    got = np.array([p for p in planes if p is not None], np.float64).reshape(-1, 4)
    plane = None
    if got.size:
        med = np.median(got, axis=0)
        norm = float(np.linalg.norm(med[:3]))
        plane = [float(x) for x in med / norm] if norm > 0 else None
    known = [d for d in dists if d is not None]
    return {
        "plane": plane,
        "max_distance": float(np.median(known)) if known else None,
        "fraction": [f.get("fraction") for f in fits],
        "rule": "per-view",
        "planes": planes,
        "max_distances": dists,
    }


def update(
    views: Sequence[ViewData],
    matches: Mapping[tuple[int, int], Matches],
    config: Config,
    *,
    previous: Snapshot | None = None,
    changed_pairs: set[tuple[int, int]] | None = None,
    name: str = "store",
    rng: Any = None,
    num_matches: int | None = None,
) -> Update:
    """Build the stage graphs, contract them and read off the objects, reusing ``previous`` where it holds.

    Parameters
    ----------
    views : list of ViewData
        Every view of the store, in store order.
    matches : mapping ``(i, j) -> Matches``
        Matches of the selected pairs, ``i < j`` indices into ``views``.
    config : Config
        As ``segment`` runs it (``for_lifter`` applied).
    previous : Snapshot, optional, keyword-only
        The last update's graphs; None computes everything.
    changed_pairs : set of (int, int), keyword-only
        View uid pairs whose matches were added or removed since
        ``previous`` (pairs with a new view need not be listed): the
        mask-graph edges of these pairs are recomputed.
    name : str, keyword-only
        The scene name in the graphs' ``meta``.
    rng : keyword-only
        Randomness of the contractor (default ``config.seed``).
    num_matches : int, optional, keyword-only
        The number of matches over all pairs, when known (else counted, which
        reads every pair's matches of a lazy mapping).

    Returns
    -------
    Update
        ``result`` has compact object ids ``1..K`` numbered as ``segment``
        numbers them (by first appearance in store order);
        ``recomputed`` says per stage and criterion how many edges were
        reused and computed.

    Notes
    -----
    O(total pixels) for the node labels, the support rules and the object
    clouds; the criteria cost only what changed when they are local.
    """
    cfg = config
    t0 = time.perf_counter()
    timings: dict[str, float] = {}
    gen = np.random.default_rng(cfg.seed if rng is None else rng)
    uids = np.array([v.uid for v in views], np.int64)
    points = [np.asarray(v.view.points) for v in views]
    labels = [v.labels for v in views]
    parts = []
    for i, v in enumerate(views):
        cols = dict(v.nodes)
        cols["view"] = np.full(len(cols["view"]), i, np.int64)
        parts.append(cols)
    table = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]} if parts else mask_node_table([])
    graph = CorrespondenceGraph(len(table["view"]), node_attr=table, masks=labels, meta={"scene": name})
    mask_uid = (uids[graph.node_attr["view"]] << MASK_BITS) | graph.node_attr["mask_id"] if graph.num_nodes else np.zeros(0, np.int64)
    shared = _evidence_fields(cfg, views, matches, points, labels, name)
    changed = set(changed_pairs or set())
    known = set(previous.view_uids.tolist()) if previous is not None else set()
    recomputed: dict[str, Any] = {}
    keys_of: dict[int, tuple[CorrespondenceGraph | None, list[bytes], list[bytes] | None]] = {}

    def edges(spec: CriterionSpec, s: int, current: CorrespondenceGraph, evidence: Evidence) -> StageEdges:
        if s not in keys_of:  # the node identities of this stage's graph and of the last update's
            prev = previous.graphs[s] if previous is not None and s < len(previous.graphs) else None
            prev_keys = node_keys(prev, previous.view_uids) if prev is not None and previous is not None else None
            keys_of[s] = (prev, node_keys(current, uids), prev_keys)
        prev, keys, prev_keys = keys_of[s]
        unique = [sp.name for sp in cfg.edge_stages[s]].count(spec.name) == 1
        edge_parts, adder = _criterion_edges(spec, s, current, evidence, keys, prev if unique else None, prev_keys if unique else None, known, changed, uids)
        recomputed[f"stage{s}/{spec.name}"] = {"reused": adder["reused"], "computed": adder["computed"]}
        return edge_parts, adder

    current, stage_graphs, stage_info = run_stages(graph, cfg, shared, rng=gen, edges=edges)
    timings.update({f"stage{i['stage']}": i["seconds"] for i in stage_info})

    result = finish_segmentation(
        [v.view for v in views],
        current,
        stage_graphs,
        labels,
        points,
        [v.background for v in views],
        cfg,
        info={
            "background": _background_info(views),
            "masks": [v.info.get("compose") for v in views],
            "stages": stage_info,
            "timings": timings,
            "num_matches": int(sum(len(m) for m in matches.values())) if num_matches is None else int(num_matches),
            "pairs": [list(p) for p in matches],
        },
        start=t0,
    )
    return Update(result, Snapshot(stage_graphs, uids.copy(), []), mask_uid, recomputed)

