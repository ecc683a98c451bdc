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

from collections.abc import Mapping
from typing import Any

import numpy as np

from .coalesce import Reduction, canonical_cluster, coalesce, group_reduce
from .graph import CorrespondenceGraph, GraphValidationError

__all__ = ["coarsen", "group_reduce", "NODE_REDUCE", "EDGE_REDUCE"]


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
    if n and not np.array_equal(canonical_cluster(cl), cl):
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

    # edges: remap, drop self-loops, merge duplicates (one shared group-by-key step)
    etab = dict(EDGE_REDUCE)
    etab.update(edge_reduce or {})
    new_ei, edge_attr, _ = coalesce(
        np.stack([cl[graph.edge_index[0]], cl[graph.edge_index[1]]]),
        graph.edge_attr,
        k,
        reduce=etab,
        merge_by=merge_by,
    )
    mem = graph.members
    members = {"view": mem["view"], "mask_id": mem["mask_id"], "node": cl[mem["node"]]}
    return CorrespondenceGraph(
        k,
        new_ei,
        edge_attr,
        node_attr,
        masks=graph.masks,
        members=members,
        level="super",
        meta=graph.meta,
    )
