"""Graph operations: the steps of a method after its edge stages.

A config's ``stages`` is the whole method: edge stages (lists of criteria,
each followed by a contraction), then graph operations, written by name::

    stages:
      - [pixel_match]
      - [chamfer_3d]
      - support          # objects below the minimum support become background
      - split            # 3D parts of an object become objects of their own
      - merge
      - mask_join
      - snap
      - support_final
      - trim             # a pixel refiner: moves border pixels only

Every operation declares its ``kind``: ``"objects"`` operations decide which
mask fragments form which object and are recorded in the objects graph
(:class:`~graphseg.graphs.lineage.Lineage`: cut edges, join edges with their
evidence, background marks with their reason); ``"pixels"`` operations are
pixel refiners that move border pixels of existing objects, never add, remove
or join one, and have the pixels they change counted. Pixel refiners come
after every objects operation. Built-in operations read their options from
their config section (``section``: ``objects``, ``split``, ``refine``,
``grow``, ``trim``); a plugin declares its own ``Options``.

Operations are found by name in :data:`graphseg.graphs.registry.operations`
(entry-point group ``graphseg.operations``). A plugin is a class like
:class:`Operation`::

    class DropSmall(Operation):
        name = "drop_small"
        class Options(BaseModel):
            min_pixels: int = 500
        def __call__(self, ctx, objects):
            sizes = np.bincount(np.concatenate([lab.ravel() for lab in objects.labels]))
            keep = sizes >= self.options.min_pixels
            keep[0] = True
            mapping = np.where(keep, np.arange(sizes.size), 0)
            objects.update(self.name, [mapping[lab] for lab in objects.labels], mapping=mapping, reason="small")

Examples
--------
>>> from graphseg.graphs.registry import operations
>>> [operations.get(n).kind for n in ("support", "split", "trim")]
['objects', 'objects', 'pixels']
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from pydantic import BaseModel

from ..validation import NoOptions, options_from
from .grow import grow_rims
from .join import join_by_masks, join_objects
from .masks import snap_to_masks
from .objects import ObjectSteps, StepContext
from .refine import refine_labels
from .split import merge_objects, split_objects
from .trim import trim_rims

__all__ = [
    "Operation",
    "Support",
    "Split",
    "Merge",
    "JoinShared",
    "MaskJoin",
    "Snap",
    "SupportFinal",
    "Refine",
    "Grow",
    "Trim",
]


def _pairs(records: list[dict[str, Any]], key: str) -> dict[frozenset[int], float]:
    """A join step's records as the evidence of its edges: ``frozenset(ids) -> value``."""
    return {frozenset(int(i) for i in r["ids"]): float(r[key]) for r in records if r.get(key) is not None}


class Operation:
    """Base class of graph operations (see the module docstring for the contract).

    ``__call__(ctx, objects)`` reads :class:`~graphseg.method.objects.StepContext`
    and changes the :class:`~graphseg.method.objects.ObjectSteps` through
    ``objects.update(...)``, which records the step; a pixel refiner's
    ``__call__(ctx, labels)`` returns ``(labels, record)``.
    """

    name: ClassVar[str] = ""
    kind: ClassVar[str] = "objects"
    section: ClassVar[str | None] = None
    settles: ClassVar[bool] = True  # the base masks take their majority object before it runs
    Options: ClassVar[type[BaseModel]] = NoOptions

    def __init__(self, options: BaseModel | None = None, /, **kwargs: Any) -> None:
        self.options = options_from(self.Options, options, kwargs, label=self.name or type(self).__name__)

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"

    def __call__(self, ctx: StepContext, objects: Any) -> Any:  # pragma: no cover - abstract
        raise NotImplementedError


class Support(Operation):
    """Objects mostly of filled-in points (``objects.min_measured``), then objects below the minimum support, become background; one-view objects the other views see as another object join it (``objects``)."""

    name = "support"
    section = "objects"

    def __call__(self, ctx: StepContext, st: ObjectSteps) -> None:
        from .segment import apply_min_support, drop_unmeasured

        cfg = ctx.config
        st.labels, unmeasured = drop_unmeasured(st.labels, ctx.views, ctx.points, cfg.objects.min_measured)
        if cfg.objects.min_measured > 0:
            st.lineage.record("unmeasured", st.labels, reason="unmeasured")
        foreground = [np.isfinite(p[..., 0]) & ~b for p, b in zip(ctx.points, ctx.background)]
        st.obj, st.labels, st.support = apply_min_support(st.obj, st.labels, ctx.points, cfg.objects, cameras=ctx.cameras, foreground=foreground, mask_view=ctx.mask_view)
        st.support["unmeasured"] = unmeasured
        st.num_objects = int(st.obj.max()) if st.obj.size else 0
        st.lineage.record("support", st.labels, reason="support")


