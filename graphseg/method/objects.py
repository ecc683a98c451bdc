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
from .grow import grow_rims
from .join import join_by_masks, join_objects
from .masks import majority_objects, snap_to_masks
from .refine import refine_labels
from .split import merge_objects, split_objects
from .trim import trim_rims

__all__ = ["ObjectSteps", "StepContext", "decide_objects", "refine_pixels"]


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
    timings: dict[str, float] = field(default_factory=dict)


def _pairs(records: Sequence[dict[str, Any]], key: str) -> dict[frozenset[int], float]:
    return {frozenset(int(i) for i in r["ids"]): float(r[key]) for r in records if r.get(key) is not None}


def decide_objects(ctx: StepContext, labels: list[np.ndarray], obj: np.ndarray, *, first_step: str) -> ObjectSteps:
    """Run the object-deciding steps after the last contraction (module docstring), in order.

    Parameters
    ----------
    ctx : StepContext
    labels : list of int32 ``[H, W]``
        The contracted graph's objects painted with their masks.
    obj : int64 ``[M]``
        The object of every base mask (``ctx.mask_view``, ``ctx.mask_id``).
    first_step : str, keyword-only
        The name of the last contraction in the record (``"stage1"``).

    Returns
    -------
    ObjectSteps
        ``lineage`` holds one recorded step per step that ran.
    """
    st = ObjectSteps(labels, obj, int(obj.max()) if obj.size else 0, Lineage(ctx.masks, ctx.mask_view, ctx.mask_id, obj, step=first_step))
    _support(ctx, st)
    if ctx.config.split.enabled:
        t = time.perf_counter()
        _split(ctx, st)
        _joins(ctx, st)
        _snap(ctx, st)
        if st.changed:
            st.obj = majority_objects(ctx.masks, st.labels, ctx.mask_view, ctx.mask_id, st.obj)
            st.num_objects = st.split["num_objects"]
        st.timings["split"] = time.perf_counter() - t
    _final_support(ctx, st)
    return st


def _support(ctx: StepContext, st: ObjectSteps) -> None:
    from .segment import apply_min_support, drop_unmeasured

    cfg = ctx.config
    st.labels, unmeasured = drop_unmeasured(st.labels, ctx.views, ctx.points, cfg.objects.min_measured)
    if cfg.objects.min_measured > 0:
        st.lineage.record("unmeasured", st.labels, reason="unmeasured")
    foreground = [np.isfinite(p[..., 0]) & ~b for p, b in zip(ctx.points, ctx.background)]
    st.obj, st.labels, st.support = apply_min_support(
        st.obj,
        st.labels,
        ctx.points,
        cfg.objects.min_views,
        ctx.min_points,
        cameras=ctx.cameras,
        foreground=foreground,
        min_confirm=int(np.ceil(cfg.objects.confirm_fraction * ctx.pixels)),
        mask_view=ctx.mask_view,
        merge=cfg.objects.merge_seen,
    )
    st.support["unmeasured"] = unmeasured
    st.num_objects = int(st.obj.max()) if st.obj.size else 0
    st.lineage.record("support", st.labels, reason="support")


def _split(ctx: StepContext, st: ObjectSteps) -> None:
    sp = ctx.config.split
    graph_options = sp.model_dump(include={"voxel_size", "min_voxels", "concave_weight", "concave_angle", "concave_margin"})  # the voxel graph both use
    common = {"max_ncut": sp.max_ncut, "own_cover": sp.own_cover, "settle_band": sp.settle_band, "rng": ctx.config.seed}
    st.labels, info = split_objects(
        st.labels,
        ctx.points,
        ctx.cameras,
        **graph_options,
        **common,
        masks=ctx.masks if sp.own_fraction is not None else None,
        own_fraction=sp.own_fraction or 0.0,
        num_objects=st.num_objects,
    )
    st.lineage.record("split", st.labels)
    fine_size = sp.fine_voxel_size if sp.fine_voxel_size is not None and sp.fine_voxel_size < sp.voxel_size else None
    info["fine_voxel_size"] = fine_size
    if fine_size is not None:  # the finer grid, parts of the same area; a cut stands only where the masks own its parts
        fine_options = {**graph_options, "voxel_size": fine_size, "min_voxels": round(sp.min_voxels * (sp.voxel_size / fine_size) ** 2)}
        st.labels, fine = split_objects(
            st.labels, ctx.points, ctx.cameras, **fine_options, **common, masks=ctx.masks, own_fraction=sp.fine_own_fraction, num_objects=info["num_objects"]
        )
        info["fine_objects"], info["fine_first_new"], info["num_objects"] = fine["objects"], fine["first_new"], fine["num_objects"]
        info["settled"] += fine["settled"]
        st.lineage.record("split_fine", st.labels)
    st.changed = info["num_objects"] > st.num_objects
    st.split = info


