"""Automatic mask generation from a promptable segmenter (SAM's "segment everything").

The algorithm of SAM's automatic mask generator, written for any model: a
regular grid of foreground point prompts is decoded in batches; each prompt
gives ``K`` candidate masks with a predicted IoU; candidates are kept when the
predicted IoU and the *stability score* (IoU of the mask thresholded at
``mask_threshold +- offset``) are high; duplicates are removed by box
non-maximum suppression; optional crop layers repeat this on zoomed crops; and
optional cleanup fills small holes and removes small islands.

The model enters only through a callable

``predict(points [B, 2] float (x, y) pixels, labels [B] int) -> (logits [B, K, h, w], iou [B, K])``

set on one image (or crop). Logits may come at any resolution ``h x w``; only
candidates that pass the IoU filter are resized (bilinear, half-pixel centres)
to the image size. So the same code runs SAM 2 in torch, an ONNX export, or a
fake predictor in tests.

Boxes are half-open pixel boxes ``[x0, y0, x1, y1)``: a mask covering columns
2..4 has ``x0 = 2, x1 = 5`` and width 3. SAM's generator measures its boxes by
their last pixel instead (``x1 = 4``, area ``(x1 - x0) (y1 - y0)``) in box NMS
and in the crop-edge test, so those two steps use that form internally (the
same masks survive as in SAM; the returned boxes stay half-open).

Examples
--------
>>> import numpy as np
>>> def predict(points, labels):  # one square around every prompt
...     yy, xx = np.mgrid[0:32, 0:32]
...     m = [(abs(xx - x) < 6) & (abs(yy - y) < 6) for x, y in points]
...     logits = np.where(np.array(m), 10.0, -10.0)[:, None]
...     return logits, np.ones((len(points), 1))
>>> masks = generate_masks(predict, (32, 32), AutomaskOptions(points_per_side=2)).masks
>>> masks.shape, int(masks[0].sum())
((4, 32, 32), 121)
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

__all__ = [
    "Proposals",
    "point_grid",
    "stability_score",
    "masks_to_boxes",
    "box_iou",
    "box_nms",
    "remove_small_regions",
    "crop_boxes",
    "generate_masks",
    "AutomaskOptions",
]

Predict = Callable[[np.ndarray, np.ndarray], tuple[Any, Any]]


class Proposals(NamedTuple):
    """Masks kept by :func:`generate_masks`, best predicted IoU first.

    ``masks`` bool ``[N, H, W]``, ``iou`` float ``[N]`` (predicted), ``stability``
    float ``[N]``, ``boxes`` int64 ``[N, 4]`` half-open, ``points`` float ``[N, 2]``
    (the prompt that produced each mask, image pixels).
    """

    masks: np.ndarray
    iou: np.ndarray
    stability: np.ndarray
    boxes: np.ndarray
    points: np.ndarray

    def take(self, idx: np.ndarray) -> Proposals:
        """The proposals at ``idx`` (an index or boolean array)."""
        return Proposals(*(a[idx] for a in self))


def _empty(h: int, w: int) -> Proposals:
    return Proposals(np.zeros((0, h, w), bool), np.zeros(0, np.float32), np.zeros(0, np.float32), np.zeros((0, 4), np.int64), np.zeros((0, 2), np.float32))


def _concat(parts: list[Proposals], h: int, w: int) -> Proposals:
    if not parts:
        return _empty(h, w)
    return Proposals(*(np.concatenate(cols) for cols in zip(*parts)))


def point_grid(n_per_side: int) -> np.ndarray:
    """A regular ``n x n`` grid of points in the unit square, cell centres (SAM's ``build_point_grid``).

    Returns
    -------
    float64 ``[n * n, 2]``
        ``(x, y)`` in ``(0, 1)``, x varying fastest.

    Examples
    --------
    >>> point_grid(2)
    array([[0.25, 0.25],
           [0.75, 0.25],
           [0.25, 0.75],
           [0.75, 0.75]])
    """
    if n_per_side < 1:
        raise ValueError(f"expected n_per_side >= 1 (got {n_per_side})")
    offset = 1.0 / (2 * n_per_side)
    side = np.linspace(offset, 1 - offset, n_per_side)
    xs, ys = np.meshgrid(side, side)
    return np.stack([xs.ravel(), ys.ravel()], 1)


def stability_score(logits: np.ndarray, mask_threshold: float = 0.0, offset: float = 1.0) -> np.ndarray:
    """IoU between the masks thresholded at ``mask_threshold + offset`` and ``mask_threshold - offset``.

    Parameters
    ----------
    logits : float ``[..., H, W]``
    mask_threshold, offset : float

    Returns
    -------
    float32 ``[...]``
        In ``[0, 1]``; 0 where both masks are empty. O(H W) per mask.

    Examples
    --------
    >>> stability_score(np.array([[3.0, 0.5, -0.5, -3.0]]))  # 1 pixel > 1, 3 pixels > -1
    array(0.33333334, dtype=float32)
    """
    logits = np.asarray(logits)
    inter = (logits > mask_threshold + offset).sum((-1, -2))
    union = (logits > mask_threshold - offset).sum((-1, -2))
    with np.errstate(invalid="ignore", divide="ignore"):
        score = np.where(union > 0, inter / np.maximum(union, 1), 0.0)
    return score.astype(np.float32)


def masks_to_boxes(masks: np.ndarray) -> np.ndarray:
    """Half-open bounding boxes ``[x0, y0, x1, y1)`` of boolean masks; ``[0, 0, 0, 0]`` for empty masks.

    Parameters
    ----------
    masks : bool ``[N, H, W]``

    Returns
    -------
    int64 ``[N, 4]``

    Examples
    --------
    >>> m = np.zeros((2, 4, 5), bool); m[0, 1:3, 2:5] = True
    >>> masks_to_boxes(m)
    array([[2, 1, 5, 3],
           [0, 0, 0, 0]])
    """
    masks = np.asarray(masks, dtype=bool)
    if masks.ndim != 3:
        raise ValueError(f"expected masks of shape [N, H, W] (got {list(masks.shape)})")
    n, h, w = masks.shape
    cols: np.ndarray = np.any(masks, axis=1)
    rows: np.ndarray = np.any(masks, axis=2)
    boxes = np.zeros((n, 4), np.int64)
    has: np.ndarray = np.any(cols, axis=1)
    boxes[has, 0] = cols[has].argmax(1)
    boxes[has, 2] = w - cols[has][:, ::-1].argmax(1)
    boxes[has, 1] = rows[has].argmax(1)
    boxes[has, 3] = h - rows[has][:, ::-1].argmax(1)
    return boxes


def box_iou(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Pairwise IoU of half-open boxes ``a [N, 4]`` and ``b [M, 4]`` -> ``[N, M]`` (0 where both are empty).

    Examples
    --------
    >>> box_iou(np.array([[0, 0, 2, 2]]), np.array([[1, 0, 3, 2], [5, 5, 6, 6]]))
    array([[0.33333333, 0.        ]])
    """
    a = np.asarray(a, np.float64).reshape(-1, 4)
    b = np.asarray(b, np.float64).reshape(-1, 4)
    area_a = (a[:, 2] - a[:, 0]) * (a[:, 3] - a[:, 1])
    area_b = (b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1])
    lt = np.maximum(a[:, None, :2], b[None, :, :2])
    rb = np.minimum(a[:, None, 2:], b[None, :, 2:])
    wh = np.clip(rb - lt, 0, None)
    inter = wh[..., 0] * wh[..., 1]
    union = area_a[:, None] + area_b[None] - inter
    return np.where(union > 0, inter / np.where(union > 0, union, 1), 0.0)