def _split_info(st: ObjectSteps) -> dict[str, Any]:
    if st.split is None:
        st.split = {"num_objects": st.num_objects}
    return st.split


class Split(Operation):
    """Objects whose fused 3D points fall into parts joined by a cheap normalized cut are cut, then again on the finer grid where the masks own the parts (``split``)."""

    name = "split"
    section = "split"
    settles = False

    def __call__(self, ctx: StepContext, st: ObjectSteps) -> None:
        sp = ctx.config.split
        masks = ctx.masks if sp.own_fraction is not None else None
        st.labels, info = split_objects(st.labels, ctx.points, ctx.cameras, sp, masks=masks, num_objects=st.top, rng=ctx.config.seed)
        st.lineage.record("split", st.labels)
        fine_size = sp.fine_voxel_size if sp.fine_voxel_size is not None and sp.fine_voxel_size < sp.voxel_size else None
        info["fine_voxel_size"] = fine_size
        if fine_size is not None:  # the finer grid, parts of the same area; a cut stands only where the masks own its parts
            fine = {"voxel_size": fine_size, "min_voxels": round(sp.min_voxels * (sp.voxel_size / fine_size) ** 2), "own_fraction": sp.fine_own_fraction}
            st.labels, got = split_objects(
                st.labels, ctx.points, ctx.cameras, sp.model_copy(update=fine), masks=ctx.masks, num_objects=info["num_objects"], rng=ctx.config.seed
            )
            info["fine_objects"], info["fine_first_new"], info["num_objects"] = got["objects"], got["first_new"], got["num_objects"]
            info["settled"] += got["settled"]
            st.lineage.record("split_fine", st.labels)
        if info["num_objects"] > st.top:
            st.changed, st.settled = True, False
        st.split = {**(st.split or {}), **info}


class Merge(Operation):
    """Touching objects whose union no cut below ``split.merge_ncut`` separates are joined (edges carry the ``ncut``)."""

    name = "merge"
    section = "split"
    settles = False

    def __call__(self, ctx: StepContext, st: ObjectSteps) -> None:
        sp, info = ctx.config.split, _split_info(st)
        info["merges"], info["merge_mapping"] = [], None
        if sp.merge_ncut is None:
            return
        st.labels, merged = merge_objects(st.labels, ctx.points, ctx.cameras, sp, num_objects=info["num_objects"], rng=ctx.config.seed)
        info["merges"] = merged["merges"]
        st.lineage.record("merge", st.labels, evidence=_pairs(merged["merges"], "ncut"), evidence_name="ncut")
        if merged["merges"]:
            info["merge_mapping"] = merged["mapping"].tolist()
            st.obj = merged["mapping"][st.obj]
            info["num_objects"] = merged["num_objects"]
            st.changed, st.settled = True, False


class _Join(Operation):
    section = "split"
    settles = False
    key: ClassVar[str] = ""
    value: ClassVar[str] = ""

    def setting(self, ctx: StepContext) -> float | None:  # pragma: no cover - abstract
        raise NotImplementedError

    def join(self, ctx: StepContext, labels: list[np.ndarray], top: int, at: float) -> tuple[list[np.ndarray], dict[str, Any]]:  # pragma: no cover - abstract
        raise NotImplementedError

    def __call__(self, ctx: StepContext, st: ObjectSteps) -> None:
        info = _split_info(st)
        info[self.key] = []
        at = self.setting(ctx)
        if at is None:
            return
        st.labels, joined = self.join(ctx, st.labels, info["num_objects"], at)
        st.lineage.record(self.name, st.labels, evidence=_pairs(joined["joins"], self.value), evidence_name=self.value)
        if joined["joins"]:
            info[self.key], info["num_objects"] = joined["joins"], joined["num_objects"]
            st.obj = joined["mapping"][st.obj]
            st.changed, st.settled = True, False


