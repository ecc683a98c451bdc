"""The contractor contract: :class:`BaseContractor` and :func:`run_contractor`.

A contractor answers "which component is each node in": it returns a
canonical ``cluster`` vector (int64 ``[N]``, ids ``0..k-1`` by first
appearance) and :func:`graphseg.graphs.coarsen` does the rest. Every
contractor is a :class:`BaseContractor` subclass that declares

* ``name`` - its registry name (entry-point group ``graphseg.contractors``);
* ``Options`` - a pydantic model (extra keys forbidden): the single source of
  its defaults and validation, checked when a ``Config`` is built, so a
  misspelt option fails there and not at the first run;
* ``uses_edge_attr`` / ``uses_node_attr`` - whether it is called with the
  graph's edge columns (``sign``, ``weight``, ``criterion``) and node columns;
* ``__call__(edge_index, num_nodes, *, rng=None[, edge_attr=][, node_attr=])``.

:func:`run_contractor` is the one path from a graph's edges to a cluster
vector, with one meaning of signed edges everywhere. This module imports
nothing above :mod:`graphseg.graphs.edge_index`, so the graph itself can
call it (:meth:`CorrespondenceGraph.contract`).

Examples
--------
>>> import numpy as np
>>> class Singletons(BaseContractor):
...     name = "singletons"
...     def __call__(self, edge_index, num_nodes, *, rng=None):
...         return np.arange(num_nodes)
>>> run_contractor(Singletons(), np.array([[0], [1]]), 3).tolist()
[0, 1, 2]
>>> Singletons(k=1)
Traceback (most recent call last):
...
graphseg.validation.CriterionOptionsError: singletons: unknown option 'k'; valid options: (none)
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np
from pydantic import BaseModel

from ..validation import NoOptions, options_from
from .edge_index import as_edge_index

__all__ = ["BaseContractor", "run_contractor", "split_signed"]


class BaseContractor:
    """Base class of contractors (see the module docstring for the contract).

    Parameters
    ----------
    options : Options, optional
        A validated ``Options`` instance (default: all defaults).
    **kwargs
        Convenience: options as keywords, validated into ``Options``.

    Attributes
    ----------
    options : Options
        The validated options.
    """

    name: ClassVar[str] = ""
    Options: ClassVar[type[BaseModel]] = NoOptions
    uses_edge_attr: ClassVar[bool] = False
    uses_node_attr: ClassVar[bool] = False

    def __init__(self, options: BaseModel | None = None, /, **kwargs: Any) -> None:
        self.options = options_from(self.Options, options, kwargs, label=self.name or type(self).__name__)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.options!r})"

    def __call__(self, edge_index: Any, num_nodes: int, *, rng: Any = None) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError


def split_signed(edge_index: Any, edge_attr: Mapping[str, Any] | None) -> tuple[np.ndarray, np.ndarray]:
    """Boolean masks ``(attractive, repulsive)`` ``[E]`` from the ``sign`` column (missing = attractive).

    Examples
    --------
    >>> [m.tolist() for m in split_signed(np.array([[0, 1], [1, 2]]), {"sign": np.array([1.0, -1.0])})]
    [[True, False], [False, True]]
    """
    e = as_edge_index(edge_index).shape[1]
    sign = None if edge_attr is None else edge_attr.get("sign")
    if sign is None:
        return np.ones(e, bool), np.zeros(e, bool)
    s = np.asarray(sign, np.float64)
    return ~(s < 0), s < 0


def run_contractor(
    contractor: Any, edge_index: Any, num_nodes: int, *, edge_attr: Mapping[str, Any] | None = None, node_attr: Mapping[str, Any] | None = None, rng: Any = None
) -> np.ndarray:
    """Run any contractor on a graph's edges with one meaning of signed edges.

    The one path from a graph to a cluster vector, used by
    :func:`graphseg.method.segment` and :meth:`CorrespondenceGraph.contract`.
    Edges with ``sign < 0`` are repulsive: a contractor that reads edge
    attributes (``uses_edge_attr``) gets them all and honours them as
    cannot-links; for any other contractor (plain components) they are
    dropped, so it never merges across them.

    Examples
    --------
    >>> from graphseg.graphs.contract import UnionFindContraction
    >>> ei = np.array([[0, 1], [1, 2]])
    >>> run_contractor(UnionFindContraction(), ei, 3, edge_attr={"sign": np.array([1.0, -1.0])}).tolist()
    [0, 0, 1]
    """
    if getattr(contractor, "uses_edge_attr", False):
        extra = {"node_attr": dict(node_attr or {})} if getattr(contractor, "uses_node_attr", False) else {}
        return np.asarray(contractor(edge_index, num_nodes, rng=rng, edge_attr=dict(edge_attr or {}), **extra))
    attract, _ = split_signed(edge_index, edge_attr)
    return np.asarray(contractor(as_edge_index(edge_index, num_nodes)[:, attract], num_nodes, rng=rng))