def box_nms(boxes: np.ndarray, scores: np.ndarray, iou_threshold: float) -> np.ndarray:
    """Greedy non-maximum suppression: indices kept, highest score first.

    A box is dropped when its IoU with an already kept, higher-scored box is
    greater than ``iou_threshold`` (as ``torchvision.ops.nms``). Ties keep the
    lower index first. O(N^2) time, O(N) memory per step.

    Examples
    --------
    >>> b = np.array([[0, 0, 10, 10], [1, 0, 11, 10], [20, 20, 30, 30]])
    >>> box_nms(b, np.array([0.5, 0.9, 0.1]), 0.7)
    array([1, 2])
    """
    boxes = np.asarray(boxes).reshape(-1, 4)
    scores = np.asarray(scores, np.float64).ravel()
    if len(boxes) != len(scores):
        raise ValueError(f"expected one score per box (got {len(scores)} scores for {len(boxes)} boxes)")
    order = np.argsort(-scores, kind="stable")
    keep: list[int] = []
    while order.size:
        i = int(order[0])
        keep.append(i)
        rest = order[1:]
        if rest.size == 0:
            break
        order = rest[box_iou(boxes[i : i + 1], boxes[rest])[0] <= iou_threshold]
    return np.array(keep, np.int64)


def remove_small_regions(mask: np.ndarray, min_area: int, mode: str) -> tuple[np.ndarray, bool]:
    """Fill small holes (``mode="holes"``) or remove small islands (``mode="islands"``).

    Regions are 8-connected components (OpenCV). In ``"islands"`` mode the
    largest island is kept when all are small.

    Returns
    -------
    (bool ``[H, W]``, bool)
        The new mask (the input is not changed) and whether anything changed.

    Examples
    --------
    >>> m = np.zeros((5, 6), bool); m[:, :3] = True; m[2, 1] = False; m[0, 5] = True
    >>> filled, changed = remove_small_regions(m, 2, "holes")
    >>> bool(filled[2, 1]), changed
    (True, True)
    >>> cleaned, _ = remove_small_regions(m, 2, "islands")
    >>> bool(cleaned[0, 5]), int(cleaned.sum())
    (False, 14)
    """
    import cv2

    if mode not in ("holes", "islands"):
        raise ValueError(f"unknown mode {mode!r}; choose 'holes' or 'islands'")
    mask = np.asarray(mask, bool)
    correct_holes = mode == "holes"
    working = (correct_holes ^ mask).astype(np.uint8)
    _, regions, stats, _ = cv2.connectedComponentsWithStats(working, connectivity=8)
    sizes = stats[1:, cv2.CC_STAT_AREA]
    small = np.flatnonzero(sizes < min_area) + 1
    if not small.size:
        return mask.copy(), False
    if correct_holes:
        out = mask | np.isin(regions, small)
    else:
        keep = np.flatnonzero(sizes >= min_area) + 1
        out = np.isin(regions, keep if keep.size else [int(np.argmax(sizes)) + 1])
    return out, True


