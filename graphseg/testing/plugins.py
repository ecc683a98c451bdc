"""Loopback plugins registered through graphseg's own entry points.

They exist so the test suite exercises the real entry-point path (as
networkx's loopback backend does). ``LoopbackEdgeAdder`` joins nothing;
``LoopbackContractor`` delegates to union-find.

Examples
--------
>>> import numpy as np
>>> LoopbackContractor()(np.array([[0], [1]]), 2).tolist()
[0, 0]
"""

from __future__ import annotations

from typing import Any

import numpy as np

from graphseg.graphs.contract import union_find_contraction
from graphseg.graphs.evidence import EdgeSet, Evidence
from graphseg.graphs.graph import CorrespondenceGraph

__all__ = ["LoopbackEdgeAdder", "LoopbackContractor"]


class LoopbackEdgeAdder:
    """Adds no edge; counts its calls."""

    name = "testing_loopback"
    calls = 0

    def __call__(self, graph: CorrespondenceGraph, evidence: Evidence) -> EdgeSet:
        type(self).calls += 1
        return EdgeSet(np.zeros((2, 0), np.int64), {"criterion": np.zeros(0, "<U16")})


class LoopbackContractor:
    """Union-find under another name."""

    name = "testing_loopback"

    def __call__(self, edge_index: Any, num_nodes: int, *, rng: Any = None) -> np.ndarray:
        return union_find_contraction(edge_index, num_nodes)