class JoinShared(_Join):
    """Two objects whose border without a depth step is at least ``split.join_shared`` of the smaller one's outline are joined (edges carry the ``shared`` share)."""

    name = "join_shared"
    key, value = "joins", "shared"

    def setting(self, ctx: StepContext) -> float | None:
        return ctx.config.split.join_shared

    def join(self, ctx: StepContext, labels: list[np.ndarray], top: int, at: float) -> tuple[list[np.ndarray], dict[str, Any]]:
        return join_objects(labels, ctx.points, ctx.cameras, min_shared=at, num_objects=top)


class MaskJoin(_Join):
    """An object lying mostly (``split.mask_join``) in masks that hold a larger object of the same colour joins it (edges carry the ``cover``)."""

    name = "mask_join"
    key, value = "mask_joins", "cover"

    def setting(self, ctx: StepContext) -> float | None:
        return ctx.config.split.mask_join

    def join(self, ctx: StepContext, labels: list[np.ndarray], top: int, at: float) -> tuple[list[np.ndarray], dict[str, Any]]:
        return join_by_masks(labels, ctx.masks, [v.rgb for v in ctx.views], min_cover=at, max_color=ctx.config.split.mask_join_color, num_objects=top)


class Snap(Operation):
    """In a mask with ``split.snap_share`` of its pixels in one object, the other pixels go to that object where the other views agree (fragments move)."""

    name = "snap"
    section = "split"
    settles = False

    def __call__(self, ctx: StepContext, st: ObjectSteps) -> None:
        sp, info = ctx.config.split, _split_info(st)
        info["snapped"] = 0
        if sp.snap_share is None:
            return
        st.labels, snapped = snap_to_masks(st.labels, ctx.masks, sp.snap_share, points=ctx.points, voxel_size=sp.voxel_size, num_objects=info["num_objects"])
        st.lineage.record("snap", st.labels)
        info["snapped"] = snapped["pixels"]
        if snapped["pixels"]:
            if snapped["mapping"] is not None:
                st.obj = snapped["mapping"][st.obj]
                info["num_objects"] = snapped["num_objects"]
            st.changed, st.settled = True, False


class SupportFinal(Operation):
    """The final objects (after the split and the joins) below the support, or below ``objects.min_object_fraction``, become background."""

    name = "support_final"
    section = "objects"

    def __call__(self, ctx: StepContext, st: ObjectSteps) -> None:
        from .segment import drop_weak_parts

        cfg = ctx.config
        min_final = max(ctx.min_points, int(np.ceil(cfg.objects.min_object_fraction * ctx.pixels)))
        st.labels, remap, st.support["dropped_final"] = drop_weak_parts(st.labels, ctx.views, ctx.points, st.num_objects, min_final, cfg.objects.min_measured)
        if st.support["dropped_final"]:
            st.obj = remap[st.obj]
            st.num_objects = int(remap.max())
            if st.split is not None:
                st.split["num_objects"] = st.num_objects
            st.lineage.record("support_final", st.labels, reason="support")


class _Refiner(Operation):
    kind = "pixels"


class Refine(_Refiner):
    """Per-pixel relabelling by the other views' labels at the same 3D point (``refine``)."""

    name = "refine"
    section = "refine"

    def __call__(self, ctx: StepContext, labels: list[np.ndarray]) -> tuple[list[np.ndarray], dict[str, Any]]:
        r = ctx.config.refine
        return refine_labels(labels, ctx.points, ctx.cameras, confidence=[v.confidence for v in ctx.views], tolerance=r.tolerance, self_weight=r.self_weight, min_views=r.min_views)


class Grow(_Refiner):
    """An object takes the unlabelled pixels at its rim up to the nearest colour edge (``grow``)."""

    name = "grow"
    section = "grow"

    def __call__(self, ctx: StepContext, labels: list[np.ndarray]) -> tuple[list[np.ndarray], dict[str, Any]]:
        return grow_rims(labels, [v.rgb for v in ctx.views], band=ctx.config.grow.band, blur=ctx.config.grow.blur)


class Trim(_Refiner):
    """Border pixels that look like the background beside them are unlabelled (``trim``)."""

    name = "trim"
    section = "trim"

    def __call__(self, ctx: StepContext, labels: list[np.ndarray]) -> tuple[list[np.ndarray], dict[str, Any]]:
        tr = ctx.config.trim
        return trim_rims(labels, [v.rgb for v in ctx.views], window=tr.window, rim=tr.rim, blur=tr.blur)
