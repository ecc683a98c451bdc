"""What edge adders read: :class:`Evidence` and what they return: :class:`EdgeSet`.

An edge adder is any callable ``adder(graph, evidence) -> EdgeSet``. The
evidence is per-view arrays only (no backend objects), so the graph package
never depends on how masks, matches or points were made.

Examples
--------
>>> import numpy as np
>>> es = EdgeSet(np.array([[0], [1]]), {"criterion": np.array(["dino"]), "weight": np.array([0.9])})
>>> es.num_edges
1
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np

from .graph import CorrespondenceGraph, as_edge_index

__all__ = ["Evidence", "EdgeSet", "EdgeAdder", "Contractor"]


@dataclass
class Evidence:
    """Per-view inputs for edge adders.

    Attributes
    ----------
    node_labels : list of int64 ``[H, W]``
        Pixel -> node of the graph being extended (-1 = no node). For a
        contracted graph this is ``graph.node_labels()``.
    matches : mapping ``(i, j) -> Matches``
        Pixel matches between views ``i < j``.
    points : list of float32 ``[H, W, 3]`` or None
        World point maps, NaN where invalid.
    features : list of float ``[h, w, D]`` or float ``[N, D]`` or None
        Per-pixel feature maps (any resolution) or per-node features.
    """

    node_labels: list[np.ndarray]
    matches: Mapping[tuple[int, int], Any] = field(default_factory=dict)
    points: Sequence[np.ndarray | None] | None = None
    features: Any = None

    @classmethod
    def for_graph(cls, graph: CorrespondenceGraph, **kwargs: Any) -> Evidence:
        """Evidence whose ``node_labels`` come from ``graph.node_labels()``."""
        return cls(node_labels=graph.node_labels(), **kwargs)


@dataclass
class EdgeSet:
    """Edges proposed by one adder: ``edge_index`` int64 ``[2, E]`` and columns of length ``E``."""

    edge_index: np.ndarray
    edge_attr: dict[str, np.ndarray] = field(default_factory=dict)
    info: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.edge_index = as_edge_index(self.edge_index)
        self.edge_attr = {k: np.asarray(v) for k, v in self.edge_attr.items()}

    @property
    def num_edges(self) -> int:
        return int(self.edge_index.shape[1])


@runtime_checkable
class EdgeAdder(Protocol):
    """Protocol of edge adders: ``name`` plus ``__call__(graph, evidence) -> EdgeSet``."""

    name: str

    def __call__(self, graph: CorrespondenceGraph, evidence: Evidence) -> EdgeSet: ...


@runtime_checkable
class Contractor(Protocol):
    """Protocol of contractors: ``__call__(edge_index, num_nodes, *, rng=None) -> cluster``."""

    def __call__(self, edge_index: Any, num_nodes: int, *, rng: Any = None) -> np.ndarray: ...
