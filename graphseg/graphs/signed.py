"""Contractors on signed edges: attractive evidence joins, repulsive evidence forbids.

Connected components trust every edge, so one wrong edge merges two objects.
Here edges carry a ``sign`` column (``< 0``: repulsive, a *cannot-link*) and a
``weight`` (strength of attraction). :func:`constrained_union_find` takes the
attractive edges strongest first and joins two clusters only when no
cannot-link joins them; with no cannot-links it equals connected components.

Examples
--------
>>> import numpy as np
>>> ei = np.array([[0, 1], [1, 2]])            # 0-1 and 1-2
>>> constrained_union_find(ei, 3).tolist()
[0, 0, 0]
>>> constrained_union_find(ei, 3, weight=[0.9, 0.5], cannot_link=[[0], [2]]).tolist()
[0, 0, 1]
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from .coalesce import canonical_cluster
from .contractor import BaseContractor, run_contractor, split_signed
from .graph import as_edge_index

# run_contractor and split_signed (now in contractor) stay importable from here
__all__ = [
    "constrained_union_find",
    "core_attach_contraction",
    "edge_strength",
    "greedy_additive_contraction",
    "run_contractor",
    "signed_edges",
    "split_signed",
    "ConstrainedUnionFindContraction",
    "CoreAttachContraction",
    "GreedyAdditiveContraction",
]


def constrained_union_find(edge_index: Any, num_nodes: int, *, weight: Any = None, cannot_link: Any = None) -> np.ndarray:
    """Union-find over edges strongest first that never joins a cannot-link pair.

    Parameters
    ----------
    edge_index : array_like of int, shape ``[2, E]``
        Attractive edges.
    num_nodes : int
    weight : array_like of float, shape ``[E]``, optional
        Strength of each edge; larger is taken first (ties: input order).
        Default: all equal.
    cannot_link : array_like of int, shape ``[2, C]``, optional
        Node pairs that must end in different clusters. A pair already joined
        by nothing else is honoured: the edge that would join their clusters
        is skipped, and the constraint moves with the merged clusters.

    Returns
    -------
    numpy.ndarray
        Canonical cluster ids, int64 ``[N]``.

    Notes
    -----
    O(E log E + (E + C) alpha(N)) plus the merging of the per-cluster
    cannot-link sets (smaller into larger: O(C log C)). Self-loop cannot-links
    are ignored.

    Examples
    --------
    >>> constrained_union_find(np.zeros((2, 0), np.int64), 2).tolist()
    [0, 1]
    """
    n = int(num_nodes)
    ei = as_edge_index(edge_index, n)
    w = np.zeros(ei.shape[1]) if weight is None else np.asarray(weight, np.float64).reshape(-1)
    if w.shape != (ei.shape[1],):
        raise ValueError(f"expected weight of shape [{ei.shape[1]}] (got {list(w.shape)})")
    cl = as_edge_index(np.zeros((2, 0), np.int64) if cannot_link is None else cannot_link, n)
    parent = list(range(n))

    def find(x: int) -> int:
        root = x
        while parent[root] != root:
            root = parent[root]
        while parent[x] != root:
            parent[x], x = root, parent[x]
        return root

    forbid: list[set[int]] = [set() for _ in range(n)]
    for a, b in cl.T.tolist():
        if a != b:
            forbid[a].add(b)
            forbid[b].add(a)
    order = np.argsort(-w, kind="stable")
    src, dst = ei[0, order].tolist(), ei[1, order].tolist()
    for u, v in zip(src, dst):
        ru, rv = find(u), find(v)
        if ru == rv or rv in forbid[ru]:
            continue
        if len(forbid[ru]) < len(forbid[rv]):
            ru, rv = rv, ru
        parent[rv] = ru  # rv joins ru: move rv's constraints to ru
        for x in forbid[rv]:
            forbid[x].discard(rv)
            forbid[x].add(ru)
            forbid[ru].add(x)
        forbid[rv] = set()
    return canonical_cluster(np.fromiter((find(i) for i in range(n)), np.int64, n))


def greedy_additive_contraction(
    edge_index: Any, num_nodes: int, *, weight: Any = None, cannot_link: Any = None, repulsion: float | None = None, core: Any = None
) -> np.ndarray:
    """Greedy additive edge contraction (GAEC, a multicut heuristic) with hard or weighted cannot-links.

    Every cluster pair carries the *sum* of the weights of the edges between
    its members. The pair with the largest sum is joined first and the sums
    of the joined cluster are added up, so a cluster that many edges tie
    together closes before a single strong edge can pull a part of it
    elsewhere. Cannot-link pairs never join (their sum is -inf). Unlike
    :func:`constrained_union_find`, which takes edges one by one, this lets the
    evidence of many edges outweigh one: parts of an object join each other,
    and the cannot-link of one of them then keeps the whole object apart.

    Parameters
    ----------
    edge_index : array_like of int, shape ``[2, E]``
        Attractive edges (parallel edges add up; self-loops are ignored).
    num_nodes : int
    weight : array_like of float, shape ``[E]``, optional
        Positive attraction of each edge; default all 1.
    cannot_link : array_like of int, shape ``[2, C]``, optional
        Node pairs that must end in different clusters.
    repulsion : float, optional
        None (default): cannot-links are hard (a pair's sum is -inf). A number:
        each cannot-link adds ``-repulsion`` to its pair's sum instead, so
        enough attraction between two clusters outweighs it (the multicut
        objective with signed weights).
    core : array_like of bool ``[N]``, optional
        Fragments never bridge: with ``core`` given, the core nodes are
        contracted first using only the edges among them; then each other node
        (a fragment) joins the one core cluster with the largest positive sum of
        its edges (minus its cannot-links) to that cluster, and fragments with no
        such cluster are contracted among themselves. A fragment thus joins at
        most one object and never ties two core clusters together.

    Returns
    -------
    numpy.ndarray
        Canonical cluster ids, int64 ``[N]``.

    Notes
    -----
    O((E + C) log(E + C)) heap operations; cluster adjacencies merge smaller
    into larger. Pure Python loops: about 1 s per 10^5 edges. Without
    cannot-links it equals connected components.

    Examples
    --------
    >>> ei = np.array([[0, 1, 0], [1, 2, 2]])     # a triangle 0-1-2
    >>> greedy_additive_contraction(ei, 4, weight=[0.9, 0.8, 0.3]).tolist()
    [0, 0, 0, 1]
    >>> greedy_additive_contraction(ei, 3, weight=[0.9, 0.8, 0.3], cannot_link=[[0], [2]]).tolist()
    [0, 0, 1]
    >>> greedy_additive_contraction(ei, 3, weight=[0.9, 0.8, 0.3], cannot_link=[[0], [2]], repulsion=0.5).tolist()
    [0, 0, 0]
    >>> bridge = np.array([[0, 1], [1, 2]])      # core 0 - fragment 1 - core 2
    >>> greedy_additive_contraction(bridge, 3, weight=[0.4, 0.9], core=[True, False, True]).tolist()
    [0, 1, 1]
    """
    if core is not None:
        return _core_first(edge_index, num_nodes, weight=weight, cannot_link=cannot_link, repulsion=repulsion, core=core)
    import heapq

    n = int(num_nodes)
    ei = as_edge_index(edge_index, n)
    w = np.ones(ei.shape[1]) if weight is None else np.asarray(weight, np.float64).reshape(-1)
    if w.shape != (ei.shape[1],):
        raise ValueError(f"expected weight of shape [{ei.shape[1]}] (got {list(w.shape)})")
    if not np.all(np.isfinite(w) & (w > 0)):
        raise ValueError(f"expected positive finite weights (got min {w.min():g})")
    cl = as_edge_index(np.zeros((2, 0), np.int64) if cannot_link is None else cannot_link, n)
    adj: list[dict[int, float]] = [{} for _ in range(n)]
    for a, b, x in zip(ei[0].tolist(), ei[1].tolist(), w.tolist()):
        if a != b:
            adj[a][b] = adj[a].get(b, 0.0) + x
            adj[b][a] = adj[a][b]
    if repulsion is not None and not (np.isfinite(repulsion) and repulsion > 0):
        raise ValueError(f"expected a positive finite repulsion or None (got {repulsion})")
    for a, b in cl.T.tolist():
        if a != b:
            adj[a][b] = adj[b][a] = -np.inf if repulsion is None else adj[a].get(b, 0.0) - float(repulsion)
    heap = [(-x, a, b) for a in range(n) for b, x in adj[a].items() if a < b and x > 0]
    heapq.heapify(heap)
    parent = np.arange(n)
    alive = np.ones(n, bool)
    while heap:
        negw, a, b = heapq.heappop(heap)
        if not (alive[a] and alive[b]) or adj[a].get(b) != -negw:
            continue  # stale: a side was merged or the sum changed
        if len(adj[a]) < len(adj[b]):
            a, b = b, a
        # b joins a: add b's sums into a's
        del adj[a][b]
        del adj[b][a]
        for c, x in adj[b].items():
            del adj[c][b]
            y = adj[a].get(c, 0.0) + x
            adj[a][c] = adj[c][a] = y
            if y > 0:
                heapq.heappush(heap, (-y, min(a, c), max(a, c)))
        adj[b] = {}
        alive[b] = False
        parent[b] = a
    while True:  # resolve merge chains
        nxt = parent[parent]
        if np.array_equal(nxt, parent):
            break
        parent = nxt
    return canonical_cluster(parent)


def _core_first(edge_index: Any, num_nodes: int, *, weight: Any, cannot_link: Any, repulsion: float | None, core: Any) -> np.ndarray:
    """:func:`greedy_additive_contraction` with ``core``: core nodes first, then each fragment joins one cluster."""
    n = int(num_nodes)
    ei = as_edge_index(edge_index, n)
    is_core = np.asarray(core, bool).reshape(-1)
    if is_core.shape != (n,):
        raise ValueError(f"expected core of shape [{n}] (got {list(is_core.shape)})")
    w = np.ones(ei.shape[1]) if weight is None else np.asarray(weight, np.float64).reshape(-1)
    if w.shape != (ei.shape[1],):
        raise ValueError(f"expected weight of shape [{ei.shape[1]}] (got {list(w.shape)})")
    cl = as_edge_index(np.zeros((2, 0), np.int64) if cannot_link is None else cannot_link, n)
    both = is_core[ei[0]] & is_core[ei[1]]
    cluster = greedy_additive_contraction(ei[:, both], n, weight=w[both], cannot_link=cl, repulsion=repulsion)
    # each fragment: summed evidence to every core cluster (edges add, cannot-links subtract)
    frag_end = np.concatenate([ei[0], ei[1]])
    core_end = np.concatenate([ei[1], ei[0]])
    ww = np.concatenate([w, w])
    sel = ~is_core[frag_end] & is_core[core_end]
    f, c, x = frag_end[sel], cluster[core_end[sel]], ww[sel]
    cf = np.concatenate([cl[0], cl[1]])
    cc = np.concatenate([cl[1], cl[0]])
    csel = ~is_core[cf] & is_core[cc]
    rep = -np.inf if repulsion is None else -float(repulsion)
    f = np.concatenate([f, cf[csel]])
    c = np.concatenate([c, cluster[cc[csel]]])
    x = np.concatenate([x, np.full(int(csel.sum()), rep)])
    joined = np.full(n, -1, np.int64)
    if f.size:
        key, inv = np.unique(f * (n + 1) + c, return_inverse=True)
        total = np.zeros(key.size)
        np.add.at(total, inv, x)
        kf, kc = key // (n + 1), key % (n + 1)
        # strongest (fragment, cluster) first; a fragment's cannot-links to fragments that already
        # joined that cluster count too (hard: it may not join there; it tries its next cluster)
        frag_cl: dict[int, list[int]] = {}
        for a, b in zip(cf[~is_core[cf] & ~is_core[cc]].tolist(), cc[~is_core[cf] & ~is_core[cc]].tolist()):
            frag_cl.setdefault(a, []).append(b)
        for k in np.argsort(-total, kind="stable").tolist():
            frag, clus, tot = int(kf[k]), int(kc[k]), float(total[k])
            if tot <= 0:
                break
            if joined[frag] >= 0:
                continue
            clash = sum(1 for o in frag_cl.get(frag, ()) if joined[o] == clus)
            if clash and (repulsion is None or tot - clash * float(repulsion) <= 0):
                continue
            joined[frag] = clus
    # fragments with no core cluster: contracted among themselves
    free = ~is_core & (joined < 0)
    fe = free[ei[0]] & free[ei[1]]
    fc = free[cl[0]] & free[cl[1]]
    sub = greedy_additive_contraction(ei[:, fe], n, weight=w[fe], cannot_link=cl[:, fc], repulsion=repulsion)
    out = np.where(is_core, cluster, np.where(joined >= 0, joined, n + sub))
    return canonical_cluster(out)


def edge_strength(edge_attr: Mapping[str, Any], num_edges: int) -> np.ndarray:
    """Comparable strength in ``(0, 1]`` of every edge from its ``weight`` and ``criterion``.

    Weights of different criteria are not on one scale, so each criterion's
    weights become their rank fraction within that criterion (the strongest
    edge of each criterion gets 1). Missing ``weight``: all 1.

    Examples
    --------
    >>> edge_strength({"weight": np.array([0.2, 0.9, 5.0]), "criterion": np.array(["a", "a", "b"])}, 3).tolist()
    [0.5, 1.0, 1.0]
    """
    w = edge_attr.get("weight")
    if w is None:
        return np.ones(num_edges)
    w = np.asarray(w, np.float64)
    crit = edge_attr.get("criterion")
    groups = np.zeros(num_edges, np.int64) if crit is None else np.unique(np.asarray(crit).astype(str), return_inverse=True)[1]
    out = np.ones(num_edges)
    for g in np.unique(groups):
        sel = np.flatnonzero(groups == g)
        rank = np.argsort(np.argsort(w[sel], kind="stable"), kind="stable")
        out[sel] = (rank + 1) / sel.size
    return out


def signed_edges(edge_index: Any, num_nodes: int, edge_attr: Mapping[str, Any] | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What every signed contractor reads from a graph's edges.

    Returns
    -------
    attract : int64 ``[2, A]``
        Edges with ``sign >= 0`` or no sign.
    strength : float64 ``[A]``
        Their :func:`edge_strength`.
    cannot_link : int64 ``[2, C]``
        Edges with ``sign < 0``.

    Examples
    --------
    >>> a, s, c = signed_edges(np.array([[0, 1], [1, 2]]), 3, {"sign": np.array([1.0, -1.0]), "weight": np.array([0.3, 0.9])})
    >>> a.tolist(), s.tolist(), c.tolist()
    ([[0], [1]], [1.0], [[1], [2]])
    """
    ei = as_edge_index(edge_index, num_nodes)
    attrs = dict(edge_attr or {})
    pos, neg = split_signed(ei, attrs)
    strength = edge_strength({k: np.asarray(v)[pos] for k, v in attrs.items()}, int(pos.sum()))
    return ei[:, pos], strength, ei[:, neg]


class _SignedContraction(BaseContractor):
    """A contractor that runs ``solve(attract, num_nodes, weight=strength, cannot_link=...)`` on :func:`signed_edges`.

    Called as ``contractor(edge_index, num_nodes, rng=rng, edge_attr=attrs)``
    (``uses_edge_attr = True``): edges with ``sign < 0`` are cannot-links, the
    others attract with their :func:`edge_strength`. Subclasses set ``solve``.
    """

    uses_edge_attr = True
    solve: Any = None

    def __call__(self, edge_index: Any, num_nodes: int, *, rng: Any = None, edge_attr: Mapping[str, Any] | None = None) -> np.ndarray:
        attract, strength, cannot = signed_edges(edge_index, num_nodes, edge_attr)
        return self.solve(attract, num_nodes, weight=strength, cannot_link=cannot)


class ConstrainedUnionFindContraction(_SignedContraction):
    """Contractor: :func:`constrained_union_find` (edges one by one, strongest first) on a graph's signed edges.

    Examples
    --------
    >>> ConstrainedUnionFindContraction()(np.array([[0, 1, 0], [1, 2, 2]]), 3, edge_attr={"sign": np.array([1.0, 1.0, -1.0])}).tolist()
    [0, 0, 1]
    """

    name = "constrained"
    solve = staticmethod(constrained_union_find)


def core_attach_contraction(edge_index: Any, num_nodes: int, *, core: Any, weight: Any = None, cannot_link: Any = None) -> np.ndarray:
    """Join core nodes by their edges; every other node follows its one strongest edge.

    Small masks (fragments at object boundaries) carry most wrong edges on real
    data. Here they cannot bridge two objects: edges between two *core* nodes
    are contracted by :func:`constrained_union_find`; each non-core node keeps
    only its strongest incident edge. Every non-core node thus has one outgoing
    link, so a component contains at most one group of joined core nodes.

    Parameters
    ----------
    edge_index : array_like of int ``[2, E]``
    num_nodes : int
    core : array_like of bool ``[N]``
    weight : array_like of float ``[E]``, optional
        Edge strength (larger first); default all equal (first edge wins).
    cannot_link : array_like of int ``[2, C]``, optional
        Honoured among core nodes.

    Returns
    -------
    numpy.ndarray
        Canonical cluster ids, int64 ``[N]``.

    Notes
    -----
    O(E log E + N).

    Examples
    --------
    >>> ei = np.array([[0, 1], [1, 2]])     # core 0 - leaf 1 - core 2
    >>> core_attach_contraction(ei, 3, core=[True, False, True], weight=[0.4, 0.9]).tolist()
    [0, 1, 1]
    """
    n = int(num_nodes)
    ei = as_edge_index(edge_index, n)
    core = np.asarray(core, bool).reshape(-1)
    if core.shape != (n,):
        raise ValueError(f"expected core of shape [{n}] (got {list(core.shape)})")
    w = np.zeros(ei.shape[1]) if weight is None else np.asarray(weight, np.float64).reshape(-1)
    if w.shape != (ei.shape[1],):
        raise ValueError(f"expected weight of shape [{ei.shape[1]}] (got {list(w.shape)})")
    both = core[ei[0]] & core[ei[1]]
    base = constrained_union_find(ei[:, both], n, weight=w[both], cannot_link=cannot_link)
    # each non-core endpoint's strongest incident edge (ties: first edge)
    ends = np.concatenate([ei[0], ei[1]])
    other = np.concatenate([ei[1], ei[0]])
    ww = np.concatenate([w, w])
    sel = ~core[ends] & (ends != other)
    ends, other, ww = ends[sel], other[sel], ww[sel]
    order = np.lexsort((-ww, ends))
    first = np.ones(order.size, bool)
    first[1:] = ends[order][1:] != ends[order][:-1]
    pick = order[first]
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    # link every node to a representative (first node) of its core group, then leaves to their pick
    rep = np.zeros(int(base.max(initial=-1)) + 1, np.int64)
    rep[base[::-1]] = np.arange(n)[::-1]
    u = np.concatenate([np.arange(n), ends[pick]])
    v = np.concatenate([rep[base], other[pick]])
    adj = coo_matrix((np.ones(u.size), (u, v)), shape=(n, n))
    _, labels = connected_components(adj, directed=False)
    return canonical_cluster(labels)


class CoreAttachContraction(BaseContractor):
    """Contractor: :func:`core_attach_contraction`; core = nodes with ``area >= min_area``.

    Takes ``edge_attr`` (strength from :func:`edge_strength`, ``sign < 0`` =
    cannot-link) and ``node_attr`` (``area``): ``uses_edge_attr = True`` and
    ``uses_node_attr = True``.

    Examples
    --------
    >>> c = CoreAttachContraction(min_area=10)
    >>> c(np.array([[0, 1], [1, 2]]), 3, edge_attr={"weight": np.array([0.4, 0.9])}, node_attr={"area": np.array([50, 3, 50])}).tolist()
    [0, 1, 1]
    """

    name = "core_attach"
    uses_edge_attr = True
    uses_node_attr = True

    class Options(BaseModel):
        """Options of ``core_attach`` (validated in the config, so a misspelt one is an error there)."""

        model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
        min_area: float = Field(1000.0, description="nodes with at least this area (pixels) are core; the others follow their strongest edge")

    @property
    def min_area(self) -> float:
        """``options.min_area``."""
        return float(self.options.min_area)  # type: ignore[attr-defined]

    def __call__(
        self,
        edge_index: Any,
        num_nodes: int,
        *,
        rng: Any = None,
        edge_attr: Mapping[str, Any] | None = None,
        node_attr: Mapping[str, Any] | None = None,
    ) -> np.ndarray:
        attract, strength, cannot = signed_edges(edge_index, num_nodes, edge_attr)
        area = None if node_attr is None else node_attr.get("area")
        core = np.ones(num_nodes, bool) if area is None else np.asarray(area, np.float64) >= self.min_area
        return core_attach_contraction(attract, num_nodes, core=core, weight=strength, cannot_link=cannot)


class GreedyAdditiveContraction(BaseContractor):
    """Contractor: :func:`greedy_additive_contraction` (strengths summed per cluster pair) on a graph's signed edges.

    Examples
    --------
    >>> GreedyAdditiveContraction()(np.array([[0, 1, 2], [1, 2, 0]]), 3, edge_attr={"sign": np.array([1.0, 1.0, -1.0])}).tolist()
    [0, 0, 1]
    """

    name = "gaec"
    uses_edge_attr = True
    uses_node_attr = True

    class Options(BaseModel):
        """Options of ``gaec`` (validated in the config, so a misspelt one is an error there)."""

        model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
        repulsion: float | None = Field(None, gt=0, description="weight of each cannot-link (None: hard cannot-links)")
        fragment_area: float | None = Field(None, gt=0, description="nodes below this area (pixels) join one core cluster only (None: off)")

    def __init__(self, options: BaseModel | None = None, /, **kwargs: Any) -> None:
        super().__init__(options, **kwargs)
        self.repulsion: float | None = getattr(self.options, "repulsion", None)
        self.fragment_area: float | None = getattr(self.options, "fragment_area", None)

    def __call__(
        self,
        edge_index: Any,
        num_nodes: int,
        *,
        rng: Any = None,
        edge_attr: Mapping[str, Any] | None = None,
        node_attr: Mapping[str, Any] | None = None,
    ) -> np.ndarray:
        attract, strength, cannot = signed_edges(edge_index, num_nodes, edge_attr)
        core = None
        if self.fragment_area is not None:
            area = None if node_attr is None else node_attr.get("area")
            if area is None:
                raise ValueError("gaec with fragment_area needs the node column 'area'")
            core = np.asarray(area, np.float64) >= self.fragment_area
        return greedy_additive_contraction(attract, num_nodes, weight=strength, cannot_link=cannot, repulsion=self.repulsion, core=core)
