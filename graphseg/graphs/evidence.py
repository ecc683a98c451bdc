"""What edge criteria read: :class:`Evidence` and what they return: :class:`EdgeSet`.

An edge criterion (:class:`graphseg.graphs.Criterion`) is called as
``criterion(graph, evidence) -> EdgeSet``. The
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

from ..geometry import point_normals
from .graph import CorrespondenceGraph, as_edge_index

__all__ = ["Evidence", "EdgeSet", "Contractor"]


@dataclass
class Evidence:
    """Per-view inputs for edge criteria (see :data:`graphseg.graphs.criterion.REQUIRES`).

    The pipeline fills only the fields some configured criterion ``requires``;
    the others stay None (``matches``: empty).

    Attributes
    ----------
    node_labels : list of int64 ``[H, W]``
        Pixel -> node of the graph being extended (-1 = no node). For a
        contracted graph this is ``graph.node_labels()``. Always given.
    matches : mapping ``(i, j) -> Matches``
        Pixel matches between views ``i < j``.
    points : list of float32 ``[H, W, 3]`` or None
        World point maps, NaN where invalid.
    features : list of float ``[h, w, D]`` or float ``[N, D]`` or None
        Per-pixel feature maps (any resolution) or per-node features.
    rgb : list of uint8 ``[H, W, 3]`` or None
    cameras : list of ``(K [3, 3], cam_to_world [4, 4])`` or None
        Per view; either matrix may be None when unknown.
    confidence : list of float ``[H, W]`` (or None per view) or None
    masks : list of int ``[H, W]`` or None
        The composed mask images (``mask_id + 1``, 0 = none) of the mask graph.
    normal_cache : dict
        Filled by :meth:`normals`. The pipeline passes one dict to every
        stage's evidence, so criteria that need normals compute them once.
    """

    node_labels: list[np.ndarray]
    matches: Mapping[tuple[int, int], Any] = field(default_factory=dict)
    points: Sequence[np.ndarray | None] | None = None
    features: Any = None
    rgb: Sequence[np.ndarray] | None = None
    cameras: Sequence[tuple[np.ndarray | None, np.ndarray | None]] | None = None
    confidence: Sequence[np.ndarray | None] | None = None
    masks: Sequence[np.ndarray] | None = None
    normal_cache: dict[int, list[np.ndarray | None]] = field(default_factory=dict, repr=False, compare=False)

    def normals(self, step: int) -> list[np.ndarray | None]:
        """:func:`graphseg.geometry.point_normals` of every view's ``points``, computed once per ``step``.

        Parameters
        ----------
        step : int
            Pixel step of the central differences.

        Returns
        -------
        list of float32 ``[H, W, 3]`` or None
            Per view (None where the view has no points); read-only arrays,
            kept in ``normal_cache`` under ``step``. The cache is keyed by the
            step only: evidence with other ``points`` needs its own dict.

        Raises
        ------
        ValueError
            When ``points`` is None.

        Notes
        -----
        O(total pixels) on the first call for a ``step``, O(1) after. The
        cache holds one ``[H, W, 3]`` float32 map per view and step (as large as
        the point maps) until the evidence is dropped.

        Examples
        --------
        >>> pts = np.zeros((3, 3, 3), np.float32); pts[..., 0], pts[..., 1] = np.mgrid[0:3, 0:3]
        >>> ev = Evidence([], points=[pts, None])
        >>> n = ev.normals(1)
        >>> np.abs(n[0][1, 1]).tolist(), n[1], ev.normals(1) is n, n[0].flags.writeable
        ([0.0, 0.0, 1.0], None, True, False)
        """
        if self.points is None:
            raise ValueError("normals need world points (evidence.points is None)")
        step = int(step)
        if step not in self.normal_cache:
            maps: list[np.ndarray | None] = []
            for p in self.points:
                n = None if p is None else point_normals(np.asarray(p, np.float32), step)
                if n is not None:
                    n.flags.writeable = False
                maps.append(n)
            self.normal_cache[step] = maps
        return self.normal_cache[step]

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
class Contractor(Protocol):
    """Protocol of contractors: ``__call__(edge_index, num_nodes, *, rng=None) -> cluster``.

    A contractor class with ``uses_edge_attr = True`` is called with
    ``edge_attr=`` (the stage graph's edge columns) as well. Contractors
    return only the canonical ``cluster`` (int64 ``[N]``, ids ``0..k-1`` by
    first appearance); :func:`graphseg.graphs.coarsen` does the rest.
    """

    def __call__(self, edge_index: Any, num_nodes: int, *, rng: Any = None) -> np.ndarray: ...