def crop_boxes(shape: tuple[int, int], n_layers: int, overlap_ratio: float = 512 / 1500) -> tuple[np.ndarray, np.ndarray]:
    """SAM's crop pyramid: the full image, then ``2^i x 2^i`` overlapping crops on layer ``i``.

    Returns
    -------
    boxes : int64 ``[C, 4]``
        Half-open ``[x0, y0, x1, y1)``; the first is the full image.
    layers : int64 ``[C]``

    Examples
    --------
    >>> b, l = crop_boxes((100, 200), 1)
    >>> b[0].tolist(), len(b), l.tolist()
    ([0, 0, 200, 100], 5, [0, 1, 1, 1, 1])
    """
    h, w = shape
    boxes = [[0, 0, w, h]]
    layers = [0]
    short = min(h, w)
    for layer in range(1, n_layers + 1):
        per_side = 2**layer
        overlap = int(overlap_ratio * short * (2 / per_side))
        cw = int(np.ceil((overlap * (per_side - 1) + w) / per_side))
        ch = int(np.ceil((overlap * (per_side - 1) + h) / per_side))
        for y0 in [int((ch - overlap) * i) for i in range(per_side)]:
            for x0 in [int((cw - overlap) * i) for i in range(per_side)]:
                boxes.append([x0, y0, min(x0 + cw, w), min(y0 + ch, h)])
                layers.append(layer)
    return np.array(boxes, np.int64), np.array(layers, np.int64)


def _sam_boxes(boxes: np.ndarray) -> np.ndarray:
    """Half-open boxes as SAM's generator compares them: ``[x0, y0, x_last, y_last]``; empty boxes stay ``[0, 0, 0, 0]``."""
    out = np.array(boxes, np.int64).reshape(-1, 4)
    out[out[:, 2] > out[:, 0], 2:] -= 1
    return out


def _resize_logits(logits: np.ndarray, h: int, w: int) -> np.ndarray:
    import cv2

    if logits.shape[-2:] == (h, w):
        return logits.astype(np.float32, copy=False)
    out = np.empty((len(logits), h, w), np.float32)
    for i, lg in enumerate(logits):
        out[i] = cv2.resize(np.ascontiguousarray(lg, np.float32), (w, h), interpolation=cv2.INTER_LINEAR)
    return out


