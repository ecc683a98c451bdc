"""The edge-criterion contract: what a criterion declares and how it is built.

An edge criterion is a class with

* ``name`` - its registry name;
* ``Options`` - a pydantic model (extra keys forbidden): the single source of its
  defaults and validation;
* ``requires`` - the evidence it reads, a subset of :data:`REQUIRES`;
* ``reduce`` - edge column -> how parallel edges merge, one of :data:`REDUCTIONS`;
* ``tags`` - e.g. ``{"dimension": "2d" | "3d" | "any"}`` (``--no-3d`` drops ``"3d"``);
* ``__init__(options)`` - built from one validated ``Options`` instance;
* ``__call__(graph, evidence) -> EdgeSet`` - never mutates its inputs.

Criteria are found by name in :data:`graphseg.graphs.edge_adders` (entry-point
group ``graphseg.edge_adders``). :func:`build_criterion` validates options and
builds one; :func:`criterion_info` reads the declarations of any registered
class, including older plain callables that declare only some of them.

Examples
--------
>>> import numpy as np
>>> from pydantic import BaseModel, ConfigDict, Field
>>> class Everything(Criterion):
...     name = "everything"
...     class Options(BaseModel):
...         model_config = ConfigDict(extra="forbid")
...         weight: float = Field(1.0, gt=0)
...     reduce = {"weight": "max"}
...     def __call__(self, graph, evidence):
...         u, v = np.triu_indices(graph.num_nodes, 1)
...         return EdgeSet(np.stack([u, v]), {"weight": np.full(u.size, self.options.weight)})
>>> from graphseg.graphs import CorrespondenceGraph
>>> g = CorrespondenceGraph(3)
>>> Everything(Everything.Options(weight=2.0))(g, Evidence([])).edge_index.tolist()
[[0, 0, 1], [1, 2, 2]]
>>> build_criterion(Everything, {"weigth": 2})
Traceback (most recent call last):
...
graphseg.validation.CriterionOptionsError: everything: unknown option 'weigth'; valid options: weight; did you mean 'weight'?
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

from pydantic import BaseModel

from ..validation import (  # defined in graphseg.validation (shared with contractors and backends), re-exported
    CriterionOptionsError,
    NoOptions,
    did_you_mean,
    non_finite,
    options_from,
    validate_options,
)
from .evidence import EdgeSet, Evidence
from .graph import CorrespondenceGraph

__all__ = [
    "Criterion",
    "CriterionInfo",
    "CriterionOptionsError",
    "REQUIRES",
    "REDUCTIONS",
    "DIMENSIONS",
    "criterion_info",
    "build_criterion",
    "validate_options",
    "did_you_mean",
    "non_finite",
    "NoOptions",
]

#: The evidence vocabulary of ``requires`` (``node_labels`` is always given).
REQUIRES: dict[str, str] = {
    "node_labels": "list of int64 [H, W]: pixel -> node of the current graph, -1 = none (always given)",
    "masks": "list of int [H, W]: the composed mask images, mask_id + 1, 0 = none",
    "matches": "{(i, j): Matches}: pixel matches between views i < j",
    "points": "list of float32 [H, W, 3]: world points, NaN = invalid",
    "confidence": "list of float [H, W] or None per view: depth / point confidence",
    "features": "list of float [h, w, D] per view, or float [N, D] per node",
    "rgb": "list of uint8 [H, W, 3]",
    "cameras": "list of (K [3, 3], cam_to_world [4, 4]) per view, entries None when unknown",
}

#: How parallel edges merge, per edge column.
REDUCTIONS: tuple[str, ...] = ("sum", "max", "min", "mean", "first")

#: Values of ``tags["dimension"]``.
DIMENSIONS: tuple[str, ...] = ("2d", "3d", "any")


class Criterion:
    """Base class of edge criteria (see the module docstring for the contract).

    Parameters
    ----------
    options : Options, optional
        A validated ``Options`` instance (default: all defaults).
    **kwargs
        Convenience: options as keywords, validated into ``Options``.
    """

    name: ClassVar[str] = ""
    Options: ClassVar[type[BaseModel]] = NoOptions
    requires: ClassVar[frozenset[str]] = frozenset()
    reduce: ClassVar[Mapping[str, str]] = {}
    tags: ClassVar[Mapping[str, str]] = {"dimension": "any"}

    def __init__(self, options: BaseModel | None = None, /, **kwargs: Any) -> None:
        self.options = options_from(self.Options, options, kwargs, label=self.name or type(self).__name__)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.options!r})"

    def __call__(self, graph: CorrespondenceGraph, evidence: Evidence) -> EdgeSet:  # pragma: no cover - abstract
        raise NotImplementedError


@dataclass(frozen=True)
class CriterionInfo:
    """The declarations of a criterion class, with defaults filled in."""

    name: str
    Options: type[BaseModel] | None
    requires: frozenset[str]
    reduce: dict[str, str]
    tags: dict[str, str] = field(default_factory=dict)

    @property
    def dimension(self) -> str:
        return self.tags.get("dimension", "any")


def criterion_info(cls: Any, name: str | None = None) -> CriterionInfo:
    """Read and check the declarations of a criterion class (or a legacy callable).

    Parameters
    ----------
    cls : type or object
        A :class:`Criterion` subclass or any object with some of the attributes.
    name : str, optional
        The registry name (used in messages and when the class has no ``name``).

    Raises
    ------
    ValueError
        If ``requires``, ``reduce`` or ``tags`` use words outside the vocabularies.

    Examples
    --------
    >>> from graphseg.graphs.chamfer import Chamfer3D
    >>> info = criterion_info(Chamfer3D)
    >>> sorted(info.requires), info.dimension, info.reduce["distance"]
    (['confidence', 'points'], '3d', 'min')
    """
    label = name or getattr(cls, "name", None) or getattr(cls, "__name__", type(cls).__name__)
    opts = getattr(cls, "Options", None)
    if opts is not None and not (isinstance(opts, type) and issubclass(opts, BaseModel)):
        raise ValueError(f"criterion {label!r}: Options must be a pydantic BaseModel subclass (got {opts!r})")
    req = frozenset(getattr(cls, "requires", frozenset()) or ())
    unknown = sorted(req - set(REQUIRES))
    if unknown:
        raise ValueError(f"criterion {label!r}: unknown requires {unknown}; vocabulary: {', '.join(REQUIRES)}")
    red = dict(getattr(cls, "reduce", {}) or {})
    bad = {k: v for k, v in red.items() if v not in REDUCTIONS}
    if bad:
        raise ValueError(f"criterion {label!r}: unknown reduce {bad}; choose from {', '.join(REDUCTIONS)}")
    tags = dict(getattr(cls, "tags", {}) or {})
    tags.setdefault("dimension", "any")
    if tags["dimension"] not in DIMENSIONS:
        raise ValueError(f"criterion {label!r}: tags['dimension'] must be one of {', '.join(DIMENSIONS)} (got {tags['dimension']!r})")
    return CriterionInfo(str(getattr(cls, "name", None) or label), opts, req, red, tags)


def build_criterion(cls: Any, options: Mapping[str, Any] | BaseModel | None = None, *, name: str | None = None) -> Any:
    """Validate ``options`` and build the criterion ``cls``.

    A class with ``Options`` is built as ``cls(Options(**options))``; a legacy
    class without it as ``cls(**options)``.
    """
    info = criterion_info(cls, name)
    if isinstance(options, BaseModel):
        return cls(options)
    opts = validate_options(info.Options, options, label=info.name)
    if isinstance(opts, BaseModel):
        return cls(opts)
    return cls(**opts)
