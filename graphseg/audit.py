"""Edge audit: which edges of a run were wrong, against ground-truth instance images.

For every input mask the audit counts the ground-truth objects under its
pixels; a mask's *majority* object is the most frequent one (0 = background
or unlabelled counts as an object too, so a mask lying mostly on the table has
majority 0). Then, per stage graph of a :class:`~graphseg.result.Result`:

* **wrong edges**: edges of that stage whose two end nodes (masks, or super
  nodes: the pooled counts of their member masks) have different majority
  objects;
* **impure masks**: input masks with less than ``purity`` (80%) of their
  labelled pixels on one object;
* **merge errors**: a final object that is the majority object of at least
  ``min_share`` of the pixels of two ground-truth objects; for each pair of
  such objects, a *minimum edge cut* of the run's edges (all stages lifted to
  input masks) separating the masks of one object from those of the other:
  the fewest edges whose removal would have kept the two apart;
* **majority grouping**: the mean IoU when every mask goes to its majority
  object, the grouping a perfect graph would make. Far above the run's IoU:
  the graph lost it; near it and low: the masks themselves (impure, or
  spilling onto the table) limit the run. It is a reference, not a strict
  bound: joining a mask whose majority is the table to an object can score
  a little higher.

:func:`loss_breakdown` splits a run's loss against the ground truth into
where each object pixel went (no point, background, no mask, dropped,
labelled), the masks' majority grouping, and the IoU once every final object
is mapped to its majority object (pieces joined, merges kept).

:func:`audit` returns plain data; :mod:`graphseg.render_audit` renders it as
text (the command line) or HTML (the report page). ``format_audit``,
``format_by_criterion`` and ``audit_html`` stay importable from here.

Examples
--------
>>> from graphseg.method.segment import segment
>>> from graphseg.testing.scenes import two_boxes_scene
>>> scene, masks, matches = two_boxes_scene()
>>> report = audit(segment(scene, masks, matches), scene)
>>> report["summary"]["merge_errors"], report["summary"]["impure_masks"]
(0, 0)
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from .graphs.signed import split_signed
from .method.masks import paint_masks
from .render_audit import audit_html, format_audit, format_by_criterion

__all__ = [
    "mask_gt_counts",
    "majority",
    "wrong_edges",
    "impure_masks",
    "lift_edges",
    "min_cut_edges",
    "audit",
    "loss_breakdown",
    "format_audit",
    "format_by_criterion",
    "audit_html",
]


def mask_gt_counts(masks: Sequence[np.ndarray], mask_view: np.ndarray, mask_id: np.ndarray, gt: Sequence[np.ndarray]) -> np.ndarray:
    """Ground-truth pixel counts under each input mask.

    Parameters
    ----------
    masks : list of int ``[H, W]``
        Per view, ``mask_id + 1`` per pixel (0 = no mask), as ``graph.masks``.
    mask_view, mask_id : int ``[M]``
        The masks to count, in this order.
    gt : list of int ``[H, W]``
        Ground-truth instance ids (0 = background); negative ids count as 0.

    Returns
    -------
    numpy.ndarray
        int64 ``[M, G + 1]``: column ``g`` counts the mask's pixels on object
        ``g`` (column 0: background). Cost O(total pixels).

    Examples
    --------
    >>> m = [np.array([[1, 1, 2]])]
    >>> mask_gt_counts(m, np.array([0, 0]), np.array([0, 1]), [np.array([[3, 0, 3]])]).tolist()
    [[1, 0, 0, 1], [0, 0, 0, 1]]
    """
    mask_view = np.asarray(mask_view, np.int64)
    mask_id = np.asarray(mask_id, np.int64)
    if mask_view.shape != mask_id.shape:
        raise ValueError(f"expected mask_view and mask_id of one shape (got {list(mask_view.shape)} and {list(mask_id.shape)})")
    g_max = max((int(np.asarray(g).max(initial=0)) for g in gt), default=0)
    out = np.zeros((mask_view.size, g_max + 1), np.int64)
    for v, (lab, g) in enumerate(zip(masks, gt)):
        lab = np.asarray(lab)
        g = np.clip(np.asarray(g, np.int64), 0, None)
        if lab.shape != g.shape:
            raise ValueError(f"view {v}: masks are {list(lab.shape)} but the ground truth is {list(g.shape)}")
        sel = np.flatnonzero(mask_view == v)
        if sel.size == 0:
            continue
        n_ids = int(lab.max(initial=0)) + 1
        on = lab > 0
        hist = np.bincount((lab[on].astype(np.int64)) * (g_max + 1) + g[on], minlength=n_ids * (g_max + 1)).reshape(n_ids, g_max + 1)
        ids = mask_id[sel] + 1
        ok = ids < n_ids
        out[sel[ok]] = hist[ids[ok]]
    return out


def majority(counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Majority object and its share per row of a count table ``[M, G + 1]``.

    Returns ``(obj int64 [M], share float64 [M])``; an empty row gives
    ``(-1, 0.0)``.

    Examples
    --------
    >>> majority(np.array([[1, 3], [0, 0]]))
    (array([ 1, -1]), array([0.75, 0.  ]))
    """
    counts = np.asarray(counts)
    tot = counts.sum(axis=1)
    obj = np.where(tot > 0, counts.argmax(axis=1), -1).astype(np.int64)
    share = np.where(tot > 0, counts.max(axis=1, initial=0) / np.maximum(tot, 1), 0.0)
    return obj, share


