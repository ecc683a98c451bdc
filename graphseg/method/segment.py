"""segment(): the GraphSeg method on arrays.

1. Background class (table plane by RANSAC, below-plane and far points).
2. Per view, masks are composed into a label image; every surviving mask is a
   :class:`~graphseg.graphs.MaskNode`.
3. For each stage of ``config.stages``, the stage's edge criteria add edges to
   the current graph, the contractor returns a cluster vector, and
   :func:`~graphseg.graphs.coarsen` builds the next, contracted graph (parallel
   edges merge as the criteria's ``reduce`` declares). The default stages are
   ``[["pixel_match"], ["chamfer_3d"]]``: 2D edge addition and contraction,
   then 3D edge addition and contraction; any number of stages works.
4. Each final super-vertex is one object; ids are consistent across views, and
   every node of every stage graph carries its final object id (node column
   ``object``).

The criteria receive exactly the evidence they ``require`` (built once,
:func:`evidence_fields`). Steps 3 and 4 are public, :func:`run_stages` and
:func:`finish_segmentation`, so that the store's incremental update
(:mod:`graphseg.store.incremental`) runs the same code with its own edge source.

Examples
--------
>>> from graphseg.method.segment import segment
>>> from graphseg.testing.scenes import two_boxes_scene
>>> scene, masks, matches = two_boxes_scene()
>>> result = segment(scene, masks, matches)
>>> result.num_objects
2
"""

from __future__ import annotations

import time
from collections.abc import Callable, Collection, Mapping, Sequence
from typing import Any

import numpy as np

from ..config import Config, CriterionSpec, ObjectConfig
from ..graphs import CorrespondenceGraph, Evidence, coarsen, node_point_sets
from ..graphs.contract import canonical_cluster
from ..graphs.signed import run_contractor
from ..result import Result
from ..scene import Matches, Scene, SceneError, View
from .background import background_masks
from .masks import compose_masks, paint_masks
from .objects import StepContext, refine_pixels, run_operations
from .refine import project_to_view

__all__ = ["segment", "run_stages", "criterion_edges", "StageEdges", "finish_segmentation", "view_masks", "finite_points", "evidence_fields", "object_support", "confirming_views", "confirming_labels", "fragment_neighbours", "apply_min_support", "MasksLike"]

MasksLike = Sequence[Any]


def _check_inputs(scene: Scene, masks: MasksLike, matches: Mapping[tuple[int, int], Matches]) -> None:
    if len(masks) != scene.num_views:
        raise ValueError(f"expected one mask set per view ({scene.num_views}) (got {len(masks)})")
    for view in scene.views:
        if view.points is None:
            raise SceneError(
                "no 3D point map; run a lifter first (depth + intrinsics + poses: lifter 'rgbd')",
                where=view.name,
                field="points",
            )
    for (i, j), m in matches.items():
        if not (0 <= i < scene.num_views and 0 <= j < scene.num_views) or i == j:
            raise ValueError(f"expected matches keyed by view pairs (i, j) of distinct views in [0, {scene.num_views}) (got {(i, j)})")
        if not isinstance(m, Matches):
            raise TypeError(f"expected Matches for pair {(i, j)} (got {type(m).__name__})")


def _validate_masks(scene: Scene, masks: MasksLike) -> list[Any]:
    """Check each view's masks; return them with bool stacks split into lists."""
    return [view_masks(m, view) for view, m in zip(scene.views, masks)]


def view_masks(masks: Any, view: View) -> Any:
    """One view's masks, checked: an int label image as is, a bool stack or a list as a list of masks.

    Parameters
    ----------
    masks : int ``[H, W]``, bool ``[K, H, W]`` or list of bool or int ``[H, W]``
        The segmenter's output for ``view`` (0 = none in a label image).
    view : View
        Gives ``[H, W]`` and the name in errors.

    Returns
    -------
    int ``[H, W]`` or list of ``[H, W]``
        The label image itself, or the masks (not copied).

    Raises
    ------
    SceneError
        For a wrong shape or dtype: ``VIEW: masks: expected ... (got ...)``.

    Examples
    --------
    >>> from graphseg.scene import View
    >>> v = View("a", np.zeros((2, 3, 3), np.uint8))
    >>> len(view_masks(np.zeros((4, 2, 3), bool), v)), view_masks(np.ones((2, 3), np.int32), v).shape
    (4, (2, 3))
    >>> view_masks([np.zeros((3, 2), bool)], v)
    Traceback (most recent call last):
    ...
    graphseg.scene.SceneError: a: masks[0]: expected a bool mask [2, 3] (got bool [3, 2])
    """
    h, w = view.shape
    if isinstance(masks, np.ndarray):
        if masks.ndim == 2 and masks.shape == (h, w) and masks.dtype.kind in "iu":
            return masks
        if masks.ndim == 3 and masks.shape[1:] == (h, w) and masks.dtype == bool:
            return list(masks)
        raise SceneError(
            f"expected an int label image [{h}, {w}] or a bool stack [K, {h}, {w}] (got {masks.dtype} {list(masks.shape)})", where=view.name, field="masks"
        )
    if not isinstance(masks, (list, tuple)):
        raise SceneError(f"expected a list of bool masks [{h}, {w}], a bool stack or a label image (got {type(masks).__name__})", where=view.name, field="masks")
    for k, mk in enumerate(masks):
        a = np.asarray(mk)
        if a.shape != (h, w) or a.dtype.kind not in "biu":
            raise SceneError(f"expected a bool mask [{h}, {w}] (got {a.dtype} {list(a.shape)})", where=view.name, field=f"masks[{k}]")
    return list(masks)


def finite_points(points: np.ndarray) -> np.ndarray:
    """``points`` with every pixel that has a non-finite coordinate set to NaN (a copy only if needed).

    Parameters
    ----------
    points : float ``[H, W, 3]``

    Returns
    -------
    float ``[H, W, 3]``
        ``points`` itself when all is finite, else a float32 copy.

    Notes
    -----
    O(H W).

    Examples
    --------
    >>> p = np.zeros((1, 2, 3)); p[0, 1, 0] = np.inf
    >>> finite_points(p)[0].tolist()
    [[0.0, 0.0, 0.0], [nan, nan, nan]]
    """
    p = np.asarray(points)
    fin = np.isfinite(p)
    if fin.all():  # common case: one SIMD pass over the flat array, no per-pixel reduction
        return p
    bad = ~(fin[..., 0] & fin[..., 1] & fin[..., 2])
    p = p.astype(np.float32, copy=True)
    p[bad] = np.nan
    return p