def _joins(ctx: StepContext, st: ObjectSteps) -> None:
    sp, info = ctx.config.split, st.split
    assert info is not None
    graph_options = sp.model_dump(include={"voxel_size", "min_voxels", "concave_weight", "concave_angle", "concave_margin"})
    info["merges"], info["merge_mapping"] = [], None
    if sp.merge_ncut is not None:
        st.labels, merged = merge_objects(st.labels, ctx.points, ctx.cameras, min_ncut=sp.merge_ncut, **graph_options, num_objects=info["num_objects"], rng=ctx.config.seed)
        info["merges"] = merged["merges"]
        st.lineage.record("merge", st.labels, evidence=_pairs(merged["merges"], "ncut"), evidence_name="ncut")
        if merged["merges"]:
            info["merge_mapping"] = merged["mapping"].tolist()
            st.obj = merged["mapping"][st.obj]
            info["num_objects"] = merged["num_objects"]
            st.changed = True
    joiners = (  # pieces that share most of their image border; pieces that the masks hold together and that look alike
        ("joins", "join_shared", "shared", sp.join_shared, lambda lab, top, at: join_objects(lab, ctx.points, ctx.cameras, min_shared=at, num_objects=top)),
        (
            "mask_joins",
            "mask_join",
            "cover",
            sp.mask_join,
            lambda lab, top, at: join_by_masks(lab, ctx.masks, [v.rgb for v in ctx.views], min_cover=at, max_color=sp.mask_join_color, num_objects=top),
        ),
    )
    for key, step, value, setting, join in joiners:
        info[key] = []
        if setting is None:
            continue
        st.labels, joined = join(st.labels, info["num_objects"], setting)
        st.lineage.record(step, st.labels, evidence=_pairs(joined["joins"], value), evidence_name=value)
        if joined["joins"]:
            info[key], info["num_objects"] = joined["joins"], joined["num_objects"]
            st.obj = joined["mapping"][st.obj]
            st.changed = True


def _snap(ctx: StepContext, st: ObjectSteps) -> None:
    sp, info = ctx.config.split, st.split
    assert info is not None
    info["snapped"] = 0
    if sp.snap_share is None:
        return
    # pixels the voxel border cut off a mask go back to its object where the other views agree
    st.labels, snapped = snap_to_masks(st.labels, ctx.masks, sp.snap_share, points=ctx.points, voxel_size=sp.voxel_size, num_objects=info["num_objects"])
    st.lineage.record("snap", st.labels)
    info["snapped"] = snapped["pixels"]
    if snapped["pixels"]:
        if snapped["mapping"] is not None:
            st.obj = snapped["mapping"][st.obj]
            info["num_objects"] = snapped["num_objects"]
        st.changed = True


def _final_support(ctx: StepContext, st: ObjectSteps) -> None:
    from .segment import drop_weak_parts

    # the final objects (the split's parts, the joins) need the support too: a part is often a strip
    # of table that the masks held to an object; objects.min_object_fraction may ask more of them
    cfg = ctx.config
    min_final = max(ctx.min_points, int(np.ceil(cfg.objects.min_object_fraction * ctx.pixels)))
    st.labels, remap, st.support["dropped_final"] = drop_weak_parts(st.labels, ctx.views, ctx.points, st.num_objects, min_final, cfg.objects.min_measured)
    if st.support["dropped_final"]:
        st.obj = remap[st.obj]
        st.num_objects = int(remap.max())
        if st.split is not None:
            st.split["num_objects"] = st.num_objects
        st.lineage.record("support_final", st.labels, reason="support")


def refine_pixels(ctx: StepContext, labels: list[np.ndarray], timings: dict[str, float]) -> tuple[list[np.ndarray], dict[str, Any]]:
    """The pixel refiners that ``ctx.config`` turns on, in order: ``refine``, ``grow``, ``trim``.

    Each moves border pixels of the existing objects only; ``info`` keeps
    each one's own record under its name and, under ``"refiners"``, the
    pixels it changed (``{name: pixels}``, plus ``"pixels"``, the total
    against the labels before the first, and ``"fraction"`` of all pixels).
    """
    cfg = ctx.config
    before = labels
    info: dict[str, Any] = {"refine": None, "grow": None, "trim": None}
    counts: dict[str, int] = {}
    steps = (
        ("refine", cfg.refine.enabled, lambda lab: refine_labels(lab, ctx.points, ctx.cameras, confidence=[v.confidence for v in ctx.views], tolerance=cfg.refine.tolerance, self_weight=cfg.refine.self_weight, min_views=cfg.refine.min_views)),
        ("grow", cfg.grow.enabled, lambda lab: grow_rims(lab, [v.rgb for v in ctx.views], band=cfg.grow.band, blur=cfg.grow.blur)),  # before the trim, so that with both on the trim has the last word
        ("trim", cfg.trim.enabled, lambda lab: trim_rims(lab, [v.rgb for v in ctx.views], window=cfg.trim.window, rim=cfg.trim.rim, blur=cfg.trim.blur)),
    )
    for name, on, step in steps:
        if not on:
            continue
        t = time.perf_counter()
        new, info[name] = step(labels)
        counts[name] = int(sum(int(np.count_nonzero(np.asarray(a) != np.asarray(b))) for a, b in zip(labels, new)))
        labels = new
        timings[name] = time.perf_counter() - t
    total = int(sum(int(np.count_nonzero(np.asarray(a) != np.asarray(b))) for a, b in zip(before, labels)))
    info["refiners"] = {**counts, "pixels": total, "fraction": total / max(1, ctx.pixels * len(labels))}
    return labels, info