def _crop_proposals(
    predict: Predict,
    crop: np.ndarray,
    image_hw: tuple[int, int],
    points: np.ndarray,
    options: AutomaskOptions,
    *,
    edge_tolerance: float = 20.0,
) -> Proposals:
    """Proposals of one crop, in full-image coordinates, after NMS within the crop."""
    points_per_batch, pred_iou_thresh, mask_threshold = options.points_per_batch, options.pred_iou_thresh, options.mask_threshold
    stability_score_thresh, stability_score_offset, box_nms_thresh = options.stability_score_thresh, options.stability_score_offset, options.box_nms_thresh
    x0, y0, x1, y1 = (int(v) for v in crop)
    h, w = y1 - y0, x1 - x0
    H, W = image_hw
    parts: list[Proposals] = []
    for start in range(0, len(points), points_per_batch):
        pts = points[start : start + points_per_batch].astype(np.float32)
        logits, iou = predict(pts, np.ones(len(pts), np.int64))
        logits = np.asarray(logits, np.float32)
        iou = np.asarray(iou, np.float32)
        if logits.ndim != 4 or iou.shape != logits.shape[:2] or len(iou) != len(pts):
            raise ValueError(f"predict must return logits [B, K, h, w] and iou [B, K] for B={len(pts)} (got {list(logits.shape)} and {list(iou.shape)})")
        k = logits.shape[1]
        logits = logits.reshape(-1, *logits.shape[2:])
        iou = iou.ravel()
        src = np.repeat(pts, k, axis=0)
        ok = iou > pred_iou_thresh
        if not ok.any():
            continue
        full = _resize_logits(logits[ok], h, w)
        iou, src = iou[ok], src[ok]
        stab = stability_score(full, mask_threshold, stability_score_offset)
        ok = stab >= stability_score_thresh
        masks = full[ok] > mask_threshold
        iou, stab, src = iou[ok], stab[ok], src[ok]
        boxes = masks_to_boxes(masks)
        ok = boxes[:, 2] > boxes[:, 0]
        boxes = boxes + np.array([x0, y0, x0, y0])
        if (x0, y0, x1, y1) != (0, 0, W, H):
            last = _sam_boxes(boxes)  # SAM tests the last pixel against the crop end
            near_crop = np.isclose(last, [x0, y0, x1, y1], atol=edge_tolerance, rtol=0)
            near_image = np.isclose(last, [0, 0, W, H], atol=edge_tolerance, rtol=0)
            ok &= ~(near_crop & ~near_image).any(1)
        if not ok.any():
            continue
        # candidates wait for NMS bit-packed (8x less memory than bool)
        parts.append(Proposals(np.packbits(masks[ok], axis=-1), iou[ok], stab[ok], boxes[ok], src[ok] + np.array([x0, y0], np.float32)))
    if not parts:
        props = _empty(h, w)
    else:
        packed = _concat(parts, h, (w + 7) // 8)
        packed = packed.take(box_nms(_sam_boxes(packed.boxes), packed.iou, box_nms_thresh))
        props = packed._replace(masks=np.unpackbits(packed.masks, axis=-1, count=w).astype(bool))
    if (h, w) != (H, W):
        full_masks = np.zeros((len(props.masks), H, W), bool)
        full_masks[:, y0:y1, x0:x1] = props.masks
        props = props._replace(masks=full_masks)
    return props


class AutomaskOptions(BaseModel):
    """The automatic mask generator's settings (see :func:`generate_masks`).

    Defaults are those of SAM 2's ``SAM2AutomaticMaskGenerator`` (predicted-IoU
    threshold 0.8; SAM 1 used 0.88).
    """

    model_config = ConfigDict(extra="forbid")
    points_per_side: int = Field(32, ge=1)
    points_per_batch: int = Field(64, ge=1)
    pred_iou_thresh: float = 0.8
    stability_score_thresh: float = Field(0.95, ge=0, le=1)
    stability_score_offset: float = 1.0
    mask_threshold: float = 0.0
    box_nms_thresh: float = Field(0.7, ge=0, le=1)
    min_mask_region_area: int = Field(0, ge=0)
    crop_n_layers: int = Field(0, ge=0)
    crop_nms_thresh: float = Field(0.7, ge=0, le=1)
    crop_overlap_ratio: float = Field(512 / 1500, ge=0, lt=1)
    crop_n_points_downscale_factor: int = Field(1, ge=1)

    def generator_kwargs(self) -> dict[str, Any]:
        """The generator's fields only (a segmenter's Options adds its own)."""
        return {k: getattr(self, k) for k in AutomaskOptions.model_fields}


def generate_masks(
    predict: Predict,
    shape: tuple[int, int],
    options: AutomaskOptions | None = None,
    *,
    predict_crop: Callable[[np.ndarray], Predict] | None = None,
) -> Proposals:
    """Segment everything: grid prompts -> filtered, de-duplicated masks.

    Parameters
    ----------
    predict : callable
        ``predict(points [B, 2], labels [B]) -> (logits [B, K, h, w], iou [B, K])``
        for the whole image; points are ``(x, y)`` pixels, labels are 1.
    shape : (H, W)
        Image size; masks are returned at this size.
    options : AutomaskOptions, optional
        The generator's settings (None: :class:`AutomaskOptions`' defaults, SAM 2's). Its fields:

    points_per_side : int
        Grid of ``points_per_side^2`` prompts (SAM default 32).
    points_per_batch : int
        Prompts decoded together (memory ~ ``points_per_batch * K * h * w``).
    pred_iou_thresh : float
        Keep candidates with predicted IoU ``>`` this (SAM: 0.88, SAM 2: 0.8).
    stability_score_thresh, stability_score_offset : float
        Keep candidates with :func:`stability_score` ``>=`` the threshold.
    mask_threshold : float
        Logit threshold of a mask.
    box_nms_thresh : float
        Box IoU above which the candidate with the lower predicted IoU is dropped.
    min_mask_region_area : int
        If > 0, fill holes and remove islands smaller than this (pixels), then
        run NMS again preferring unchanged masks (as SAM does).
    crop_n_layers, crop_nms_thresh, crop_overlap_ratio, crop_n_points_downscale_factor
        SAM's crop layers (0 = full image only). Layer ``i`` uses
        ``points_per_side / factor^i`` points per side; masks touching a crop
        edge that is not an image edge are dropped; duplicates across crops are
        removed preferring smaller crops.
    predict_crop : callable, optional
        ``predict_crop(box [4]) -> predict`` for a crop ``[x0, y0, x1, y1)``; needed
        when ``crop_n_layers > 0``. Points passed to it are crop pixels.

    Returns
    -------
    Proposals
        Sorted by predicted IoU, best first.

    Notes
    -----
    Cost: ``points_per_side^2 / points_per_batch`` decoder calls; resizing and
    stability scoring O(H W) per candidate that passes the IoU filter; NMS O(N^2)
    in the candidates kept. Candidates are held bit-packed until NMS
    (``H W / 8`` bytes each).
    """
    o = options if options is not None else AutomaskOptions()
    H, W = (int(s) for s in shape)
    crop_n_layers, crop_overlap_ratio, min_mask_region_area, box_nms_thresh = o.crop_n_layers, o.crop_overlap_ratio, o.min_mask_region_area, o.box_nms_thresh
    if crop_n_layers > 0 and predict_crop is None:
        raise ValueError("crop_n_layers > 0 needs predict_crop (a function box -> predict for that crop)")
    boxes, layers = crop_boxes((H, W), crop_n_layers, crop_overlap_ratio)
    parts = []
    for box, layer in zip(boxes, layers):
        n = max(1, int(o.points_per_side / o.crop_n_points_downscale_factor**layer))
        cw, ch = box[2] - box[0], box[3] - box[1]
        pts = point_grid(n) * np.array([cw, ch])
        pred = predict if layer == 0 else predict_crop(box)  # type: ignore[misc]
        parts.append(
            _crop_proposals(pred, box, (H, W), pts, o)
        )
    props = _concat(parts, H, W)
    if len(boxes) > 1:
        crop_of = np.concatenate([np.full(len(p.iou), i) for i, p in enumerate(parts)]).astype(np.int64)
        area = ((boxes[:, 2] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 1])).astype(np.float64)
        props = props.take(box_nms(_sam_boxes(props.boxes), 1.0 / area[crop_of], o.crop_nms_thresh))
    if min_mask_region_area > 0 and len(props.masks):
        new_masks = np.empty_like(props.masks)
        unchanged = np.empty(len(props.masks), np.float64)
        for i, m in enumerate(props.masks):
            m, c1 = remove_small_regions(m, min_mask_region_area, "holes")
            m, c2 = remove_small_regions(m, min_mask_region_area, "islands")
            new_masks[i] = m
            unchanged[i] = not (c1 or c2)
        new_boxes = masks_to_boxes(new_masks)
        props = props._replace(masks=new_masks, boxes=new_boxes)
        props = props.take(box_nms(_sam_boxes(new_boxes), unchanged, box_nms_thresh))
        props = props.take(np.asarray(props.masks.any(axis=(1, 2))))
    return props.take(np.argsort(-props.iou, kind="stable"))