def object_support(labels: Sequence[np.ndarray], points: Sequence[np.ndarray], num_objects: int) -> tuple[np.ndarray, np.ndarray]:
    """Views and valid 3D points of every object in the label images.

    Parameters
    ----------
    labels : list of int ``[H, W]``
        Per view; 0 = none, ``1..num_objects`` objects.
    points : list of float ``[H, W, 3]``
        World points; a pixel counts when all three coordinates are finite.
    num_objects : int

    Returns
    -------
    views, points : int64 ``[num_objects]``
        ``views[k - 1]``: the views in which object ``k`` has a valid pixel;
        ``points[k - 1]``: its valid pixels over all views.

    Notes
    -----
    O(total pixels).

    Examples
    --------
    >>> lab = [np.array([[1, 1, 2]]), np.array([[0, 1, 0]])]
    >>> pts = [np.zeros((1, 3, 3)), np.zeros((1, 3, 3))]
    >>> pts[0][0, 1] = np.nan                       # no 3D point behind one pixel
    >>> [a.tolist() for a in object_support(lab, pts, 2)]
    [[2, 1], [2, 1]]
    """
    views = np.zeros(num_objects, np.int64)
    count = np.zeros(num_objects, np.int64)
    for lab, p in zip(labels, points):
        pa = np.asarray(p)
        valid = np.isfinite(pa[..., 0]) & np.isfinite(pa[..., 1]) & np.isfinite(pa[..., 2])
        c = np.bincount(np.asarray(lab, np.int64)[valid], minlength=num_objects + 1)[1 : num_objects + 1]
        count += c
        views += c > 0
    return views, count


def confirming_views(
    pts: np.ndarray,
    view: int,
    points: Sequence[np.ndarray],
    cameras: Sequence[tuple[np.ndarray, np.ndarray]],
    foreground: Sequence[np.ndarray],
    *,
    tolerance: float = 0.03,
    min_share: float = 0.3,
) -> int:
    """How many other views see the world points ``pts`` of one view's object where they are.

    A view confirms them when at least ``min_share`` of the points that project
    into its image land on a foreground pixel whose own point lies at the same
    depth (within ``tolerance`` of the depth, a relative test that holds at any
    scale). An object cut from one view only, whose points no other view sees
    there (a floor tile lifted to the wrong depth), is confirmed by none; one
    that the graph left unmerged but that the other views see is confirmed.

    Parameters
    ----------
    pts : float ``[P, 3]``
        World points of the object in view ``view``.
    view : int
        The view they come from (not counted).
    points : list of float ``[H, W, 3]``
        World point maps of every view.
    cameras : list of (K ``[3, 3]``, cam_to_world ``[4, 4]``)
    foreground : list of bool ``[H, W]``
        Pixels with a valid point that are not background.
    tolerance, min_share : float, keyword-only

    Returns
    -------
    int
        The number of confirming views.

    Notes
    -----
    O(P) per view.

    Examples
    --------
    >>> K = np.array([[10.0, 0, 2], [0, 10, 2], [0, 0, 1]])
    >>> pm = np.zeros((5, 5, 3)); pm[..., 2] = 1.0          # a wall at z = 1 seen by camera 1
    >>> cams = [(K, np.eye(4)), (K, np.eye(4))]
    >>> fg = [np.ones((5, 5), bool)] * 2
    >>> confirming_views(np.array([[0.0, 0, 1.0]]), 0, [pm, pm], cams, fg)
    1
    >>> confirming_views(np.array([[0.0, 0, 0.5]]), 0, [pm, pm], cams, fg)   # floats in front of it
    0
    """
    return confirming_labels(pts, view, points, cameras, foreground, None, tolerance=tolerance, min_share=min_share)[0]


def confirming_labels(
    pts: np.ndarray,
    view: int,
    points: Sequence[np.ndarray],
    cameras: Sequence[tuple[np.ndarray, np.ndarray]],
    foreground: Sequence[np.ndarray],
    labels: Sequence[np.ndarray] | None,
    *,
    tolerance: float = 0.03,
    min_share: float = 0.3,
) -> tuple[int, dict[int, int]]:
    """:func:`confirming_views`, and the object ids the confirming views give those points.

    Parameters
    ----------
    pts, view, points, cameras, foreground, tolerance, min_share
        As in :func:`confirming_views`.
    labels : list of int ``[H, W]`` or None
        Object ids per view (0 = none); None counts views only.

    Returns
    -------
    views : int
        The number of confirming views.
    ids : dict
        ``{object id: pixels}`` over the confirmed pixels of the confirming
        views (empty without ``labels``).

    Examples
    --------
    >>> K = np.array([[10.0, 0, 2], [0, 10, 2], [0, 0, 1]])
    >>> pm = np.zeros((5, 5, 3)); pm[..., 2] = 1.0
    >>> lab = [np.zeros((5, 5), int), np.full((5, 5), 7)]
    >>> confirming_labels(np.array([[0.0, 0, 1.0]]), 0, [pm, pm], [(K, np.eye(4))] * 2, [np.ones((5, 5), bool)] * 2, lab)
    (1, {7: 1})
    """
    out = 0
    ids: dict[int, int] = {}
    P = np.asarray(pts, np.float64)
    for w, ((K, T), pm, fg) in enumerate(zip(cameras, points, foreground)):
        if w == view or K is None or T is None or len(P) == 0:
            continue
        seen, v, u = project_to_view(P, K, T, pm, tolerance=tolerance)
        h, wd = fg.shape
        inside = (u >= 0) & (u < wd) & (v >= 0) & (v < h)  # in front of the camera and in the image
        if not inside.any():
            continue
        v, u, seen = v[inside], u[inside], seen[inside]
        ok = fg[v, u] & seen
        if ok.mean() >= min_share:
            out += 1
            if labels is not None:
                for i, c in zip(*np.unique(np.asarray(labels[w])[v[ok], u[ok]], return_counts=True)):
                    ids[int(i)] = ids.get(int(i), 0) + int(c)
    return out, ids


#: At most this many points of an object per view enter :func:`apply_min_support`'s confirmation test (evenly strided).
CONFIRM_SAMPLE = 2000


