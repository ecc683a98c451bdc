"""The steps after the last contraction, each recorded as a graph operation.

Every super-vertex of the last contracted graph starts as one object. Then,
in this order, each step that its config section turns on runs once on the
label images, and :class:`~graphseg.graphs.lineage.Lineage` records what it
decided on the mask fragments:

=============== ================================================ =========================
step            what it decides                                  recorded as
=============== ================================================ =========================
``unmeasured``  objects mostly of filled-in points               background (``unmeasured``)
``support``     objects below the minimum support; one-view      background (``support``);
                objects the other views see as another object    joins
``split``       3D parts of an object (normalized cut)           cut edges (``cut_by``)
``split_fine``  the finer grid's parts                           cut edges
``merge``       touching pieces no cheap cut separates           join edges (``ncut``)
``join_shared`` pieces sharing most of their image border        join edges (``shared``)
``mask_join``   pieces the masks hold to a larger object         join edges (``cover``)
``snap``        pixels a voxel border cut off their mask         fragments moved
``support_final`` final objects below the support                background (``support``)
=============== ================================================ =========================

The pixel refiners (``refine``, ``grow``, ``trim``) then move border pixels
of existing objects only; the pixels they change are counted
(``info["refiners"]``), and the objects graph does not hold them.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..config import Config
from ..graphs.lineage import Lineage
from ..scene import View
from .masks import majority_objects

__all__ = ["ObjectSteps", "StepContext", "run_operations", "refine_pixels"]


@dataclass
class StepContext:
    """What every step reads: the views, their points and cameras, the composed masks, the config."""

    views: Sequence[View]
    points: Sequence[np.ndarray]
    masks: Sequence[np.ndarray]
    background: Sequence[np.ndarray]
    mask_view: np.ndarray
    mask_id: np.ndarray
    config: Config

    @property
    def cameras(self) -> list[tuple[Any, Any]]:
        return [(v.K, v.cam_to_world) for v in self.views]

    @property
    def pixels(self) -> int:
        return self.views[0].shape[0] * self.views[0].shape[1] if len(self.views) else 0

    @property
    def min_points(self) -> int:
        return int(np.ceil(self.config.objects.min_point_fraction * self.pixels))


@dataclass
class ObjectSteps:
    """The objects as the steps leave them: label images, each base mask's object, the record."""

    labels: list[np.ndarray]
    obj: np.ndarray
    num_objects: int
    lineage: Lineage
    support: dict[str, Any] = field(default_factory=dict)
    split: dict[str, Any] | None = None
    changed: bool = False
    settled: bool = True
    timings: dict[str, float] = field(default_factory=dict)
    info: dict[str, Any] = field(default_factory=dict)

    def update(
        self,
        step: str,
        labels: list[np.ndarray],
        *,
        mapping: np.ndarray | None = None,
        reason: str = "",
        evidence: dict[frozenset[int], float] | None = None,
        evidence_name: str = "",
    ) -> None:
        """Take the labels a graph operation produced and record them (the API of a plugin operation).

        ``mapping`` (old id -> new id, int ``[K + 1]``) renames whole objects;
        without it the objects may have moved pixels, and each base mask's
        object is taken by majority once the operations end. ``reason`` names
        why objects became background; ``evidence`` gives the value of each
        join (``frozenset({a, b})`` of ids before the step).
        """
        self.labels = labels
        self.lineage.record(step, labels, reason=reason, evidence=evidence, evidence_name=evidence_name)
        if mapping is not None:
            self.obj = np.asarray(mapping, np.int64)[self.obj]
        else:
            self.changed, self.settled = True, False
        self.num_objects = max(int(self.obj.max(initial=0)), int(max((int(lab.max(initial=0)) for lab in labels), default=0)))

    @property
    def top(self) -> int:
        """The largest object id the split's bookkeeping knows (the split's count when a split-family step ran)."""
        return int(self.split["num_objects"]) if self.split is not None else self.num_objects

    def settle(self, ctx: StepContext) -> None:
        """After steps that moved pixels: every base mask takes the object with most of its pixels."""
        if self.changed and not self.settled:
            self.obj = majority_objects(ctx.masks, self.labels, ctx.mask_view, ctx.mask_id, self.obj)
            self.num_objects = self.top
        self.settled = True


def run_operations(ctx: StepContext, operations: Sequence[Any], labels: list[np.ndarray], obj: np.ndarray, *, first_step: str) -> ObjectSteps:
    """Run the graph operations of the step list after the last contraction, in order.

    Parameters
    ----------
    ctx : StepContext
    operations : sequence of built operations
        Callables ``op(ctx, objects)`` with a ``name`` and a ``kind``
        (``"objects"``; the pixel refiners run in :func:`refine_pixels`).
    labels : list of int32 ``[H, W]``
        The contracted graph's objects painted with their masks.
    obj : int64 ``[M]``
        The object of every base mask (``ctx.mask_view``, ``ctx.mask_id``).
    first_step : str, keyword-only
        The name of the last contraction in the record (``"stage1"``).

    Returns
    -------
    ObjectSteps
        ``lineage`` holds one recorded step per operation (the split two, with
        its finer pass).
    """
    st = ObjectSteps(labels, obj, int(obj.max()) if obj.size else 0, Lineage(ctx.masks, ctx.mask_view, ctx.mask_id, obj, step=first_step))
    for op in operations:
        t = time.perf_counter()
        if getattr(op, "settles", True):
            st.settle(ctx)
        op(ctx, st)
        st.timings[op.name] = st.timings.get(op.name, 0.0) + time.perf_counter() - t
    st.settle(ctx)
    return st


def refine_pixels(ctx: StepContext, refiners: Sequence[Any], labels: list[np.ndarray], timings: dict[str, float]) -> tuple[list[np.ndarray], dict[str, Any]]:
    """The pixel refiners of the step list, in order (``refine``, ``grow``, ``trim``, or a plugin's).

    Each ``refiner(ctx, labels) -> (labels, record)`` moves border pixels of
    the existing objects only; ``info`` keeps each one's record under its
    name and, under ``"refiners"``, the pixels it changed (``{name: pixels}``,
    plus ``"pixels"``, the total against the labels before the first, and
    ``"fraction"`` of all pixels).
    """
    before = labels
    info: dict[str, Any] = {"refine": None, "grow": None, "trim": None}
    counts: dict[str, int] = {}
    for refiner in refiners:
        t = time.perf_counter()
        new, info[refiner.name] = refiner(ctx, labels)
        if len(new) != len(labels) or any(np.asarray(a).shape != np.asarray(b).shape for a, b in zip(labels, new)):
            raise ValueError(f"pixel refiner {refiner.name!r} returned labels of other shapes")
        counts[refiner.name] = int(sum(int(np.count_nonzero(np.asarray(a) != np.asarray(b))) for a, b in zip(labels, new)))
        labels = new
        timings[refiner.name] = time.perf_counter() - t
    total = int(sum(int(np.count_nonzero(np.asarray(a) != np.asarray(b))) for a, b in zip(before, labels)))
    info["refiners"] = {**counts, "pixels": total, "fraction": total / max(1, ctx.pixels * len(labels))}
    return labels, info
