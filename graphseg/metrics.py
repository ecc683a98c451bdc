"""Segmentation metrics following the GraphSeg paper.

All metrics are computed over every view's pixels that have a valid 3D point.
For each ground-truth object ``g``:

* the predicted object with the highest IoU gives ``iou``, ``precision``,
  ``recall`` and ``f1`` (pixel counts pooled over views);
* the predicted object with the lowest Chamfer distance gives ``chamfer`` and
  ``iou_sel`` (the IoU of that object).

Chamfer here is symmetric: the mean squared nearest-neighbour distance from A
to B plus the mean squared nearest-neighbour distance from B to A (m^2), on
voxel-downsampled world points.

``pixel_utility`` = ground-truth object pixels assigned to any predicted
object / ground-truth object pixels.

IoU, F1 and pixel utility never see a predicted object that overlaps no
ground-truth object, so they cannot count phantom objects (stray fragments,
floor tiles). Panoptic quality does (Kirillov et al., 2019): a ground-truth and
a predicted object match when their IoU (pooled over views) exceeds 0.5, a match
that is unique by construction. With TP matches, FP unmatched predicted objects
and FN unmatched ground-truth objects, ``sq`` is the mean IoU of the matches,
``rq = TP / (TP + FP / 2 + FN / 2)`` and ``pq = sq * rq``. ``num_pred`` and
``num_gt`` count the objects.

Examples
--------
>>> import numpy as np
>>> gt = [np.array([[1, 1, 0, 2]])]
>>> pred = [np.array([[5, 5, 5, 0]])]
>>> pts = [np.array([[[0, 0, 0], [0.01, 0, 0], [0.5, 0, 0], [1, 0, 0]]], np.float32)]
>>> m = evaluate(pred, gt, pts)
>>> [round(o["iou"], 3) for o in m["objects"]], round(m["mean"]["pixel_utility"], 3)
([0.667, 0.0], 0.667)
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from .graphs.chamfer import directed_chamfer, node_point_sets
from .graphs.pixel_match import pair_counts

__all__ = ["iou", "f1_score", "chamfer_distance", "contingency", "mean_iou", "panoptic_quality", "evaluate", "METRIC_KEYS"]

METRIC_KEYS = ("iou", "f1", "precision", "recall", "chamfer", "iou_sel")


def iou(a: np.ndarray, b: np.ndarray) -> float:
    """Intersection over union of two boolean masks (0 when both are empty).

    Examples
    --------
    >>> iou(np.array([1, 1, 0], bool), np.array([0, 1, 1], bool))
    0.3333333333333333
    """
    a, b = np.asarray(a, bool), np.asarray(b, bool)
    union = int((a | b).sum())
    return float((a & b).sum() / union) if union else 0.0


def f1_score(precision: float, recall: float) -> float:
    """Harmonic mean of precision and recall (0 when both are 0).

    Examples
    --------
    >>> f1_score(0.5, 1.0)
    0.6666666666666666
    """
    return 0.0 if precision + recall == 0 else 2 * precision * recall / (precision + recall)


def chamfer_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Symmetric Chamfer distance: mean_a min_b |a-b|^2 + mean_b min_a |a-b|^2 (inf if a set is empty).

    Examples
    --------
    >>> chamfer_distance(np.array([[0.0, 0, 0]]), np.array([[0.0, 0, 1], [0, 0, 3]]))
    6.0
    """
    return directed_chamfer(a, b) + directed_chamfer(b, a)


