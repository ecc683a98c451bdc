"""Bidirectional mask overlap (SAM3D's merging rule) from pixel matches.

For two nodes ``a`` (view ``i``) and ``b`` (view ``j``), ``h`` counts the
matches of the pair ``(i, j)`` from ``a`` to ``b``; ``out(a)`` counts all
matches of the pair that start in ``a`` (wherever they land). The overlap is
bidirectional: ``min(h / out(a), h / out(b))``, so a large mask that swallows
a small one does not merge with it, unlike the one-sided ``h / min(out)`` of
``pixel_match``'s ``pair_hits``.

Examples
--------
>>> import numpy as np
>>> from graphseg.scene import Matches
>>> labs = [np.array([[0, 0, 1]]), np.array([[2, 2, 2]])]
>>> m = {(0, 1): Matches([[0, 0], [1, 0], [2, 0]], [[0, 0], [1, 0], [2, 0]], [1.0, 1.0, 1.0])}
>>> es = bidirectional_overlap_edges(labs, m, 3, threshold=0.5, min_matches=1)
>>> es.edge_index.tolist(), es.edge_attr["weight"].round(3).tolist()
([[0], [2]], [0.667])
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from .criterion import Criterion
from .evidence import EdgeSet, Evidence
from .graph import CorrespondenceGraph
from .pixel_match import lookup_pixels, pair_counts

__all__ = ["bidirectional_overlap_edges", "BidirectionalOverlap"]


def bidirectional_overlap_edges(
    node_labels: Sequence[np.ndarray],
    matches: Mapping[tuple[int, int], Any],
    num_nodes: int,
    *,
    threshold: float,
    min_matches: int,
) -> EdgeSet:
    """Edges whose bidirectional overlap reaches ``threshold`` in some view pair.

    Parameters
    ----------
    node_labels : list of int ``[H, W]`` (-1 = none)
    matches : mapping ``(i, j) -> Matches``
    num_nodes : int
    threshold : float
    min_matches : int
        Node pairs sharing fewer matches in a view pair are skipped.

    Both options are required keywords: the defaults live in :class:`BidirectionalOverlap.Options`.

    Returns
    -------
    EdgeSet
        Columns ``criterion`` ("bidirectional_overlap"), ``weight`` (the best
        overlap over view pairs), ``count``.

    Notes
    -----
    O(total matches + P log P).
    """
    n = max(num_nodes, 1)
    key_parts, ovs, cnts = [np.zeros(0, np.int64)], [np.zeros(0)], [np.zeros(0, np.int64)]
    for (i, j), m in matches.items():
        if len(m) == 0:
            continue
        a, in_a = lookup_pixels(node_labels[i], m.xy_i)
        b, in_b = lookup_pixels(node_labels[j], m.xy_j)
        base = in_a & in_b
        out_a = np.bincount(a[base & (a >= 0)], minlength=n)
        out_b = np.bincount(b[base & (b >= 0)], minlength=n)
        ok = base & (a >= 0) & (b >= 0) & (a != b)
        x, y = a[ok].astype(np.int64), b[ok].astype(np.int64)
        pu, pv, pc = pair_counts(np.minimum(x, y), np.maximum(x, y), n)
        hits = out_a + out_b  # a node lies in one view, so one of the terms is 0
        enough = pc >= min_matches
        key_parts.append(pu[enough] * n + pv[enough])
        ovs.append(pc[enough] / np.maximum(np.maximum(hits[pu], hits[pv]), 1)[enough])
        cnts.append(pc[enough])
    key, ov, cnt = np.concatenate(key_parts), np.concatenate(ovs), np.concatenate(cnts)
    # per node pair, the best overlap over view pairs (the first view pair on ties);
    # edges in the order their pair first appears
    order = np.lexsort((np.arange(key.size), -ov, key))
    best = order[np.flatnonzero(np.diff(key[order], prepend=-1))]  # one per key, in key order
    _, appears = np.unique(key, return_index=True)  # also in key order
    first = best[np.argsort(appears)]
    first = first[ov[first] >= threshold]
    keys = key[first]
    u, v = np.divmod(keys, n)
    w = ov[first].astype(np.float64)
    c = cnt[first].astype(np.int64)
    return EdgeSet(np.stack([u, v]).reshape(2, -1), {"criterion": np.full(keys.size, "bidirectional_overlap"), "weight": w, "count": c}, info={"threshold": threshold})


class BidirectionalOverlap(Criterion):
    """The ``bidirectional_overlap`` criterion (SAM3D-style merging).

    Examples
    --------
    >>> BidirectionalOverlap(threshold=0.3).options.threshold
    0.3
    """

    name = "bidirectional_overlap"
    requires = frozenset({"node_labels", "matches"})
    reduce = {"weight": "max", "count": "sum"}
    tags = {"dimension": "2d"}

    class Options(BaseModel):
        model_config = ConfigDict(extra="forbid")
        threshold: float = Field(0.5, ge=0, le=1)
        min_matches: int = Field(5, ge=1)


    def __call__(self, graph: CorrespondenceGraph, evidence: Evidence) -> EdgeSet:
        return bidirectional_overlap_edges(evidence.node_labels, evidence.matches, graph.num_nodes, **self.options.model_dump())