def wrong_edges(edge_index: np.ndarray, node_obj: np.ndarray) -> np.ndarray:
    """Indices of edges whose end nodes have different (known) majority objects.

    Examples
    --------
    >>> wrong_edges(np.array([[0, 0, 1], [1, 2, 2]]), np.array([4, 4, 5])).tolist()
    [1, 2]
    """
    ei = np.asarray(edge_index, np.int64).reshape(2, -1)
    a, b = node_obj[ei[0]], node_obj[ei[1]]
    return np.flatnonzero((a != b) & (a >= 0) & (b >= 0))


def impure_masks(counts: np.ndarray, purity: float = 0.8) -> np.ndarray:
    """Rows (masks) whose majority share is below ``purity`` (empty masks excluded).

    Examples
    --------
    >>> impure_masks(np.array([[5, 5], [9, 1], [0, 0]])).tolist()
    [0]
    """
    obj, share = majority(counts)
    return np.flatnonzero((obj >= 0) & (share < purity))


def lift_edges(graphs: Sequence[Any], base_area: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every stage's own edges as edges between input masks.

    An edge between two super nodes becomes an edge between their largest
    member masks (any members would keep the same connectivity, since the
    members of a super node are already joined by earlier edges).

    Parameters
    ----------
    graphs : list of CorrespondenceGraph
        ``result.graphs``; graph ``s`` carries the stage-``s`` edges (column
        ``stage``) and ``members`` mapping input masks to its nodes. Repulsive
        edges (``sign < 0``) are left out.
    base_area : float ``[M]``
        Area of each input mask, indexed like ``graphs[0].members``.

    Returns
    -------
    edge_index : int64 ``[2, E]`` over input masks
    stage : int64 ``[E]``
    index : int64 ``[E]``, the edge's column in ``graphs[stage]``
    """
    eis, stages, idx = [], [], []
    for s, g in enumerate(graphs):
        st = g.edge_attr.get("stage")
        own = np.flatnonzero(np.asarray(st) == s) if st is not None else np.arange(g.num_edges)
        attract, _ = split_signed(g.edge_index, g.edge_attr)
        own = own[attract[own]]  # cannot-links join nothing
        node = g.members["node"]
        # representative member of each node: its largest input mask
        order = np.lexsort((-base_area, node))
        first = np.ones(order.size, bool)
        first[1:] = node[order][1:] != node[order][:-1]
        rep = np.full(g.num_nodes, -1, np.int64)
        rep[node[order][first]] = order[first]
        eis.append(rep[g.edge_index[:, own]])
        stages.append(np.full(own.size, s, np.int64))
        idx.append(own.astype(np.int64))
    if not eis:
        return np.zeros((2, 0), np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64)
    return np.concatenate(eis, axis=1), np.concatenate(stages), np.concatenate(idx)


def min_cut_edges(edge_index: np.ndarray, side_a: np.ndarray, side_b: np.ndarray) -> np.ndarray:
    """A minimum set of edges whose removal disconnects node set ``a`` from ``b``.

    Unit capacities; edges are undirected. Uses ``networkx.minimum_cut`` with
    a super source and sink. Returns the edge columns (int64), or an empty
    array when the two sets are not connected. Cost: one max-flow,
    O(V E^2) worst case (Edmonds-Karp), fast on mask graphs.

    Examples
    --------
    >>> ei = np.array([[0, 1, 2], [1, 2, 3]])
    >>> min_cut_edges(ei, np.array([0, 1]), np.array([3])).size
    1
    """
    import networkx as nx

    ei = np.asarray(edge_index, np.int64).reshape(2, -1)
    a, b = set(np.asarray(side_a).tolist()), set(np.asarray(side_b).tolist())
    if not a or not b or a & b:
        return np.zeros(0, np.int64)
    g = nx.DiGraph()
    for e, (u, v) in enumerate(ei.T.tolist()):
        if u == v:
            continue
        for x, y in ((u, v), (v, u)):
            if g.has_edge(x, y):
                g[x][y]["capacity"] += 1
                g[x][y]["ids"].append(e)
            else:
                g.add_edge(x, y, capacity=1, ids=[e])
    src, snk = "s", "t"
    for u in a:
        g.add_edge(src, u)  # no capacity attribute = infinite
    for v in b:
        g.add_edge(v, snk)
    if not nx.has_path(g, src, snk):
        return np.zeros(0, np.int64)
    _, (reach, _) = nx.minimum_cut(g, src, snk)
    cut = sorted({e for u, v, d in g.edges(data=True) if u in reach and v not in reach and "ids" in d for e in d["ids"]})
    return np.asarray(cut, np.int64)


def audit(result: Any, scene: Any, *, purity: float = 0.8, min_share: float = 0.2, max_listed: int = 50) -> dict[str, Any]:
    """Audit a run's edges against the scene's ground-truth instance images.

    Parameters
    ----------
    result : Result
        A run on ``scene`` (its ``graphs`` must store the mask images).
    scene : Scene
        Views with ``instances`` ``[H, W]`` (0 = background).
    purity : float
        A mask is impure below this majority share.
    min_share : float
        A final object "covers" a ground-truth object when it holds at least
        this share of that object's masked pixels.
    max_listed : int
        Wrong edges listed per stage (all are counted).

    Returns
    -------
    dict
        JSON-serialisable: ``summary``, ``stages`` (per stage: attractive
        ``edges``, ``wrong``, ``wrong_by_criterion``, ``cannot_links``,
        ``wrong_cannot_links`` (joining one object), ``wrong_edges`` listed as
        ``{"edge", "u", "v", "objects", "criterion", "weight"}``),
        ``impure_masks`` (``{"view", "mask_id", "object", "share"}``) and
        ``merge_errors`` (``{"object", "gt", "cut": [{"stage", "edge",
        "views", "mask_ids", "objects", "criterion"}]}``).

    Notes
    -----
    O(total pixels) for the counts, then one max-flow per merged pair.
    """
    gt = [getattr(v, "instances", None) for v in scene.views]
    if any(g is None for g in gt):
        raise ValueError("the scene has no ground-truth instances; the audit needs them")
    if not result.graphs or result.graphs[0].masks is None:
        raise ValueError("the result stores no mask images; the audit needs them")
    g0 = result.graphs[0]
    mem = g0.members
    counts = mask_gt_counts(g0.masks, mem["view"], mem["mask_id"], [np.asarray(g) for g in gt])
    base_obj, base_share = majority(counts)
    objects = getattr(scene, "objects", None) or {}
    names = dict(objects) if isinstance(objects, dict) else {k + 1: n for k, n in enumerate(objects)}

    def name(o: int) -> str:
        return "background" if o == 0 else str(names.get(o, o))

    stages = []
    for s, g in enumerate(result.graphs):
        node = g.members["node"]
        node_counts = np.zeros((g.num_nodes, counts.shape[1]), np.int64)
        np.add.at(node_counts, node, counts)
        node_obj, _ = majority(node_counts)
        st = g.edge_attr.get("stage")
        own = np.flatnonzero(np.asarray(st) == s) if st is not None else np.arange(g.num_edges)
        _, repel = split_signed(g.edge_index, g.edge_attr)
        # repulsive edges (cannot-links) are wrong when they join masks of the same object
        rep = own[repel[own]]
        ro = node_obj[g.edge_index[:, rep]]
        wrong_repel = int(((ro[0] == ro[1]) & (ro[0] >= 0)).sum())
        own = own[~repel[own]]
        bad = own[wrong_edges(g.edge_index[:, own], node_obj)]
        crit = g.edge_attr.get("criterion")
        weight = g.edge_attr.get("weight")
        by_crit: dict[str, int] = {}
        for e in bad:
            c = str(crit[e]) if crit is not None else "?"
            by_crit[c] = by_crit.get(c, 0) + 1
        listed = [
            {
                "edge": int(e),
                "u": int(g.edge_index[0, e]),
                "v": int(g.edge_index[1, e]),
                "objects": [name(int(node_obj[g.edge_index[0, e]])), name(int(node_obj[g.edge_index[1, e]]))],
                "criterion": str(crit[e]) if crit is not None else None,
                "weight": float(weight[e]) if weight is not None and np.issubdtype(np.asarray(weight).dtype, np.number) else None,
            }
            for e in bad[:max_listed]
        ]
        stages.append(
            {
                "stage": s,
                "nodes": int(g.num_nodes),
                "edges": int(own.size),
                "wrong": int(bad.size),
                "wrong_by_criterion": by_crit,
                "wrong_edges": listed,
                "cannot_links": int(rep.size),
                "wrong_cannot_links": wrong_repel,
            }
        )

    imp = impure_masks(counts, purity)
    impure = [{"view": int(mem["view"][i]), "mask_id": int(mem["mask_id"][i]), "object": name(int(base_obj[i])), "share": round(float(base_share[i]), 3)} for i in imp]

    # merge errors: final objects holding >= min_share of two GT objects' masked pixels
    obj_of_base = np.zeros(mem["view"].size, np.int64)
    lookup = {(int(v), int(m)): int(o) for v, m, o in zip(result.mask_view, result.mask_id, result.mask_object)}
    for i, (v, m) in enumerate(zip(mem["view"].tolist(), mem["mask_id"].tolist())):
        obj_of_base[i] = lookup.get((v, m), 0)
    n_obj = int(obj_of_base.max(initial=0))
    per_obj = np.zeros((n_obj + 1, counts.shape[1]), np.int64)
    np.add.at(per_obj, obj_of_base, counts)
    gt_tot = per_obj[1:].sum(axis=0)
    area = counts.sum(axis=1).astype(np.float64)
    lifted, lstage, lidx = lift_edges(result.graphs, area)
    merges = []
    for k in range(1, n_obj + 1):
        covered = [int(o) for o in np.flatnonzero((per_obj[k] >= min_share * np.maximum(gt_tot, 1)) & (per_obj[k] > 0)) if o > 0]
        for x in range(len(covered)):
            for y in range(x + 1, len(covered)):
                a, b = covered[x], covered[y]
                in_k = obj_of_base == k
                side_a = np.flatnonzero(in_k & (base_obj == a))
                side_b = np.flatnonzero(in_k & (base_obj == b))
                cut = min_cut_edges(lifted, side_a, side_b)
                merges.append(
                    {
                        "object": k,
                        "gt": [name(a), name(b)],
                        "cut": [
                            {
                                "stage": int(lstage[e]),
                                "edge": int(lidx[e]),
                                "views": [int(mem["view"][lifted[0, e]]), int(mem["view"][lifted[1, e]])],
                                "mask_ids": [int(mem["mask_id"][lifted[0, e]]), int(mem["mask_id"][lifted[1, e]])],
                                "objects": [name(int(base_obj[lifted[0, e]])), name(int(base_obj[lifted[1, e]]))],
                                "criterion": _criterion(result.graphs[int(lstage[e])], int(lidx[e])),
                            }
                            for e in cut
                        ],
                    }
                )
    grouping = None
    pts = [getattr(v, "points", None) for v in scene.views]
    if all(p is not None for p in pts):
        from .metrics import mean_iou

        labels = paint_masks(g0.masks, mem["view"], mem["mask_id"], base_obj)
        value = mean_iou(labels, [np.asarray(g) for g in gt], [np.asarray(p) for p in pts])
        grouping = None if value is None else round(value, 4)  # None: no ground-truth object
    summary = {
        "masks": int(counts.shape[0]),
        "majority_grouping_iou": grouping,
        "impure_masks": len(impure),
        "edges": [st["edges"] for st in stages],
        "wrong_edges": [st["wrong"] for st in stages],
        "merge_errors": len(merges),
        "cut_edges": int(sum(len(m["cut"]) for m in merges)),  # type: ignore[arg-type,misc]
    }
    return {"summary": summary, "stages": stages, "impure_masks": impure, "merge_errors": merges, "purity": purity, "min_share": min_share}


def loss_breakdown(
    result: Any, instances: Sequence[np.ndarray], points: Sequence[np.ndarray], *, eval_points: Sequence[np.ndarray] | None = None
) -> dict[str, Any]:
    """Where a run loses against the ground truth: pixels, masks, grouping, pieces.

    Parameters
    ----------
    result : Result
        A run (its ``graphs[0]`` must store the mask images; ``background`` is read when present).
    instances : list of int ``[H, W]``
        Ground-truth instance ids for the run's views, in its order (0 or
        negative = background; negative labels of the run count as none too).
    points : list of float ``[H, W, 3]``
        The point maps the run used (NaN = no point).
    eval_points : list of float ``[H, W, 3]``, optional
        The point maps the IoUs are computed on (default ``points``); give the
        true ones to score a lifted run as the benchmarks do.

    Returns
    -------
    dict
        ``pixels``: shares of the ground-truth object pixels that had no point
        (``no_point``), fell in the background class (``background``), lay in
        no mask (``no_mask``), lay in a mask but carry no object (``dropped``:
        the object had too little support, or a step after contraction such
        as the rim trim unlabelled the pixel) or carry an object
        (``labelled``); they sum to 1. ``iou``: the run's mean IoU;
        ``objects_majority``: the mean IoU after every final object takes the
        ground-truth object holding most of its object pixels (table pixels do
        not vote; an object on no ground-truth object is dropped): pieces of one
        object are joined and merged objects stay merged, so
        ``objects_majority - iou`` is what the pieces cost; ``masks_majority``: the masks' majority grouping
        (:func:`audit`'s ``majority_grouping_iou``; ``masks_majority -
        objects_majority`` is roughly what wrong grouping cost). IoUs are None
        without a ground-truth object.

    Notes
    -----
    O(total pixels).

    Examples
    --------
    >>> from graphseg.method.segment import segment
    >>> from graphseg.testing.scenes import two_boxes_scene
    >>> scene, masks, matches = two_boxes_scene()
    >>> b = loss_breakdown(segment(scene, masks, matches), [v.instances for v in scene.views], [v.points for v in scene.views])
    >>> round(b["pixels"]["labelled"], 3), b["iou"] == b["objects_majority"]
    (0.999, True)
    """
    from .metrics import contingency, mean_iou

    labels = [np.clip(np.asarray(lab), 0, None) for lab in result.labels]  # negative ids count as none
    gt = [np.clip(np.asarray(g), 0, None) for g in instances]
    n = len(labels)
    if not (len(gt) == len(points) == n):
        raise ValueError(f"expected instances and points for the run's {n} views (got {len(gt)} and {len(points)})")
    if eval_points is not None and len(eval_points) != n:
        raise ValueError(f"expected eval_points for the run's {n} views (got {len(eval_points)})")
    if result.background is not None and len(result.background) != n:
        raise ValueError(f"expected a background image for each of the run's {n} views (got {len(result.background)})")
    if not result.graphs or result.graphs[0].masks is None:
        raise ValueError("the result stores no mask images; the breakdown needs them")
    ev = [np.asarray(p) for p in (points if eval_points is None else eval_points)]
    g0 = result.graphs[0]
    fate = dict.fromkeys(("no_point", "background", "no_mask", "dropped", "labelled"), 0)
    for v, (lab, g) in enumerate(zip(labels, gt)):
        pts = np.asarray(points[v], np.float64)
        for what, shape in (("labels", lab.shape), ("points", pts.shape[:2]), ("eval_points", ev[v].shape[:2])):
            if shape != g.shape:
                raise ValueError(f"view {v}: {what} are {list(shape)} but the ground truth is {list(g.shape)}")
        obj = g > 0
        has = np.isfinite(pts).all(-1)
        bg = np.asarray(result.background[v], bool) if result.background is not None else np.zeros(g.shape, bool)
        masked = np.asarray(g0.masks[v]) > 0
        fate["no_point"] += int((obj & ~has).sum())
        rest = obj & has & (lab == 0)
        fate["labelled"] += int((obj & has & (lab > 0)).sum())
        fate["background"] += int((rest & bg).sum())
        fate["no_mask"] += int((rest & ~bg & ~masked).sum())
        fate["dropped"] += int((rest & ~bg & masked).sum())
    total = sum(fate.values())
    shares = {k: (c / total if total else 0.0) for k, c in fate.items()}
    # every final object -> the ground-truth object holding most of its object pixels (table pixels
    # do not vote: an object mostly on the table still maps to the object it covers); none -> 0
    table, gt_ids, pred_ids = contingency(labels, gt)  # [G + 1, P + 1]; row and column 0: none
    on_obj = table[1:]
    best = gt_ids[1:][on_obj.argmax(axis=0)] if on_obj.shape[0] else np.zeros(pred_ids.size, np.int64)
    to_gt = np.zeros(int(pred_ids.max()) + 1, np.int64)
    to_gt[pred_ids] = np.where((on_obj.sum(axis=0) > 0) & (pred_ids > 0), best, 0)
    mapped = [to_gt[lab] for lab in labels]
    mem = g0.members
    base_obj, _ = majority(mask_gt_counts(g0.masks, mem["view"], mem["mask_id"], gt))
    grouped = paint_masks(g0.masks, mem["view"], mem["mask_id"], np.clip(base_obj, 0, None))
    return {
        "pixels": shares,
        "iou": mean_iou(labels, gt, ev),
        "objects_majority": mean_iou(mapped, gt, ev),
        "masks_majority": mean_iou(grouped, gt, ev),
    }


def _criterion(graph: Any, e: int) -> str | None:
    c = graph.edge_attr.get("criterion")
    return None if c is None else str(c[e])
