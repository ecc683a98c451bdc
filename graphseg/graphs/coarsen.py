"""coarsen(): the one shared step that builds a contracted graph from a cluster vector.

Contractors only return ``cluster`` (node -> component id); :func:`coarsen`
remaps the edges, drops self-loops, merges duplicate edges with a per-column
reduction, and aggregates the node table, as PyG's ``pool_edge`` does.

Examples
--------
>>> import numpy as np
>>> from graphseg.graphs import CorrespondenceGraph
>>> g = CorrespondenceGraph(4, edge_index=[[0, 1, 2], [1, 2, 3]],
...     edge_attr={"criterion": np.array(["pixel_match"] * 3), "weight": [0.5, 0.2, 0.9]},
...     node_attr={"area": [10, 20, 30, 40]})
>>> s = coarsen(g, np.array([0, 0, 1, 1]))
>>> s.node_attr["area"].tolist(), s.edge_index.tolist(), s.edge_attr["weight"].tolist()
([30, 70], [[0], [1]], [0.2])
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from .graph import CorrespondenceGraph, GraphValidationError

__all__ = ["coarsen", "group_reduce", "NODE_REDUCE", "EDGE_REDUCE"]

Reduction = str | tuple[str, str] | Callable[[np.ndarray, np.ndarray, int], np.ndarray]

#: Default node-column reductions; ``None`` drops the column (it lives on in ``members``).
NODE_REDUCE: dict[str, Reduction | None] = {
    "area": "sum",
    "num_points": "sum",
    "member_count": "sum",
    "bbox": "bbox",
    "bbox_3d": "bbox",
    "centroid": ("wmean", "area"),
    "centroid_3d": ("wmean", "num_points"),
    "view": None,
    "mask_id": None,
    "component": None,
}

#: Default edge-column reductions for merged duplicate edges.
EDGE_REDUCE: dict[str, Reduction] = {
    "weight": "max",
    "count": "sum",
    "multiplicity": "sum",
    "stage": "min",
    "distance": "min",
}


def group_reduce(
    values: np.ndarray,
    groups: np.ndarray,
    num_groups: int,
    how: Reduction,
    weights: np.ndarray | None = None,
) -> np.ndarray:
    """Reduce ``values`` (``[N]`` or ``[N, k]``) over ``groups`` (``[N]`` ints).

    Parameters
    ----------
    values : numpy.ndarray
        Rows to reduce.
    groups : numpy.ndarray
        int ``[N]`` group of each row, in ``[0, num_groups)``.
    num_groups : int
    how : str, tuple or callable
        ``"sum"``, ``"mean"``, ``"min"``, ``"max"``, ``"first"``, ``"bbox"`` (min
        over the first half of the columns, max over the second), ``("wmean",
        col)`` (mean weighted by ``weights``), or ``f(values, groups, k)``.
    weights : numpy.ndarray, optional
        ``[N]`` weights for ``"wmean"``.

    Returns
    -------
    numpy.ndarray
        ``[num_groups, ...]``.

    Notes
    -----
    Scatter operations only (``bincount``, ``ufunc.at``): O(N).

    Examples
    --------
    >>> group_reduce(np.array([1, 5, 2]), np.array([0, 1, 0]), 2, "max").tolist()
    [2, 5]
    >>> group_reduce(np.array([[0, 0, 1, 1], [2, 2, 3, 3]]), np.array([0, 0]), 1, "bbox").tolist()
    [[0, 0, 3, 3]]
    """
    if callable(how):
        return np.asarray(how(values, groups, num_groups))
    values = np.asarray(values)
    n = groups.size
    if how == "first":
        first = np.full(num_groups, n, np.int64)
        np.minimum.at(first, groups, np.arange(n, dtype=np.int64))
        return values[np.minimum(first, max(n - 1, 0))] if n else values[:0]
    if values.dtype.kind not in "biuf":
        raise GraphValidationError(f"cannot reduce a {values.dtype} column with {how!r}")
    flat = values.reshape(n, -1) if n else values.reshape(0, int(np.prod(values.shape[1:], dtype=np.int64)))
    if how == "bbox":
        half = flat.shape[1] // 2
        lo = group_reduce(flat[:, :half], groups, num_groups, "min")
        hi = group_reduce(flat[:, half:], groups, num_groups, "max")
        return np.concatenate([lo.reshape(num_groups, half), hi.reshape(num_groups, flat.shape[1] - half)], 1)
    if how in ("sum", "mean") or (isinstance(how, tuple) and how[0] == "wmean"):
        w = weights if isinstance(how, tuple) else None
        if w is not None:
            w = np.asarray(w, dtype=np.float64)
            finite = np.isfinite(flat).all(1) & (w > 0)
        cols = []
        for j in range(flat.shape[1]):
            col = flat[:, j].astype(np.float64)
            if w is not None:
                cols.append(np.bincount(groups[finite], weights=col[finite] * w[finite], minlength=num_groups))
            else:
                cols.append(np.bincount(groups, weights=col, minlength=num_groups))
        out = np.stack(cols, 1) if cols else np.zeros((num_groups, 0))
        if how == "sum":
            if values.dtype.kind in "biu":
                out = np.rint(out).astype(values.dtype if values.dtype.kind != "b" else np.int64)
        else:
            denom = (
                np.bincount(groups[finite], weights=w[finite], minlength=num_groups)
                if w is not None
                else np.bincount(groups, minlength=num_groups).astype(np.float64)
            )
            with np.errstate(invalid="ignore", divide="ignore"):
                out = out / denom[:, None]
        return out.reshape((num_groups,) + values.shape[1:])
    if how in ("min", "max"):
        op: Any
        if flat.dtype.kind == "f":
            init = np.inf if how == "min" else -np.inf
            op = np.fmin if how == "min" else np.fmax
        else:
            info = np.iinfo(flat.dtype) if flat.dtype.kind in "iu" else np.iinfo(np.int8)
            init = info.max if how == "min" else info.min
            op = np.minimum if how == "min" else np.maximum
        out = np.full((num_groups, flat.shape[1]), init, dtype=flat.dtype)
        op.at(out, groups, flat)
        if flat.dtype.kind == "f":
            out[np.isinf(out) & (out == init)] = np.nan
        return out.reshape((num_groups,) + values.shape[1:])
    raise GraphValidationError(f"unknown reduction {how!r}")


def _default_reduce(name: str, col: np.ndarray, table: Mapping[str, Reduction | None]) -> Reduction | None:
    if name in table:
        return table[name]
    return "mean" if col.dtype.kind in "biuf" else "first"


def coarsen(
    graph: CorrespondenceGraph,
    cluster: Any,
    *,
    node_reduce: Mapping[str, Reduction | None] | None = None,
    edge_reduce: Mapping[str, Reduction] | None = None,
    merge_by: tuple[str, ...] = ("criterion",),
) -> CorrespondenceGraph:
    """Contract ``graph`` along ``cluster`` into a super-node graph.

    Parameters
    ----------
    graph : CorrespondenceGraph
        Graph with ``N`` nodes.
    cluster : array_like of int, shape ``[N]``
        Component id of each node, ``0..k-1``.
    node_reduce : mapping, optional
        Per-column overrides of :data:`NODE_REDUCE` (``None`` drops a column).
    edge_reduce : mapping, optional
        Per-column overrides of :data:`EDGE_REDUCE`; other numeric columns are
        averaged and str columns keep the first value.
    merge_by : tuple of str
        Edge columns that must also agree for two edges between the same pair of
        super nodes to merge. By default edges of different criteria stay apart,
        so provenance survives.

    Returns
    -------
    CorrespondenceGraph
        ``level="super"`` with ``k`` nodes. Node columns: ``component``
        (``0..k-1``), ``member_count`` and the aggregated columns; edge columns
        gain ``multiplicity`` (edges merged into each). ``members`` and ``masks``
        carry over, so the base masks of each super node stay known.

    Notes
    -----
    O(N + E log E): one sort of the edge keys, scatters for the rest.
    """
    n = graph.num_nodes
    cl = np.asarray(cluster)
    if cl.shape != (n,):
        raise GraphValidationError(f"expected cluster of shape [{n}] (got {list(cl.shape)})")
    if n and not np.issubdtype(cl.dtype, np.integer):
        raise GraphValidationError(f"expected cluster of an integer dtype (got {cl.dtype})")
    cl = cl.astype(np.int64)
    if n and cl.min() < 0:
        raise GraphValidationError(f"expected cluster ids >= 0 (got {int(cl.min())})")
    k = int(cl.max()) + 1 if n else 0
    if n and k > n:
        raise GraphValidationError(f"expected cluster ids in [0, {n}) (got max {k - 1})")
    if n:
        from .contract import canonical_cluster

        if not np.array_equal(canonical_cluster(cl), cl):
            raise GraphValidationError("expected a canonical cluster vector (ids 0..k-1 numbered by first appearance, none unused); pass it through canonical_cluster()")
    ntab = dict(NODE_REDUCE)
    ntab.update(node_reduce or {})
    member_count = np.bincount(cl, minlength=k).astype(np.int64)
    if "member_count" in graph.node_attr:
        member_count = group_reduce(graph.node_attr["member_count"], cl, k, "sum")
    node_attr: dict[str, np.ndarray] = {"component": np.arange(k, dtype=np.int64), "member_count": member_count}
    for name, col in graph.node_attr.items():
        if name in node_attr:
            continue
        how = _default_reduce(name, col, ntab)
        if how is None:
            continue
        w = None
        if isinstance(how, tuple) and how[0] == "wmean":
            wcol = graph.node_attr.get(how[1])
            w = np.ones(n) if wcol is None else wcol
        node_attr[name] = group_reduce(col, cl, k, how, weights=w)

    # edges: remap, drop self-loops, merge duplicates
    u = cl[graph.edge_index[0]]
    v = cl[graph.edge_index[1]]
    keep = u != v
    lo = np.minimum(u, v)[keep]
    hi = np.maximum(u, v)[keep]
    cols = {name: col[keep] for name, col in graph.edge_attr.items()}
    e = lo.size
    key = lo * max(k, 1) + hi
    for name in merge_by:
        if name in cols and e:
            _, code = np.unique(cols[name], return_inverse=True)
            key = key * (int(code.max()) + 1) + code.reshape(-1)
    order = np.argsort(key, kind="stable")
    skey = key[order]
    starts = np.flatnonzero(np.r_[True, skey[1:] != skey[:-1]]) if e else np.zeros(0, np.int64)
    groups = np.empty(e, np.int64)
    groups[order] = np.cumsum(np.r_[True, skey[1:] != skey[:-1]]) - 1 if e else groups[:0]
    g = starts.size
    first = order[starts]
    etab = dict(EDGE_REDUCE)
    etab.update(edge_reduce or {})
    edge_attr: dict[str, np.ndarray] = {}
    mult = cols.pop("multiplicity", np.ones(e, np.int64))
    for name, col in cols.items():
        if name in merge_by:
            edge_attr[name] = col[first]
            continue
        how = etab.get(name, "mean" if col.dtype.kind in "biuf" else "first")
        if how == "mean" and col.dtype.kind in "iu":
            how = "max"
        edge_attr[name] = group_reduce(col, groups, g, how)
    edge_attr["multiplicity"] = group_reduce(np.asarray(mult, np.int64), groups, g, "sum")
    mem = graph.members
    members = {"view": mem["view"], "mask_id": mem["mask_id"], "node": cl[mem["node"]]}
    return CorrespondenceGraph(
        k,
        np.stack([lo[first], hi[first]]) if g else np.zeros((2, 0), np.int64),
        edge_attr,
        node_attr,
        masks=graph.masks,
        members=members,
        level="super",
        meta=graph.meta,
    )