def apply_min_support(
    obj: np.ndarray,
    labels: Sequence[np.ndarray],
    points: Sequence[np.ndarray],
    options: ObjectConfig | None = None,
    *,
    cameras: Sequence[tuple[Any, Any]] | None = None,
    foreground: Sequence[np.ndarray] | None = None,
    mask_view: np.ndarray | None = None,
) -> tuple[np.ndarray, list[np.ndarray], dict[str, Any]]:
    """Objects below the minimum support become background; the rest are renumbered ``1..K``.

    An object counts the views it has pixels in; one with fewer than
    ``min_views`` and at least ``min_confirm`` valid points also counts the
    views that see its points where they are (:func:`confirming_views`, when
    ``cameras`` and ``foreground`` are given), so an object the graph left in
    one view is kept when the other views see it. With ``merge``, when the
    pixels that confirm it carry, in more than half of the cases, one other
    object with full support, it joins that object instead (the graph missed
    the edge, for example because one view's estimated pose or points were a
    little off).
    Small fragments next to an object are not confirmed: a depth halo around
    the object in another view would confirm them.

    Parameters
    ----------
    obj : int64 ``[M]``
        Object id (``1..K``) of every mask.
    labels : list of int ``[H, W]``
        The painted object ids per view.
    points : list of float ``[H, W, 3]``
    options : graphseg.config.ObjectConfig, optional
        The ``objects`` section (default: its defaults). Read here:
        ``min_views`` (capped at the number of views) and
        ``min_point_fraction`` (times one view's pixels: the valid points an
        object needs), ``confirm_fraction`` (the same: the valid points an
        object needs before other views may confirm it) and ``merge_seen``
        (let a confirmed one-view object join the object the confirming views
        see there).
    cameras : list of (K, cam_to_world), optional, keyword-only
    foreground : list of bool ``[H, W]``, optional, keyword-only
    mask_view : int64 ``[M]``, optional, keyword-only
        The view of every mask. With it (and ``cameras``), a dropped fragment
        that continues a kept object across its border in the image
        (:func:`fragment_neighbours`) is given to that object instead of the
        background: a piece the segmenter cut off an object stays with it.

    Returns
    -------
    obj : int64 ``[M]``
        New ids, 0 for the masks of dropped objects (order of the kept ids unchanged).
    labels : list of int32 ``[H, W]``
        New label images (new arrays; the inputs are not modified).
    support : dict
        ``min_views`` (as applied), ``min_points``, ``confirmed`` (objects kept by
        views that see them, merged ones included), ``dropped`` (how many),
        ``absorbed`` (fragments given to the object they continue, per view),
        ``merged`` (confirmed objects that joined the object the other views
        see there) and ``dropped_objects``:
        ``{"views", "points"}`` per dropped object.

    Examples
    --------
    >>> lab = [np.array([[1, 1, 2, 3]]), np.array([[1, 0, 0, 3]])]
    >>> pts = [np.zeros((1, 4, 3)), np.zeros((1, 4, 3))]
    >>> from graphseg.config import ObjectConfig
    >>> new, out, info = apply_min_support(np.array([1, 2, 3, 1, 3]), lab, pts, ObjectConfig(min_views=2, min_point_fraction=0))
    >>> new.tolist(), out[0].tolist(), info["dropped"]
    ([1, 0, 2, 1, 2], [[1, 1, 0, 2]], 1)
    """
    opt = options if options is not None else ObjectConfig()
    pixels = int(np.asarray(labels[0]).size) if len(labels) else 0
    min_points, min_confirm = int(np.ceil(opt.min_point_fraction * pixels)), int(np.ceil(opt.confirm_fraction * pixels))
    merge, sample = opt.merge_seen, CONFIRM_SAMPLE
    num = int(obj.max()) if obj.size else 0
    need_views = min(int(opt.min_views), len(labels))
    views, count = object_support(labels, points, num)
    seen = views.copy()
    confirmed = 0
    part_of = np.zeros(num, np.int64)  # 1-based object that the confirming views see in place of this one
    if cameras is not None and foreground is not None and all(K is not None and T is not None for K, T in cameras):
        candidates = np.flatnonzero((views < need_views) & (count >= max(int(min_points), int(min_confirm))))
        groups = []  # per view: pixel indices sorted by object id (stable: increasing index within an id), and the id bounds
        for lab in labels if candidates.size else []:
            flat = np.asarray(lab).ravel()
            order = np.argsort(flat, kind="stable")
            groups.append((order, np.searchsorted(flat[order], np.arange(num + 2))))
        for k in candidates:
            ids: dict[int, int] = {}
            for v, pm in enumerate(points):
                order, bounds = groups[v]
                sel = order[bounds[k + 1] : bounds[k + 2]]
                if sel.size == 0:
                    continue
                pts = np.asarray(pm).reshape(-1, 3)[sel[:: max(1, sel.size // sample)]]
                pts = pts[np.isfinite(pts).all(1)]
                n, seen_ids = confirming_labels(pts, v, points, cameras, foreground, labels)
                seen[k] += n
                for i, c in seen_ids.items():
                    ids[i] = ids.get(i, 0) + c
            if seen[k] < need_views:
                continue
            confirmed += 1
            # The other views see these points as part of one object with full support:
            # the graph missed that edge (one view's pose or points were off), so the
            # fragment joins it instead of standing as an object of its own.
            total = sum(c for i, c in ids.items() if i > 0)
            best = max((i for i in ids if i > 0 and i != k + 1), key=lambda i: ids[i], default=0)
            if merge and best and 2 * ids[best] > total and views[best - 1] >= need_views:
                part_of[k] = best
    keep = (seen >= need_views) & (count >= int(min_points)) & (part_of == 0)
    remap = np.zeros(num + 1, np.int64)
    remap[1:][keep] = np.arange(1, int(keep.sum()) + 1)
    merged = np.flatnonzero(part_of > 0)
    remap[merged + 1] = remap[part_of[merged]]
    new_obj = remap[np.asarray(obj, np.int64)]
    new_labels = [remap[np.asarray(lab, np.int64)].astype(np.int32) for lab in labels]
    absorbed = 0
    placed = keep | (part_of > 0)
    if mask_view is not None and cameras is not None and all(T is not None for _, T in cameras) and (~placed).any():
        for v, (lab, pm, (_, T)) in enumerate(zip(labels, points, cameras)):
            into = fragment_neighbours(np.asarray(lab), np.asarray(pm), np.asarray(T)[:3, 3], placed)
            if not into:
                continue
            for frag, c in into.items():  # fragment frag (1-based, dropped) continues object c (1-based, kept)
                new_labels[v][np.asarray(lab) == frag] = remap[c]
                sel = (np.asarray(mask_view) == v) & (np.asarray(obj) == frag)
                new_obj[sel] = remap[c]
                absorbed += 1
    info: dict[str, Any] = {
        "min_views": need_views,
        "min_points": int(min_points),
        "confirmed": confirmed,
        "dropped": int((~placed).sum()),
        "absorbed": absorbed,
        "merged": int(merged.size),
        "dropped_objects": [{"views": int(v), "points": int(c)} for v, c in zip(views[~placed], count[~placed])],
    }
    return new_obj, new_labels, info


def measured_points(labels: Sequence[np.ndarray], views: Sequence[View], points: Sequence[np.ndarray], num_objects: int) -> tuple[np.ndarray, np.ndarray] | None:
    """Valid points and measured points of every object, over the views whose lifter recorded its fill confidence.

    A lifter that fills holes in its point maps (the ``sfm`` lifter's
    colour-region planes) records in ``View.meta["fill_confidence"]`` the
    confidence it gives a point that nothing measured; a point counts as
    measured when its confidence is above that.

    Returns
    -------
    (total, measured) : int64 ``[num_objects + 1]`` each (index = object id; 0 = none), or None
        None when no view has the record (and a confidence).
    """
    tested = [i for i, v in enumerate(views) if v.confidence is not None and v.meta.get("fill_confidence") is not None]
    if not tested:
        return None
    total = np.zeros(num_objects + 1, np.int64)
    measured = np.zeros(num_objects + 1, np.int64)
    for i in tested:
        lab = np.asarray(labels[i], np.int64)
        valid = np.isfinite(np.asarray(points[i])).all(-1)
        good = valid & (np.asarray(views[i].confidence) > float(views[i].meta["fill_confidence"]))
        lab = np.where(valid & (lab <= num_objects), lab, num_objects + 1)  # the other pixels go to a bin of their own
        total += np.bincount(lab.ravel(), minlength=num_objects + 2)[: num_objects + 1]
        measured += np.bincount(lab[good], minlength=num_objects + 2)[: num_objects + 1]
    return total, measured


def _weak_measured(total: np.ndarray, measured: np.ndarray, min_measured: float) -> np.ndarray:
    """Ids (> 0) of the objects whose measured share is below ``min_measured`` (:func:`measured_points`; index 0 holds the unlabelled pixels)."""
    weak = np.flatnonzero((total > 0) & (measured < min_measured * total))
    return weak[weak > 0]


def _relabel(labels: Sequence[np.ndarray], weak: np.ndarray, num_objects: int) -> tuple[list[np.ndarray], np.ndarray]:
    """``labels`` with the objects ``weak`` (ids) unlabelled and the others renumbered ``1..K`` in order; and the id map ``[num_objects + 1]``."""
    keep = np.ones(num_objects + 1, bool)
    keep[0] = False
    keep[weak] = False
    remap = np.zeros(num_objects + 1, np.int64)
    remap[keep] = np.arange(1, int(keep.sum()) + 1)
    return [remap[np.asarray(lab, np.int64)].astype(np.asarray(lab).dtype) for lab in labels], remap


def drop_unmeasured(labels: Sequence[np.ndarray], views: Sequence[View], points: Sequence[np.ndarray], min_measured: float) -> tuple[list[np.ndarray], int]:
    """Unlabel the objects less than ``min_measured`` of whose valid points measurement supports (:func:`measured_points`).

    An object whose share of measured points (over all views that have the
    record) is below ``min_measured`` is a surface the fill invented (far
    floor or wall seen past the table, a table patch at a wrong depth), not an
    object: its pixels become 0, and :func:`apply_min_support` then drops it
    like any object with no support. Views without the record, or without
    confidence, are not tested. The other ids are kept as they are.

    Parameters
    ----------
    labels : list of int ``[H, W]``
        Object ids per view (0 = none).
    views : list of View
        Their ``confidence`` and ``meta["fill_confidence"]`` are read.
    points : list of float ``[H, W, 3]``
    min_measured : float
        0 returns ``labels`` unchanged.

    Returns
    -------
    labels : list of int ``[H, W]``
        New arrays where an object was unlabelled, else the inputs.
    dropped : int
        Objects unlabelled.

    Examples
    --------
    >>> from graphseg.scene import View
    >>> conf = np.array([[0.25, 0.25, 0.25, 0.9]], np.float32)
    >>> v = View("a", np.zeros((1, 4, 3), np.uint8), confidence=conf, meta={"fill_confidence": 0.25})
    >>> out, n = drop_unmeasured([np.array([[1, 1, 2, 2]])], [v], [np.zeros((1, 4, 3))], 0.2)
    >>> out[0].tolist(), n
    ([[0, 0, 2, 2]], 1)
    """
    if min_measured <= 0:
        return list(labels), 0
    k = max((int(np.max(lab)) for lab in labels if np.size(lab)), default=0)
    shares = measured_points(labels, views, points, k)
    if shares is None:
        return list(labels), 0
    weak = _weak_measured(*shares, min_measured)
    if not weak.size:
        return list(labels), 0
    lut = np.arange(k + 1, dtype=np.int64)
    lut[weak] = 0
    return [lut[np.asarray(lab, np.int64)].astype(np.asarray(lab).dtype) for lab in labels], int(weak.size)


def drop_weak_parts(
    labels: Sequence[np.ndarray], views: Sequence[View], points: Sequence[np.ndarray], num_objects: int, min_points: int, min_measured: float
) -> tuple[list[np.ndarray], np.ndarray, int]:
    """The final objects below the minimum support become background, and the rest are renumbered ``1..K``.

    The split (:func:`~graphseg.method.split.split_objects`) cuts objects that
    passed :func:`apply_min_support` into parts, and the joins put parts
    together; on estimated points a part is often a strip of table or floor
    that the masks held to an object. Every final object needs
    ``min_points`` valid points over all views and, where the views record
    their fill confidence, a ``min_measured`` share of measured points
    (:func:`measured_points`), like any object. With the ``rgbd`` preset
    (``min_point_fraction``: 92 points at 640 x 480; no ``min_object_fraction``
    or ``min_measured``) every object has passed :func:`apply_min_support` and
    every part holds at least ``split.min_voxels`` voxels, so none of measured
    depth is dropped.

    Returns
    -------
    labels : list of int ``[H, W]``
    remap : int64 ``[num_objects + 1]``
        Old id -> new id (0: dropped).
    dropped : int

    Examples
    --------
    >>> lab = [np.array([[1, 1, 1, 2, 3, 3]])]
    >>> out, remap, n = drop_weak_parts(lab, [], [np.zeros((1, 6, 3))], 3, 2, 0.0)
    >>> out[0].tolist(), remap.tolist(), n
    ([[1, 1, 1, 0, 2, 2]], [0, 1, 0, 2], 1)
    """
    num_objects = max([int(num_objects)] + [int(np.max(lab)) for lab in labels if np.size(lab)])
    _, count = object_support(labels, points, num_objects)
    weak = np.flatnonzero(count < int(min_points)) + 1
    if min_measured > 0:
        shares = measured_points(labels, views, points, num_objects)
        if shares is not None:
            weak = np.union1d(weak, _weak_measured(*shares, min_measured))
    if not weak.size:
        return list(labels), np.arange(num_objects + 1, dtype=np.int64), 0
    out, remap = _relabel(labels, weak, num_objects)
    return out, remap, int(weak.size)


def fragment_neighbours(labels: np.ndarray, points: np.ndarray, center: np.ndarray, keep: np.ndarray, *, tolerance: float = 0.03, min_pairs: int = 3) -> dict[int, int]:
    """Which kept object each dropped fragment of one view continues, if any.

    A fragment continues object ``c`` when it touches ``c`` in the image
    (4-neighbour pixel pairs) and the surface runs on across that border: the
    two points of at least half of those pairs (and ``min_pairs``) lie within
    ``tolerance`` of their distance to the camera of each other. Of several
    such objects it continues the one with the most such pairs. A fragment cut
    off an object by the segmenter goes back to it; a floor tile or a fragment
    across a depth step does not.

    Parameters
    ----------
    labels : int ``[H, W]``
        Object ids before the support rule (0 = none).
    points : float ``[H, W, 3]``
        World points of the view.
    center : float ``[3]``
        The view's camera centre.
    keep : bool ``[K]``
        ``keep[k - 1]``: object ``k`` meets the minimum support.
    tolerance : float, keyword-only
        Relative distance between neighbouring points (a scale-free test).
    min_pairs : int, keyword-only

    Returns
    -------
    dict
        Fragment id -> object id (both 1-based, before renumbering).

    Notes
    -----
    O(H W).

    Examples
    --------
    >>> lab = np.array([[1, 1, 2, 2, 0, 3]])
    >>> pts = np.zeros((1, 6, 3)); pts[..., 2] = 1.0; pts[0, 5, 2] = 3.0   # 3 lies far behind
    >>> pts[..., 0] = np.arange(6) * 0.001
    >>> fragment_neighbours(lab, pts, np.zeros(3), np.array([True, False, False]), min_pairs=1)
    {2: 1}
    """
    lab = np.asarray(labels, np.int64)
    pts = np.asarray(points, np.float64)
    k = len(keep)
    kept = np.zeros(k + 1, bool)
    kept[1:] = keep
    dropped = np.zeros(k + 1, bool)
    dropped[1:] = ~keep
    total = np.zeros((k + 1, k + 1), np.int64)
    good = np.zeros((k + 1, k + 1), np.int64)
    for a_sl, b_sl in (((slice(None), slice(None, -1)), (slice(None), slice(1, None))), ((slice(None, -1), slice(None)), (slice(1, None), slice(None)))):
        la, lb = lab[a_sl].ravel(), lab[b_sl].ravel()
        for frag, other, pf, po in ((la, lb, pts[a_sl], pts[b_sl]), (lb, la, pts[b_sl], pts[a_sl])):
            sel = np.flatnonzero(dropped[frag] & kept[other])
            if sel.size == 0:
                continue
            p, q = pf.reshape(-1, 3)[sel], po.reshape(-1, 3)[sel]
            with np.errstate(invalid="ignore"):
                near = np.linalg.norm(p - q, axis=1) <= tolerance * np.linalg.norm(p - center, axis=1)
            np.add.at(total, (frag[sel], other[sel]), 1)
            np.add.at(good, (frag[sel], other[sel]), near.astype(np.int64))
    out: dict[int, int] = {}
    for f in np.flatnonzero(dropped):
        row = good[f]
        c = int(np.argmax(row))
        if row[c] >= min_pairs and 2 * row[c] >= total[f, c]:
            out[int(f)] = c
    return out


def _degenerate_warnings(num_views: int, num_masks: int, num_objects: int) -> list[str]:
    warn = []
    if num_views == 1:
        warn.append("only one view: no cross-view evidence, every mask is its own object")
    if num_masks == 0:
        warn.append("no usable masks (every mask was empty, background, or below masks.min_area): 0 objects")
    elif num_objects == 0:
        warn.append("0 objects found")
    return warn


def evidence_fields(
    required: Collection[str],
    views: Sequence[View],
    *,
    matches: Mapping[tuple[int, int], Matches],
    points: list[np.ndarray],
    features: Any,
    labels: list[np.ndarray],
    name: str,
) -> dict[str, Any]:
    """The evidence fields the criteria require, built once for all stages.

    ``node_labels`` is added per stage by
    :meth:`~graphseg.graphs.Evidence.for_graph`; ``normal_cache`` (an empty
    dict) lets the stages' criteria compute the normals once.

    Parameters
    ----------
    required : set of str
        ``Config.requires()``: ``matches``, ``points``, ``features``, ``rgb``,
        ``cameras``, ``confidence``, ``masks``.
    views : list of View
        Give ``rgb``, ``cameras`` (``K``, ``cam_to_world``) and ``confidence``.
    matches : mapping ``(i, j) -> Matches``, keyword-only
    points : list of float ``[H, W, 3]``, keyword-only
    features : optional, keyword-only
        Per-view maps ``[h, w, D]`` or per-node ``[N, D]``.
    labels : list of int ``[H, W]``, keyword-only
        The composed masks (``masks``).
    name : str, keyword-only
        The scene's name, for errors.

    Returns
    -------
    dict
        The required fields, and ``normal_cache``.

    Raises
    ------
    ValueError
        ``features`` are required and None.
    SceneError
        ``rgb`` is required and a view has none.

    Examples
    --------
    >>> from graphseg.scene import View
    >>> v = View("a", np.zeros((2, 3, 3), np.uint8))
    >>> sorted(evidence_fields({"rgb", "masks"}, [v], matches={}, points=[], features=None, labels=[], name="s"))
    ['masks', 'normal_cache', 'rgb']
    """
    out: dict[str, Any] = {}
    if "matches" in required:
        out["matches"] = matches
    if "points" in required:
        out["points"] = points
    if "features" in required:
        if features is None:
            raise ValueError("a configured criterion requires features; pass features= (per-view maps [h, w, D] or per-node [N, D])")
        out["features"] = features
    if "rgb" in required:
        if any(v.rgb is None for v in views):
            raise SceneError("a configured criterion requires rgb images", where=name, field="rgb")
        out["rgb"] = [v.rgb for v in views]
    if "cameras" in required:
        out["cameras"] = [(v.K, v.cam_to_world) for v in views]
    if "confidence" in required:
        out["confidence"] = [v.confidence for v in views]
    if "masks" in required:
        out["masks"] = labels
    out["normal_cache"] = {}  # normals are computed once for all stages' criteria
    return out


#: What an edge source gives for one criterion on one stage graph: the edges, as parts
#: ``(edge_index int64 [2, E], edge_attr {name: [E]})``, and the adder's info (``Result.info["stages"]``).
StageEdges = tuple[list[tuple[np.ndarray, dict[str, np.ndarray]]], dict[str, Any]]


def criterion_edges(spec: CriterionSpec, stage: int, graph: CorrespondenceGraph, evidence: Evidence) -> StageEdges:
    """The edges one configured criterion adds to one stage graph, computed on the whole graph.

    The default edge source of :func:`run_stages`.

    Parameters
    ----------
    spec : CriterionSpec
        The criterion and its options (one entry of ``config.stages``).
    stage : int
        The stage index (unused here; part of the edge-source signature).
    graph : CorrespondenceGraph
        The stage's graph before edges are added.
    evidence : Evidence
        :meth:`~graphseg.graphs.Evidence.for_graph` of ``graph``.

    Returns
    -------
    parts : list of (int64 ``[2, E]``, dict of ``[E]``)
        One part: the criterion's edges and their attributes.
    info : dict
        ``edges`` (E) and the criterion's scalar diagnostics.

    Notes
    -----
    The cost of the criterion.

    Examples
    --------
    >>> lab = [np.array([[1, 1, 2]]), np.array([[1, 1, 0]])]   # masks 0, 1 of view 0; mask 0 of view 1
    >>> pts = [np.zeros((1, 3, 3)), np.zeros((1, 3, 3))]
    >>> pts[0][0, 2] = 1.0                                      # mask 1 of view 0 lies 1 m away
    >>> g = CorrespondenceGraph.from_masks(lab, pts)
    >>> spec = CriterionSpec.model_validate({"chamfer_3d": {"tau": 1e-4}})
    >>> parts, info = criterion_edges(spec, 1, g, Evidence.for_graph(g, points=pts))
    >>> parts[0][0].tolist(), info["edges"]
    ([[0], [2]], 1)
    """
    es = spec.build()(graph, evidence)
    return [(es.edge_index, dict(es.edge_attr))], {"edges": es.num_edges, **{k: v for k, v in es.info.items() if np.isscalar(v)}}


def run_stages(
    graph: CorrespondenceGraph,
    config: Config,
    shared: Mapping[str, Any],
    *,
    rng: np.random.Generator,
    edges: Callable[[CriterionSpec, int, CorrespondenceGraph, Evidence], StageEdges] = criterion_edges,
) -> tuple[CorrespondenceGraph, list[CorrespondenceGraph], list[dict[str, Any]]]:
    """Edge addition and contraction, stage by stage: the core of :func:`segment`.

    For each stage of ``config.stages``, every criterion's edges are added to
    a copy of the current graph (edge columns ``stage`` and ``criterion``
    set), the contractor (``config.contractor``) partitions it and
    :func:`~graphseg.graphs.coarsen` builds the next graph
    (``config.edge_reduce()`` merges parallel edges).

    Parameters
    ----------
    graph : CorrespondenceGraph
        The mask graph.
    config : Config
        ``stages``, ``contractor`` and the criteria's ``reduce`` are read.
    shared : mapping
        The evidence fields the criteria require (``node_labels`` is added
        per stage by :meth:`~graphseg.graphs.Evidence.for_graph`).
    rng : numpy.random.Generator, keyword-only
        Randomness of the contractor.
    edges : callable, keyword-only
        ``edges(spec, stage, graph, evidence) -> (parts, info)``: the edges
        of one criterion on one stage graph (default :func:`criterion_edges`;
        the store's incremental update reuses the edges of its last update).

    Returns
    -------
    partition : CorrespondenceGraph
        The graph after the last contraction (``graph`` itself without stages).
    stage_graphs : list of CorrespondenceGraph
        One per stage, with that stage's edges (``meta["stage"]`` set).
    stage_info : list of dict
        Per stage: ``stage``, ``nodes``, ``adders`` (each criterion's info),
        ``components`` and ``seconds``.

    Notes
    -----
    The cost of the criteria, plus one contraction and one coarsening per
    stage (about linear in nodes + edges).

    Examples
    --------
    >>> from graphseg.testing.scenes import two_boxes_scene
    >>> from graphseg.method.masks import compose_masks
    >>> scene, masks, matches = two_boxes_scene()
    >>> labels = [compose_masks(m, max_overlap=0.09, min_area=1)[0] for m in masks]
    >>> g = CorrespondenceGraph.from_masks(labels, [v.points for v in scene.views])
    >>> cfg = Config.preset("rgbd")
    >>> shared = {"matches": matches, "points": [v.points for v in scene.views], "normal_cache": {}}
    >>> part, graphs, info = run_stages(g, cfg, shared, rng=np.random.default_rng(0))
    >>> [s["nodes"] for s in info], part.num_nodes      # 2 boxes x 2 parts x 3 views + 3 table masks
    ([15, 3], 3)
    """
    contractor = config.contractor.build()
    edge_reduce = config.edge_reduce()
    stage_graphs: list[CorrespondenceGraph] = []
    stage_info: list[dict[str, Any]] = []
    current = graph
    for s, stage in enumerate(config.edge_stages):
        t = time.perf_counter()
        evidence = Evidence.for_graph(current, **shared)
        with_edges = current.copy()
        info_s: dict[str, Any] = {"stage": s, "nodes": current.num_nodes, "adders": {}}
        for spec in stage:
            parts, info_s["adders"][spec.name] = edges(spec, s, current, evidence)
            for ei, attrs in parts:
                n = ei.shape[1]
                attrs = dict(attrs)
                attrs["stage"] = np.full(n, s, np.int64)
                attrs.setdefault("criterion", np.full(n, spec.name))
                with_edges.add_edges(ei, attrs, in_place=True)
        cluster = run_contractor(contractor, with_edges.edge_index, with_edges.num_nodes, edge_attr=with_edges.edge_attr, node_attr=with_edges.node_attr, rng=rng)
        with_edges.meta["stage"] = s
        stage_graphs.append(with_edges)
        current = coarsen(with_edges, cluster, edge_reduce=edge_reduce)
        info_s["components"] = current.num_nodes
        info_s["seconds"] = time.perf_counter() - t
        stage_info.append(info_s)
    return current, stage_graphs, stage_info


def segment(
    scene: Scene,
    masks: MasksLike,
    matches: Mapping[tuple[int, int], Matches] | None,
    config: Config | None = None,
    *,
    features: Any = None,
    rng: Any = None,
    checked: bool = False,
) -> Result:
    """Run GraphSeg on one scene.

    Parameters
    ----------
    scene : Scene
        Views with world ``points`` ``[H, W, 3]`` (and ``cam_to_world`` for the
        background's distance test).
    masks : list, one entry per view
        A list of boolean masks ``[H, W]`` (may overlap or nest), a bool stack
        ``[K, H, W]``, or an int label image ``[H, W]`` (0 = none).
    matches : mapping ``(i, j) -> Matches`` or None
        Pixel matches per view pair (needed when a criterion requires ``matches``).
    config : Config, optional
        Defaults to ``Config()`` (GraphSeg); ``Config.minus()`` is GraphSeg-minus.
    features : optional
        Per-view per-pixel feature maps ``[h, w, D]`` for criteria that require
        ``features`` (e.g. ``dino``).
    rng : None, int or numpy.random.Generator, keyword-only
        Randomness of the background RANSAC and the contractor; default
        ``config.seed``.
    checked : bool, keyword-only
        The caller validated ``scene`` already (:func:`graphseg.pipeline.plan_run`):
        it is not validated again. The masks and matches always are.

    Returns
    -------
    Result
        ``info["warnings"]`` lists one-line warnings for degenerate input (one
        view, no usable mask, no object); such input still gives a valid result.

    Raises
    ------
    SceneError
        For an invalid scene (duplicate view names, non-rigid poses, wrong
        shapes) or masks of the wrong shape or dtype ("expected ... (got ...)").
        Non-finite points are treated as invalid pixels.

    Notes
    -----
    Cost is dominated by mask composition (O(K H W) per view), match lookup
    (O(total matches)) and the Chamfer stage (one sort of the gathered points
    plus k-d tree queries of candidate pairs).
    """
    cfg = config or Config()  # Config(method="sam3d") holds the sam3d stages (its validator put them there)
    matches = {} if matches is None else matches
    if not checked:
        scene.validate()
    _check_inputs(scene, masks, matches)
    masks = _validate_masks(scene, masks)
    gen = np.random.default_rng(cfg.seed if rng is None else rng)
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    points = [finite_points(np.asarray(v.points)) for v in scene.views]  # all present (checked above); inf -> invalid
    centers = [v.camera_center for v in scene.views] if all(v.cam_to_world is not None for v in scene.views) else None
    bg, bg_info = background_masks(points, centers, cfg.background, rng=gen)
    timings["background"] = time.perf_counter() - t0

    t = time.perf_counter()
    labels, compose_info = [], []
    for v, view in enumerate(scene.views):
        m = masks[v]
        lab, info = compose_masks(m, background=bg[v], max_overlap=cfg.background.max_overlap, min_area=cfg.masks.min_area)
        if lab.shape != view.shape:
            raise ValueError(f"view {view.name}: masks are {list(lab.shape)} but the image is {list(view.shape)}")
        labels.append(lab)
        compose_info.append(info)
    graph = CorrespondenceGraph.from_masks(labels, points, meta={"scene": scene.name})
    timings["compose"] = time.perf_counter() - t

    shared = evidence_fields(cfg.requires(), scene.views, matches=matches, points=points, features=features, labels=labels, name=scene.name)
    current, stage_graphs, stage_info = run_stages(graph, cfg, shared, rng=gen)
    timings.update({f"stage{i['stage']}": i["seconds"] for i in stage_info})

    return finish_segmentation(
        scene.views,
        current,
        stage_graphs,
        labels,
        points,
        bg,
        cfg,
        info={
            "background": {"plane": bg_info.plane, "max_distance": bg_info.max_distance, "fraction": bg_info.fraction},
            "masks": compose_info,
            "stages": stage_info,
            "timings": timings,
            "num_matches": int(sum(len(m) for m in matches.values())),
            "pairs": [list(p) for p in matches],
        },
        start=t0,
    )


def finish_segmentation(
    views: Sequence[View],
    partition: CorrespondenceGraph,
    stage_graphs: list[CorrespondenceGraph],
    labels: Sequence[np.ndarray],
    points: Sequence[np.ndarray],
    background: Sequence[np.ndarray],
    config: Config,
    *,
    info: Mapping[str, Any] | None = None,
    start: float | None = None,
) -> Result:
    """The objects of the final partition, and the :class:`~graphseg.result.Result` of a run.

    The steps after the last contraction, shared by :func:`segment` and the
    store's incremental update (:func:`graphseg.store.incremental.update`):
    every super-vertex of ``partition`` becomes one object (ids ``1..K`` by
    first appearance, :func:`~graphseg.graphs.contract.canonical_cluster`),
    its masks are painted into label images, the minimum-support rules
    (:func:`apply_min_support`, ``config.objects``) drop or merge objects,
    the optional refinement (``config.refine``) relabels pixels, the optional
    rim growing (``config.grow``) gives an object the unlabelled pixels at its
    rim up to the nearest colour edge, the optional
    rim trimming (``config.trim``) unlabels border pixels that look like the
    background beside them, every node of
    every stage graph gets its final object id (node column ``object``; 0 =
    below the minimum support) and the object clouds are gathered
    (``config.output``).

    Parameters
    ----------
    views : list of View
        The views of the run (their ``K``, ``cam_to_world``, ``confidence``,
        ``rgb``, names and shape are read; their point maps are not).
    partition : CorrespondenceGraph
        The graph after the last contraction; its ``members`` map every base
        mask ``(view, mask_id)`` to its super-vertex.
    stage_graphs : list of CorrespondenceGraph
        One per stage, with that stage's edges: they become ``Result.graphs``
        and their node column ``object`` is set (they are taken over, not copied).
    labels : list of int ``[H, W]``
        The composed masks per view, ``mask_id + 1`` (0 = none).
    points : list of float ``[H, W, 3]``
        World points per view (NaN = invalid).
    background : list of bool ``[H, W]``
        The background class per view.
    config : Config
        ``objects``, ``split``, ``refine``, ``grow``, ``trim`` and ``output`` are read.
    info : mapping, optional, keyword-only
        The run's own entries of ``Result.info`` (``background``, ``masks``,
        ``stages``, ``timings``, ``num_matches``, ``pairs``), kept in their
        order; ``support``, ``split``, ``refine``, ``trim``, ``grow`` and ``warnings`` are
        added, and ``timings`` (a copy) gets ``split`` (split and merge, when
        enabled), ``refine``, ``grow`` and ``trim`` (when enabled), ``outputs`` and ``total``. ``split`` (None
        when disabled) holds :func:`~graphseg.method.split.split_objects`'
        ``objects`` and ``first_new`` (ids before any merge), ``settled`` (voxels
        whose part :func:`~graphseg.method.split.settle_parts` changed, both passes;
        ``split.settle_band``), the grid of the
        finer pass, ``fine_voxel_size`` (None: one pass), and its ``fine_objects``
        and ``fine_first_new``, then the merge's ``merges``
        and ``merge_mapping`` (:func:`~graphseg.method.split.merge_objects`'
        ``merges``, and its ``mapping`` as a list, or None without a merge), the
        ``joins`` of :func:`~graphseg.method.join.join_objects` (``split.join_shared``;
        empty when off), ``mask_joins`` (those of
        :func:`~graphseg.method.join.join_by_masks`; ``split.mask_join``), ``snapped`` (the pixels :func:`~graphseg.method.masks.snap_to_masks`
        relabelled; ``split.snap_share``) and ``num_objects`` (the final count).
        ``support`` (:func:`apply_min_support`'s record) gains ``unmeasured``
        (objects :func:`drop_unmeasured` unlabelled before it) and
        ``dropped_final`` (final objects, after the split and the joins, below
        the support, :func:`drop_weak_parts`).
    start : float, optional, keyword-only
        :func:`time.perf_counter` at the start of the run, for
        ``timings["total"]`` (None: not recorded).

    Returns
    -------
    Result
        ``info["warnings"]`` lists one-line warnings for degenerate input (one
        view, no usable mask, no object).

    Notes
    -----
    O(total pixels) for the label images, the support rules and the object
    clouds, plus the confirmation test of the objects seen in too few views
    (:func:`confirming_labels`).

    Examples
    --------
    >>> from graphseg.graphs import CorrespondenceGraph
    >>> from graphseg.testing.scenes import two_boxes_scene
    >>> scene, masks, _ = two_boxes_scene(views=1)
    >>> lab = [np.asarray(masks[0][0], np.int32)]          # one mask: mask_id 0 in view 0
    >>> g = CorrespondenceGraph.from_masks(lab, [scene.views[0].points])
    >>> res = finish_segmentation(scene.views, g, [g.copy()], lab, [scene.views[0].points], [np.zeros(lab[0].shape, bool)], Config())
    >>> res.num_objects, res.graphs[0].node_attr["object"].tolist(), res.info["warnings"]
    (1, [1], ['only one view: no cross-view evidence, every mask is its own object'])
    """
    cfg = config
    t = time.perf_counter()
    head = dict(info or {})
    timings: dict[str, float] = dict(head.get("timings") or {})
    mem = partition.members
    obj = canonical_cluster(mem["node"]) + 1 if mem["node"].size else mem["node"]
    painted = paint_masks(labels, mem["view"], mem["mask_id"], obj, dtype=np.int32)
    ctx = StepContext(views, points, labels, background, mem["view"], mem["mask_id"], cfg)
    ops = [spec.build() for spec in cfg.operations]
    steps = run_operations(ctx, [op for op in ops if op.kind != "pixels"], painted, obj, first_step=f"stage{len(stage_graphs) - 1}" if stage_graphs else "masks")
    timings.update(steps.timings)
    t = time.perf_counter()  # "outputs": what follows the graph operations (objects graph, pixel refiners, object columns, clouds)
    objects_graph = steps.lineage.graph(meta={"scene": partition.meta.get("scene")})
    out_labels, pixel_info = refine_pixels(ctx, [op for op in ops if op.kind == "pixels"], steps.labels, timings)
    _object_columns(stage_graphs, labels, mem, steps.obj, steps.changed)
    num_objects = steps.num_objects
    object_nodes = [lab.astype(np.int64) - 1 for lab in out_labels]
    clouds = node_point_sets(object_nodes, points, num_objects, stride=cfg.output.stride, voxel_size=cfg.output.voxel_size, colors=[v.rgb for v in views])
    timings["outputs"] = time.perf_counter() - t
    if start is not None:
        timings["total"] = time.perf_counter() - start
    return Result(
        labels=out_labels,
        mask_view=mem["view"].copy(),
        mask_id=mem["mask_id"].copy(),
        mask_object=steps.obj.astype(np.int64),
        object_points=clouds,
        graphs=stage_graphs,
        config=cfg,
        view_names=[v.name for v in views],
        background=list(background),
        info={
            **head,
            "timings": timings,
            "support": steps.support,
            "split": steps.split,
            **pixel_info,
            "warnings": _degenerate_warnings(len(views), int(mem["node"].size), num_objects),
        },
        objects_graph=objects_graph,
    )


def _object_columns(stage_graphs: Sequence[CorrespondenceGraph], labels: Sequence[np.ndarray], mem: Mapping[str, np.ndarray], obj: np.ndarray, changed: bool) -> None:
    """Final object id of every node of every stage graph (node column ``object``; 0: below the minimum support).

    After a split the masks of one node can belong to different objects: the
    node takes the one with most pixels.
    """
    area = None
    if changed:
        sizes = [np.bincount(np.asarray(lab, np.int64).ravel()) for lab in labels]  # pixels of each composed mask
        area = np.array([sizes[v][m + 1] if m + 1 < sizes[v].size else 0 for v, m in zip(mem["view"].tolist(), mem["mask_id"].tolist())], np.float64)
    for g in stage_graphs:
        col = np.zeros(g.num_nodes, np.int64)
        if area is None:
            col[g.members["node"]] = obj
        else:
            node = np.asarray(g.members["node"], np.int64)
            k = int(obj.max(initial=0)) + 1
            votes = np.bincount(node * k + obj, weights=area + 1e-9, minlength=g.num_nodes * k).reshape(g.num_nodes, k)
            col = votes.argmax(1).astype(np.int64)
        g.node_attr["object"] = col
