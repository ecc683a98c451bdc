"""3D edge addition: super-vertices joined by a small Chamfer distance (``chamfer_3d``).

The paper's directed Chamfer distance between point sets ``X`` and ``Y`` is::

    D(X, Y) = mean_{x in X} min_{y in Y} ||x - y||^2        (m^2)

and an edge joins two nodes when ``min(D(X, Y), D(Y, X)) <= tau_3D``. The
paper states ``tau_3D = 5e-4`` m^2 (:data:`graphseg.published.TAU_3D_PAPER`,
the default of ``Chamfer3D.Options.tau``); the official code used ``5e-5``
(:data:`graphseg.published.TAU_3D_OFFICIAL`, the measured presets' value).

Point sets are stored in CSR layout: ``points`` float64 ``[P, 3]`` sorted by
node, and ``ptr`` int64 ``[N + 1]`` so node ``k`` owns ``points[ptr[k]:ptr[k+1]]``.

Examples
--------
>>> import numpy as np
>>> x = np.array([[0.0, 0, 0], [1, 0, 0]])
>>> y = np.array([[0.0, 0, 0]])
>>> float(directed_chamfer(x, y)), float(directed_chamfer(y, x))
(0.5, 0.0)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field
from scipy.spatial import cKDTree

from ..published import TAU_3D_PAPER
from .coalesce import _argsort_keys, combine_keys, group_by_key
from .criterion import Criterion
from .evidence import EdgeSet, Evidence
from .graph import CorrespondenceGraph

__all__ = [
    "PointSets",
    "node_point_sets",
    "directed_chamfer",
    "remove_outliers",
    "chamfer_edges",
    "point_spacing",
    "spacing_aware_chamfer_edges",
    "strongest_attachments",
    "SPACING_FACTOR",
    "Chamfer3D",
]

#: The ``factor`` of :func:`spacing_aware_chamfer_edges` measured on sparse points
#: (``benchmarks/bench_sparse_points.py``): random samplings of one surface with
#: spacing ``s`` sit about ``1.2 s`` apart (RMS), so ``1.5 s`` keeps them. The
#: ``chamfer_3d`` option ``spacing_factor`` is off (None) unless set.
SPACING_FACTOR: float = 1.5


@dataclass
class PointSets:
    """Per-node point sets in CSR layout (``points`` ``[P, 3]``, ``ptr`` ``[N + 1]``, ``colors`` ``[P, 3]`` or None)."""

    points: np.ndarray
    ptr: np.ndarray
    colors: np.ndarray | None = None

    @property
    def num_nodes(self) -> int:
        return int(self.ptr.size - 1)

    def __getitem__(self, k: int) -> np.ndarray:
        return self.points[self.ptr[k] : self.ptr[k + 1]]

    def sizes(self) -> np.ndarray:
        return np.diff(self.ptr)

    def node_of_point(self) -> np.ndarray:
        """Node id of every point ``[P]``."""
        return np.repeat(np.arange(self.num_nodes), self.sizes())

    def select(self, keep: np.ndarray) -> PointSets:
        """Keep the points where ``keep`` (bool ``[P]``) holds."""
        node = self.node_of_point()[keep]
        ptr = np.zeros(self.num_nodes + 1, np.int64)
        ptr[1:] = np.cumsum(np.bincount(node, minlength=self.num_nodes))
        return PointSets(self.points[keep], ptr, None if self.colors is None else self.colors[keep])


def node_point_sets(
    node_labels: Sequence[np.ndarray],
    points: Sequence[np.ndarray | None],
    num_nodes: int,
    *,
    stride: int = 1,
    voxel_size: float | None = None,
    colors: Sequence[np.ndarray] | None = None,
) -> PointSets:
    """Gather each node's world points over all views, optionally voxel-downsampled.

    Parameters
    ----------
    node_labels : list of int ``[H, W]``
        Pixel -> node (-1 = none).
    points : list of float ``[H, W, 3]`` (NaN = invalid) or None
    num_nodes : int
    stride : int
        Take every ``stride``-th pixel in x and y first.
    voxel_size : float, optional
        Replace the points of a node that share a voxel by their mean.
    colors : list of uint8 ``[H, W, 3]``, optional
        Carried along (averaged per voxel).

    Returns
    -------
    PointSets

    Notes
    -----
    One sort of the (node, voxel) keys: O(P log P) for ``P`` valid pixels.

    Examples
    --------
    >>> lab = np.array([[0, 0, 1]])
    >>> pts = np.array([[[0, 0, 0], [0.001, 0, 0], [1, 1, 1]]], dtype=np.float32)
    >>> ps = node_point_sets([lab], [pts], 2, voxel_size=0.01)
    >>> ps.ptr.tolist(), ps[0].shape
    ([0, 1, 2], (1, 3))
    """
    nodes: list[np.ndarray] = []
    xyz: list[list[np.ndarray]] = [[], [], []]
    cols: list[np.ndarray] = []
    for v, lab in enumerate(node_labels):  # loop over views only
        p = points[v]
        if p is None:
            continue
        lab_s = np.asarray(lab)[::stride, ::stride].reshape(-1)
        idx = np.flatnonzero(lab_s >= 0)
        q = np.asarray(p)[::stride, ::stride]
        # one contiguous column per coordinate: 1D gathers and SIMD finiteness tests are
        # several times faster than row gathers of [P, 3] and all(axis=1)
        c3 = [q[..., k].reshape(-1)[idx] for k in range(3)]
        if not np.isfinite(q).all():  # one flat pass; the per-pixel test only when needed
            ok = np.isfinite(c3[0])
            ok &= np.isfinite(c3[1])
            ok &= np.isfinite(c3[2])
            if not ok.all():
                idx = idx[ok]
                c3 = [c[ok] for c in c3]
        nodes.append(lab_s[idx].astype(np.int64))
        for k in range(3):
            xyz[k].append(c3[k].astype(np.float32, copy=False))
        if colors is not None:
            cq = np.asarray(colors[v])[::stride, ::stride]
            cols.append(np.stack([cq[..., k].reshape(-1)[idx] for k in range(3)], 1))
    if not nodes:
        return PointSets(np.zeros((0, 3)), np.zeros(num_nodes + 1, np.int64), np.zeros((0, 3), np.uint8) if colors is not None else None)
    node = np.concatenate(nodes)
    X = [np.concatenate(c) for c in xyz]  # float32 columns while grouping; means come out float64
    C = np.concatenate(cols) if colors is not None else None
    if voxel_size is not None and voxel_size > 0 and node.size:
        ijk = [np.floor((c - c.min()) / voxel_size).astype(np.int64) for c in X]
        ext = [int(c.max()) + 1 for c in ijk]
        grouped = group_by_key(combine_keys([node, *ijk], [num_nodes, *ext]), stable=False)
        grp, g = grouped.groups, grouped.num_groups  # groups ordered by (node, voxel)
        cnt = grouped.counts.astype(np.float64)
        P = np.stack([np.bincount(grp, weights=c, minlength=g) for c in X], 1) / cnt[:, None]
        if C is not None:
            C = np.rint(np.stack([np.bincount(grp, weights=C[:, k], minlength=g) for k in range(3)], 1) / cnt[:, None]).astype(np.uint8)
        node = node[grouped.first]
    else:
        order = _argsort_keys(node, True)
        node = node[order]
        P = np.stack([c[order] for c in X], 1).astype(np.float64)
        C = None if C is None else C[order]
    ptr = np.zeros(num_nodes + 1, np.int64)
    ptr[1:] = np.cumsum(np.bincount(node, minlength=num_nodes))
    return PointSets(P, ptr, C)


def directed_chamfer(x: np.ndarray, y: np.ndarray | cKDTree, *, upper: float | None = None) -> float:
    """``D(X, Y) = mean_x min_y ||x - y||^2`` in squared units.

    Parameters
    ----------
    x : float ``[P, 3]``
    y : float ``[Q, 3]`` or a ``cKDTree`` built on it
    upper : float, optional
        Early exit: a result known to exceed ``upper`` may be returned as inf.

    Returns
    -------
    float
        inf when either set is empty.

    Notes
    -----
    O(P log Q) with a k-d tree.
    """
    tree = y if isinstance(y, cKDTree) else cKDTree(np.asarray(y))
    if len(x) == 0 or tree.n == 0:
        return float("inf")
    bound = np.inf if upper is None else float(np.sqrt(upper * len(x))) * (1 + 1e-9)
    d, _ = tree.query(x, k=1, distance_upper_bound=bound)
    if np.isinf(d).any():
        return float("inf")
    return float(np.mean(d * d))


def remove_outliers(
    sets: PointSets,
    method: str | None,
    *,
    k: int,
    std_ratio: float,
    eps: float,
    min_samples: int,
) -> PointSets:
    """Remove outliers per node before the Chamfer test.

    Every option is a required keyword; the defaults are those of
    :class:`Chamfer3D.Options` (``outlier_k``, ``outlier_std_ratio``,
    ``dbscan_eps``, ``dbscan_min_samples``).

    Parameters
    ----------
    sets : PointSets
    method : {None, "statistical", "dbscan"}
        ``"statistical"``: drop points whose mean distance to their ``k``
        neighbours exceeds the node's mean by ``std_ratio`` standard deviations.
        ``"dbscan"``: DBSCAN with ``eps`` and ``min_samples``; keep the node's
        largest cluster (noise and smaller clusters are dropped).
    k : int
        Statistical: neighbours per point.
    std_ratio : float
        Statistical: standard deviations above the node's mean distance.
    eps : float
        DBSCAN: neighbourhood radius (metres).
    min_samples : int
        DBSCAN: neighbours (the point included) that make a core point.

    Returns
    -------
    PointSets

    Notes
    -----
    One k-d tree per node: O(P log P) in total.

    Examples
    --------
    >>> line = np.c_[np.arange(0, 0.1, 0.01), np.zeros(10), np.zeros(10)]
    >>> sets = PointSets(np.r_[line, [[1.0, 1, 1]]], np.array([0, 11]))   # one node, one stray point
    >>> remove_outliers(sets, "dbscan", k=8, std_ratio=2.0, eps=0.02, min_samples=3).sizes().tolist()
    [10]
    """
    if method is None:
        return sets
    keep = np.ones(len(sets.points), bool)
    for n in range(sets.num_nodes):
        a, b = int(sets.ptr[n]), int(sets.ptr[n + 1])
        x = sets.points[a:b]
        if method == "statistical":
            if len(x) <= k:
                continue
            d, _ = cKDTree(x).query(x, k=k + 1)
            md = d[:, 1:].mean(1)
            keep[a:b] = md <= md.mean() + std_ratio * md.std()
        elif method == "dbscan":
            if len(x) < min_samples:
                continue
            keep[a:b] = _dbscan_largest(x, eps, min_samples)
        else:
            raise ValueError(f"unknown outlier method {method!r}; choose None, 'statistical' or 'dbscan'")
    return sets.select(keep)


def _dbscan_largest(x: np.ndarray, eps: float, min_samples: int) -> np.ndarray:
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    tree = cKDTree(x)
    counts = tree.query_ball_point(x, eps, return_length=True)
    core = counts >= min_samples
    if not core.any():
        return np.ones(len(x), bool)
    pairs = tree.query_pairs(eps, output_type="ndarray")
    both = core[pairs[:, 0]] & core[pairs[:, 1]]
    cp = pairs[both]
    n = len(x)
    _, lab = connected_components(coo_matrix((np.ones(len(cp)), (cp[:, 0], cp[:, 1])), shape=(n, n)), directed=False)
    best = np.bincount(lab[core]).argmax()
    in_best = core & (lab == best)
    # border points: within eps of a core point of the cluster
    d, _ = cKDTree(x[in_best]).query(x, k=1, distance_upper_bound=eps * (1 + 1e-9))
    return np.isfinite(d)


def _candidate_pairs(lo: np.ndarray, hi: np.ndarray, max_gap: float) -> np.ndarray:
    """Node pairs ``u < v`` whose boxes are within ``max_gap``; O(K^2) over boxes only, chunked."""
    k = lo.shape[0]
    out = []
    chunk = 512
    for s in range(0, k, chunk):
        lo_a, hi_a = lo[s : s + chunk, None, :], hi[s : s + chunk, None, :]
        gap = np.maximum(0.0, np.maximum(lo[None] - hi_a, lo_a - hi[None]))
        d2 = np.einsum("abk,abk->ab", gap, gap)
        a, b = np.nonzero(d2 <= max_gap * max_gap)
        a = a + s
        sel = a < b
        out.append(np.stack([a[sel], b[sel]]))
    return np.concatenate(out, 1) if out else np.zeros((2, 0), np.int64)


def _batched_directed(
    sets: PointSets,
    src: np.ndarray,
    dst: np.ndarray,
    tau: float,
    *,
    centroids: np.ndarray | None = None,
    boxes: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """``D(sets[src[e]], sets[dst[e]])`` for every e, one k-d tree query per distinct ``dst``.

    With per-node ``centroids`` ``[N, 3]`` and ``boxes`` (``lo``, ``hi`` ``[N, 3]``),
    pairs whose source centroid lies farther than ``sqrt(tau)`` from the target's
    box are dropped first (O(1) per pair).

    Pairs whose mean squared distance to the target's bounding box (a lower
    bound of D) exceeds ``tau`` are never queried. Queries are bounded by
    ``sqrt(tau * |X|)``: a single point farther than that already makes the
    mean exceed ``tau``, so such pairs come back as inf.
    """
    out = np.full(src.size, np.inf)
    if src.size == 0:
        return out
    if centroids is not None and boxes is not None:
        # Jensen: the squared distance to a box is convex, so its value at the source's
        # centroid is <= its mean over the source points (the bound below) <= D. Pairs
        # failing this pair-level test (with a rounding margin) would fail the per-point
        # bound too; they are dropped before any per-point work.
        c = centroids[src]
        gap = np.maximum(0.0, np.maximum(boxes[0][dst] - c, c - boxes[1][dst]))
        alive = np.flatnonzero(np.einsum("ij,ij->i", gap, gap) <= tau * (1 + 1e-6))
        if alive.size < src.size:
            out[alive] = _batched_directed(sets, src[alive], dst[alive], tau, boxes=boxes)
            return out
    order = np.argsort(dst, kind="stable")
    bounds = np.flatnonzero(np.r_[True, dst[order][1:] != dst[order][:-1], True])
    for a, b in zip(bounds[:-1], bounds[1:]):
        idx = order[a:b]
        t = int(dst[idx[0]])
        target_pts = sets[t]
        lo, hi = (boxes[0][t], boxes[1][t]) if boxes is not None else (target_pts.min(0), target_pts.max(0))
        chunks = [sets[int(s)] for s in src[idx]]
        lens = np.array([len(c) for c in chunks])
        x = np.concatenate(chunks)
        starts = np.r_[0, np.cumsum(lens)[:-1]]
        # lower bound: squared distance of each x to the target's bounding box
        gap = np.maximum(0.0, np.maximum(lo - x, x - hi))
        lower = np.add.reduceat(np.einsum("ij,ij->i", gap, gap), starts) / lens
        live = lower <= tau
        if not live.any():
            continue
        keep_pts = np.repeat(live, lens)
        x, lens = x[keep_pts], lens[live]
        starts = np.r_[0, np.cumsum(lens)[:-1]]
        bound = float(np.sqrt(tau * lens.max())) * (1 + 1e-9)
        dd, _ = cKDTree(target_pts).query(x, k=1, distance_upper_bound=bound)
        means = np.add.reduceat(dd * dd, starts) / lens
        out[idx[live]] = np.where(np.isfinite(means), means, np.inf)
    return out


def chamfer_edges(sets: PointSets, tau: float, *, prune: bool) -> EdgeSet:
    """Edges between nodes with ``min(D(X, Y), D(Y, X)) <= tau``.

    Both options are required; their defaults are those of
    :class:`Chamfer3D.Options` (``tau``, ``prune``).

    Parameters
    ----------
    sets : PointSets
        Per-node points (already downsampled / cleaned).
    tau : float
        Threshold in m^2 (paper: :data:`~graphseg.published.TAU_3D_PAPER`;
        official code: :data:`~graphseg.published.TAU_3D_OFFICIAL`).
    prune : bool
        Skip pairs whose bounding boxes are farther apart than ``sqrt(tau)``: if
        ``D(X, Y) <= tau`` some ``x`` lies within ``sqrt(tau)`` of ``Y``, so such
        pairs can never pass. With ``prune=False`` every pair is tested.

    Returns
    -------
    EdgeSet
        Columns ``criterion`` ("chamfer_3d"), ``distance`` (m^2) and ``weight`` =
        ``1 / (1 + distance / tau)``; ``info`` has the candidate count.

    Notes
    -----
    Box test O(K^2) over ``K`` nodes (not over points); each candidate costs one
    k-d tree query of the smaller set, with an early exit.

    Examples
    --------
    >>> a = np.zeros((4, 3)); a[:, 0] = [0, 0.01, 0.02, 0.03]
    >>> sets = PointSets(np.r_[a, a + [0.005, 0, 0], a + [1, 0, 0]], np.array([0, 4, 8, 12]))
    >>> es = chamfer_edges(sets, 5e-4, prune=True)
    >>> es.edge_index.tolist(), es.edge_attr["distance"].round(7).tolist()
    ([[0], [1]], [2.5e-05])
    """
    k = sets.num_nodes
    sizes = sets.sizes()
    nonempty = np.flatnonzero(sizes > 0)
    if nonempty.size < 2:
        return EdgeSet(np.zeros((2, 0), np.int64), {"criterion": np.zeros(0, "<U10"), "distance": np.zeros(0), "weight": np.zeros(0)}, {"candidates": 0})
    # points are stored by node (CSR): per-node boxes and centroids are segment reductions
    starts = sets.ptr[nonempty]
    lo = np.minimum.reduceat(sets.points, starts, axis=0).astype(np.float64, copy=False)
    hi = np.maximum.reduceat(sets.points, starts, axis=0).astype(np.float64, copy=False)
    boxes = (np.full((k, 3), np.inf), np.full((k, 3), -np.inf))
    boxes[0][nonempty], boxes[1][nonempty] = lo, hi
    centroids = np.zeros((k, 3))
    centroids[nonempty] = np.add.reduceat(sets.points, starts, axis=0) / sizes[nonempty, None]
    if prune:
        cand = _candidate_pairs(lo, hi, float(np.sqrt(tau)))
    else:
        a, b = np.triu_indices(nonempty.size, 1)
        cand = np.stack([a, b])
    cand = nonempty[cand]
    if cand.shape[1] == 0:
        us = vs = np.zeros(0, np.int64)
        dist = np.zeros(0)
    else:
        # D(small -> big) for every candidate, batched: one tree query per target node
        small = np.where(sizes[cand[0]] <= sizes[cand[1]], cand[0], cand[1])
        big = np.where(sizes[cand[0]] <= sizes[cand[1]], cand[1], cand[0])
        d = _batched_directed(sets, small, big, tau, centroids=centroids, boxes=boxes)
        retry = d > tau
        if retry.any():  # the other direction only where the first failed
            d[retry] = np.minimum(d[retry], _batched_directed(sets, big[retry], small[retry], tau, centroids=centroids, boxes=boxes))
        ok = d <= tau
        us, vs, dist = cand[0][ok], cand[1][ok], d[ok]
    dist = np.asarray(dist, np.float64)
    return EdgeSet(
        np.stack([us, vs]).astype(np.int64).reshape(2, -1),
        {"criterion": np.full(len(us), "chamfer_3d"), "distance": dist, "weight": 1.0 / (1.0 + dist / tau)},
        {"candidates": int(cand.shape[1]), "tau": tau},
    )


def point_spacing(sets: PointSets) -> np.ndarray:
    """Median nearest-neighbour distance within each node's point set ``[N]`` (NaN with < 2 points).

    Examples
    --------
    >>> s = point_spacing(PointSets(np.array([[0.0, 0, 0], [0.1, 0, 0], [0.3, 0, 0]]), np.array([0, 3, 3])))
    >>> np.round(s, 3).tolist()[0], bool(np.isnan(s[1]))
    (0.1, True)

    Notes
    -----
    One k-d tree per node: O(P log P) in total.
    """
    out = np.full(sets.num_nodes, np.nan)
    for k in range(sets.num_nodes):
        x = sets[k]
        if len(x) >= 2:
            d, _ = cKDTree(x).query(x, k=2)
            out[k] = float(np.median(d[:, 1]))
    return out


def spacing_aware_chamfer_edges(sets: PointSets, tau: float, *, factor: float, prune: bool) -> EdgeSet:
    """:func:`chamfer_edges` with the per-pair threshold ``max(tau, (factor * max(s_i, s_j))^2)``.

    Two independent samplings of one surface are not point-to-point aligned:
    for random samples with median nearest-neighbour spacing ``s`` the directed
    Chamfer distance is about ``1.44 s^2`` even when the surfaces coincide, so
    sparse sets (structure from motion, ``s`` of centimetres) would fail every
    test. ``s_k`` is :func:`point_spacing`; for dense sets this is exactly
    :func:`chamfer_edges`. Every option is required; the ``chamfer_3d``
    criterion passes its ``tau``, ``spacing_factor`` and ``prune``.

    Parameters
    ----------
    sets : PointSets
    tau : float
        The floor (the dense-point threshold).
    factor : float
        Multiple of the spacing allowed as RMS nearest-neighbour distance
        (:data:`SPACING_FACTOR` = 1.5: random samplings of one surface give about 1.2 s).
    prune : bool
        As in :func:`chamfer_edges`.

    Returns
    -------
    EdgeSet
        As :func:`chamfer_edges`, plus the column ``tau`` (the threshold each edge met).

    Examples
    --------
    >>> a = np.c_[np.arange(0, 1, 0.1), np.zeros(10), np.zeros(10)]      # spacing 0.1
    >>> sets = PointSets(np.r_[a, a + [0.05, 0, 0]], np.array([0, 10, 20]))
    >>> chamfer_edges(sets, 1e-4, prune=True).num_edges, spacing_aware_chamfer_edges(sets, 1e-4, factor=SPACING_FACTOR, prune=True).num_edges
    (0, 1)
    """
    if not tau > 0 or not factor >= 0:
        raise ValueError(f"expected tau > 0 and factor >= 0 (got {tau}, {factor})")
    s = np.nan_to_num(point_spacing(sets), nan=0.0)
    node_tau = np.maximum(tau, (factor * s) ** 2)
    es = chamfer_edges(sets, float(node_tau.max()) if node_tau.size else tau, prune=prune)
    i, j = es.edge_index
    pair_tau = np.maximum(node_tau[i], node_tau[j]) if i.size else np.zeros(0)
    keep = es.edge_attr["distance"] <= pair_tau
    attr = {k: v[keep] for k, v in es.edge_attr.items()}
    attr["weight"] = 1.0 / (1.0 + attr["distance"] / pair_tau[keep]) if keep.any() else np.zeros(0)
    attr["tau"] = pair_tau[keep]
    return EdgeSet(es.edge_index[:, keep], attr, {**es.info, "tau": tau, "factor": factor})


def strongest_attachments(edge_index: np.ndarray, weight: np.ndarray, size: np.ndarray, ratio: float) -> np.ndarray:
    """Which edges to keep so that a fragment joins at most one larger node.

    An edge is an *attachment* of its smaller end when that end has less than
    ``ratio`` of the other end's size; among its attachments a node keeps only
    the strongest (largest ``weight``; ties: the first). Edges between nodes of
    comparable size are all kept. A small node near two objects thus attaches
    to the closer one instead of bridging them.

    Parameters
    ----------
    edge_index : int ``[2, E]``
    weight : float ``[E]``
        Strength, larger = stronger.
    size : float ``[N]``
        Node size (pixels or points).
    ratio : float
        In ``(0, 1]``.

    Returns
    -------
    bool ``[E]``

    Notes
    -----
    O(E log E).

    Examples
    --------
    >>> ei = np.array([[0, 0, 1], [1, 2, 2]])         # fragment 0 next to objects 1 and 2
    >>> strongest_attachments(ei, np.array([0.9, 0.5, 0.7]), np.array([10, 500, 400]), 0.25).tolist()
    [True, False, True]
    """
    ei = np.asarray(edge_index, np.int64).reshape(2, -1)
    w = np.asarray(weight, np.float64).reshape(-1)
    sz = np.asarray(size, np.float64).reshape(-1)
    if w.shape != (ei.shape[1],):
        raise ValueError(f"expected weight of shape [{ei.shape[1]}] (got {list(w.shape)})")
    if not 0 < ratio <= 1:
        raise ValueError(f"expected ratio in (0, 1] (got {ratio})")
    keep = np.ones(ei.shape[1], bool)
    if ei.shape[1] == 0:
        return keep
    a, b = sz[ei[0]], sz[ei[1]]
    small = np.where(a <= b, ei[0], ei[1])
    attach = np.minimum(a, b) < ratio * np.maximum(a, b)
    idx = np.flatnonzero(attach)
    if idx.size:
        order = idx[np.lexsort((-w[idx], small[idx]))]
        first = np.ones(order.size, bool)
        first[1:] = small[order][1:] != small[order][:-1]
        keep[order[~first]] = False
    return keep


class Chamfer3D(Criterion):
    """The ``chamfer_3d`` criterion: gathers node points, downsamples, cleans, tests.

    Options (:class:`Chamfer3D.Options`): ``tau`` (m^2; 5e-4 as in the paper,
    :data:`~graphseg.published.TAU_3D_PAPER`; the official code used 5e-5,
    :data:`~graphseg.published.TAU_3D_OFFICIAL`), ``voxel_size`` (metres, None = no
    downsampling), ``stride`` (pixel stride when gathering points),
    ``outliers`` (None, ``"statistical"`` or ``"dbscan"``, with
    ``outlier_k``/``outlier_std_ratio`` and ``dbscan_eps``/``dbscan_min_samples``)
    and ``prune`` (bounding-box pruning, see :func:`chamfer_edges`).

    For lifted points (structure from motion, a learned lifter) three options
    make the test tolerate them; all are off by default:

    * ``min_confidence``: points whose confidence (``Evidence.confidence``;
      views without one keep every point) is below it are ignored;
    * ``spacing_factor``: each pair's threshold grows with the point spacing,
      ``max(tau, (spacing_factor * max(s_i, s_j))^2)``
      (:func:`spacing_aware_chamfer_edges`);
    * ``fragment_ratio``: a node smaller than this share of a node it would
      join keeps only its strongest such edge (:func:`strongest_attachments`),
      so noisy fragments between two objects join one, never bridge both.

    Examples
    --------
    >>> lab = [np.array([[0, 1]])]
    >>> pts = [np.array([[[0, 0, 0], [0.01, 0, 0]]], dtype=np.float32)]
    >>> g = CorrespondenceGraph(2, node_attr={"area": [1, 1]})
    >>> Chamfer3D(Chamfer3D.Options(voxel_size=None, stride=1))(g, Evidence(lab, points=pts)).edge_index.tolist()
    [[0], [1]]
    """

    class Options(BaseModel):
        """Options of ``chamfer_3d``."""

        model_config = ConfigDict(extra="forbid")
        tau: float = Field(TAU_3D_PAPER, gt=0, description="m^2; the paper states 5e-4, the official code used 5e-5")
        voxel_size: float | None = Field(0.005, gt=0, description="metres; None = no downsampling")
        stride: int = Field(2, ge=1, description="pixel stride when gathering points")
        outliers: Literal["statistical", "dbscan"] | None = None
        outlier_k: int = Field(8, ge=1, description="statistical: neighbours per point")
        outlier_std_ratio: float = Field(2.0, gt=0, description="statistical: standard deviations")
        dbscan_eps: float = Field(0.02, gt=0, description="dbscan: neighbourhood radius (metres)")
        dbscan_min_samples: int = Field(5, ge=1)
        prune: bool = True
        min_confidence: float | None = Field(None, ge=0, description="ignore points whose confidence is below this (None: use every point)")
        spacing_factor: float | None = Field(None, ge=0, description="per-pair threshold max(tau, (spacing_factor * point spacing)^2) (None: tau alone)")
        fragment_ratio: float | None = Field(
            None, gt=0, le=1, description="a node below this share of the area of a node it would join keeps only its strongest such edge (None: keep all)"
        )

    name = "chamfer_3d"
    requires = frozenset({"points", "confidence"})
    reduce = {"distance": "min", "weight": "max"}
    tags = {"dimension": "3d"}
    options: Chamfer3D.Options

    def point_sets(self, graph: CorrespondenceGraph, evidence: Evidence) -> PointSets:
        """The cleaned, downsampled point set of every node."""
        if evidence.points is None:
            raise ValueError("chamfer_3d needs world points (Evidence.points)")
        o = self.options
        points: list[np.ndarray | None] = list(evidence.points)
        if o.min_confidence is not None and evidence.confidence is not None:
            t = float(o.min_confidence)
            for v, c in enumerate(evidence.confidence):
                if c is not None:  # unsure points become invalid (NaN); a view without confidence keeps all
                    p = np.array(points[v], np.float32)  # a copy: the evidence is never changed
                    p[np.asarray(c) < t] = np.nan
                    points[v] = p
        sets = node_point_sets(evidence.node_labels, points, graph.num_nodes, stride=o.stride, voxel_size=o.voxel_size)
        return remove_outliers(
            sets, o.outliers, k=o.outlier_k, std_ratio=o.outlier_std_ratio, eps=o.dbscan_eps, min_samples=o.dbscan_min_samples
        )

    def __call__(self, graph: CorrespondenceGraph, evidence: Evidence) -> EdgeSet:
        o = self.options
        sets = self.point_sets(graph, evidence)
        if o.spacing_factor is not None:
            es = spacing_aware_chamfer_edges(sets, o.tau, factor=o.spacing_factor, prune=o.prune)
        else:
            es = chamfer_edges(sets, o.tau, prune=o.prune)
        if o.fragment_ratio is not None and es.num_edges:
            size = np.asarray(graph.node_attr["area"], np.float64) if "area" in graph.node_attr else sets.sizes().astype(np.float64)
            keep = strongest_attachments(es.edge_index, es.edge_attr["weight"], size, o.fragment_ratio)
            es = EdgeSet(es.edge_index[:, keep], {k: v[keep] for k, v in es.edge_attr.items()}, {**es.info, "detached": int((~keep).sum())})
        return es