def contingency(pred: Sequence[np.ndarray], gt: Sequence[np.ndarray], valid: Sequence[np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pixel counts of every (gt id, predicted id) pair over all views.

    Returns
    -------
    table : int64 ``[G + 1, P + 1]``
        ``table[g, p]`` pixels with ground truth ``g`` and prediction ``p`` (row/col 0 = none).
    gt_ids, pred_ids : int64 arrays, the ids of rows and columns (starting with 0).
    """
    g_all, p_all = [], []
    for k, (p, g) in enumerate(zip(pred, gt)):
        if np.asarray(p).shape != np.asarray(g).shape:
            raise ValueError(f"view {k}: prediction {list(np.shape(p))} and ground truth {list(np.shape(g))} differ in shape")
        sel = np.ones(np.shape(g), bool) if valid is None else np.asarray(valid[k], bool)
        g_all.append(np.asarray(g, np.int64)[sel])
        p_all.append(np.asarray(p, np.int64)[sel])
    g = np.concatenate(g_all) if g_all else np.zeros(0, np.int64)
    p = np.concatenate(p_all) if p_all else np.zeros(0, np.int64)
    gt_ids, gi = _dense_ids(g)
    pred_ids, pi = _dense_ids(p)
    a, b, c = pair_counts(gi, pi, max(len(gt_ids), len(pred_ids)))
    table = np.zeros((len(gt_ids), len(pred_ids)), np.int64)
    table[a, b] = c
    return table, gt_ids, pred_ids


def _dense_ids(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The sorted ids of ``x`` with 0 (int64) and each element's index among them: ``union1d`` and
    ``searchsorted``, by counting when the ids are small non-negative integers (labels are), O(N + max id)."""
    x = np.asarray(x, np.int64)
    if x.size and x.min() >= 0 and x.max() <= 4 * x.size + (1 << 16):
        present = np.bincount(x)
        present[0] = 1
        ids = np.flatnonzero(present)
        lut = np.zeros(len(present), np.int64)
        lut[ids] = np.arange(len(ids))
        return ids.astype(np.int64), lut[x]
    ids = np.union1d([0], x)
    return ids, np.searchsorted(ids, x)


def mean_iou(pred: Sequence[np.ndarray], gt: Sequence[np.ndarray], points: Sequence[np.ndarray]) -> float | None:
    """The mean over ground-truth objects of their best IoU: ``evaluate(...)["mean"]["iou"]`` without the Chamfer part.

    Parameters
    ----------
    pred, gt : list of int ``[H, W]``
        Per view; 0 = background / none.
    points : list of float ``[H, W, 3]``
        Pixels with a non-finite point are ignored.

    Returns
    -------
    float or None
        None when the ground truth has no object.

    Notes
    -----
    O(total pixels).

    Examples
    --------
    >>> pts = [np.zeros((1, 4, 3))]
    >>> mean_iou([np.array([[5, 5, 5, 0]])], [np.array([[1, 1, 0, 2]])], pts)
    0.3333333333333333
    """
    valid = [np.isfinite(np.asarray(p)).all(-1) for p in points]
    ious = _iou_table(contingency(pred, gt, valid)[0])
    if ious.shape[0] == 0:
        return None
    return float(ious.max(axis=1).mean()) if ious.shape[1] else 0.0


def _iou_table(table: np.ndarray) -> np.ndarray:
    """IoU ``[G, P]`` of every ground-truth object with every predicted object, from :func:`contingency`'s table
    (row/column 0 is id 0, "none": ids are sorted and start with 0)."""
    inter = table[1:, 1:].astype(np.float64)
    union = table[1:].sum(1)[:, None] + table[:, 1:].sum(0)[None, :] - inter
    return np.divide(inter, union, out=np.zeros_like(inter), where=union > 0)


def panoptic_quality(iou_table: np.ndarray) -> dict[str, float | int]:
    """Panoptic quality from the IoU of every ground-truth (row) and predicted (column) object.

    Parameters
    ----------
    iou_table : float ``[G, P]``
        IoU of ground-truth object ``g`` and predicted object ``p``.

    Returns
    -------
    dict
        ``pq``, ``sq``, ``rq`` (floats; ``sq`` is 0 without a match, and all
        three are 1 when both sets are empty) and the counts ``tp``, ``fp``, ``fn``.

    Notes
    -----
    A pair matches when its IoU exceeds 0.5; each object then has at most one
    match, because the masks of one side do not overlap. O(G P).

    Examples
    --------
    >>> t = np.array([[0.9, 0.0, 0.0], [0.0, 0.6, 0.1]])   # 2 true objects, 3 predicted
    >>> q = panoptic_quality(t)
    >>> round(q["sq"], 3), round(q["rq"], 3), round(q["pq"], 3), q["fp"], q["fn"]
    (0.75, 0.8, 0.6, 1, 0)
    """
    t = np.asarray(iou_table, np.float64)
    if t.ndim != 2:
        raise ValueError(f"expected iou_table of shape [G, P] (got {list(t.shape)})")
    g, p = t.shape
    matched = t > 0.5
    tp = int(matched.sum())
    fp, fn = p - tp, g - tp
    if tp + fp + fn == 0:
        return {"pq": 1.0, "sq": 1.0, "rq": 1.0, "tp": 0, "fp": 0, "fn": 0}
    sq = float(t[matched].mean()) if tp else 0.0
    rq = tp / (tp + 0.5 * fp + 0.5 * fn)
    return {"pq": sq * rq, "sq": sq, "rq": rq, "tp": tp, "fp": fp, "fn": fn}


def evaluate(
    pred: Sequence[np.ndarray],
    gt: Sequence[np.ndarray],
    points: Sequence[np.ndarray],
    *,
    voxel_size: float | None = 0.005,
    names: Mapping[int, str] | None = None,
) -> dict[str, Any]:
    """Per-object and mean metrics for predicted vs ground-truth label images.

    Parameters
    ----------
    pred, gt : list of int ``[H, W]``
        Per view; 0 = background / none. Ids must be consistent across views.
    points : list of float ``[H, W, 3]``
        World points; pixels with a non-finite point are ignored.
    voxel_size : float, optional
        Downsampling for the Chamfer distances (metres).
    names : mapping, optional
        Ground-truth id -> object name for the rows.

    Returns
    -------
    dict
        ``{"objects": [{"id", "name", "iou", "f1", "precision", "recall", "pred",
        "chamfer", "iou_sel", "pred_sel", "pixels"}], "mean": {...,
        "pixel_utility", "pq", "sq", "rq"}, "num_gt", "num_pred",
        "panoptic": {"tp", "fp", "fn"}}``; ready for JSON. Only pixels with a
        valid point count, so ``num_pred`` counts the predicted objects that
        have at least one such pixel.

    Notes
    -----
    O(total pixels) for the overlap table; Chamfer costs one k-d tree query per
    (gt, predicted) pair on downsampled points.
    """
    valid = [np.isfinite(np.asarray(p)).all(-1) for p in points]
    table, gt_ids, pred_ids = contingency(pred, gt, valid)
    gt_size = table.sum(1)
    pred_size = table.sum(0)
    g_obj = np.flatnonzero(gt_ids > 0)
    p_obj = np.flatnonzero(pred_ids > 0)
    # point sets of each gt / predicted object, ids mapped to rows/cols - 1
    def sets(labels: Sequence[np.ndarray], ids: np.ndarray) -> Any:
        node = [np.searchsorted(ids, np.asarray(lab, np.int64)) - 1 for lab in labels]
        node = [np.where(np.isin(np.asarray(lab), ids[1:]), n, -1) for n, lab in zip(node, labels)]
        return node_point_sets(node, points, len(ids) - 1, voxel_size=voxel_size)

    gsets = sets(gt, gt_ids)
    psets = sets(pred, pred_ids)
    ptrees = {}
    rows = []
    iou_all = _iou_table(table)  # g_obj = 1..G and p_obj = 1..P: id 0 is always first
    for gi in g_obj:
        inter = table[gi, p_obj].astype(np.float64)
        ious = iou_all[gi - 1]
        row: dict[str, Any] = {"id": int(gt_ids[gi]), "pixels": int(gt_size[gi])}
        if names and int(gt_ids[gi]) in names:
            row["name"] = names[int(gt_ids[gi])]
        if p_obj.size and ious.max() > 0:
            k = int(np.argmax(ious))
            prec = inter[k] / pred_size[p_obj[k]]
            rec = inter[k] / gt_size[gi]
            row.update(iou=float(ious[k]), precision=float(prec), recall=float(rec), f1=f1_score(prec, rec), pred=int(pred_ids[p_obj[k]]))
        else:
            row.update(iou=0.0, precision=0.0, recall=0.0, f1=0.0, pred=None)
        gpts = gsets[int(gi) - 1]
        gtree = cKDTree(gpts) if len(gpts) else None
        best, best_k = float("inf"), None
        for k, pj in enumerate(p_obj):
            ppts = psets[int(pj) - 1]
            if gtree is None or len(ppts) == 0:
                continue
            if pj not in ptrees:
                ptrees[pj] = cKDTree(ppts)
            c = directed_chamfer(gpts, ptrees[pj]) + directed_chamfer(ppts, gtree)
            if c < best:
                best, best_k = c, k
        row["chamfer"] = best if best_k is not None else None
        row["iou_sel"] = float(ious[best_k]) if best_k is not None else 0.0
        row["pred_sel"] = int(pred_ids[p_obj[best_k]]) if best_k is not None else None
        rows.append(row)
    gt_obj_pixels = int(gt_size[g_obj].sum())
    assigned = int(table[np.ix_(g_obj, p_obj)].sum()) if g_obj.size and p_obj.size else 0
    mean: dict[str, Any] = {}
    for key in METRIC_KEYS:
        vals = [r[key] for r in rows if r.get(key) is not None]
        mean[key] = float(np.mean(vals)) if vals else None
    mean["pixel_utility"] = assigned / gt_obj_pixels if gt_obj_pixels else None
    pq = panoptic_quality(iou_all)
    mean.update(pq=pq["pq"], sq=pq["sq"], rq=pq["rq"])
    return {
        "objects": rows,
        "mean": mean,
        "num_gt": int(g_obj.size),
        "num_pred": int(p_obj.size),
        "panoptic": {k: pq[k] for k in ("tp", "fp", "fn")},
    }
