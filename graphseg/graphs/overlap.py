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
    threshold: float = 0.5,
    min_matches: int = 5,
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

    Returns
    -------
    EdgeSet
        Columns ``criterion`` ("bidirectional_overlap"), ``weight`` (the best
        overlap over view pairs), ``count``.

    Notes
    -----
    O(total matches + P log P).
    """
    best: dict[int, tuple[float, int]] = {}
    n = max(num_nodes, 1)
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
        ov = pc / np.maximum(np.maximum(hits[pu], hits[pv]), 1)
        for u, v, c, o in zip(pu.tolist(), pv.tolist(), pc.tolist(), ov.tolist()):
            if c >= min_matches and o > best.get(u * n + v, (-1.0, 0))[0]:
                best[u * n + v] = (o, c)
    keys = np.array([k for k, (o, _) in best.items() if o >= threshold], np.int64)
    u, v = np.divmod(keys, n)
    w = np.array([best[k][0] for k in keys.tolist()], np.float64)
    c = np.array([best[k][1] for k in keys.tolist()], np.int64)
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
