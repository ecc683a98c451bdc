"""Mask composition: overlapping / nested masks of one view -> one label image.

Rule (deterministic): masks whose background overlap is ``>= max_overlap`` are
dropped first. The rest are painted from the largest to the smallest area (ties:
lower index first), so a smaller mask is painted over a larger one and small
parts are kept rather than swallowed. Background pixels are then cleared, and a
mask left with fewer than ``min_area`` visible pixels is dropped.

The label image holds ``mask_id + 1`` (0 = no mask), ``mask_id`` being the
mask's index in the input list (or ``label - 1`` for a label-image input).

Examples
--------
>>> import numpy as np
>>> big = np.ones((3, 3), bool)
>>> small = np.zeros((3, 3), bool); small[1, 1] = True
>>> lab, info = compose_masks([big, small], max_overlap=0.09, min_area=1)
>>> lab.tolist()
[[1, 1, 1], [1, 2, 1], [1, 1, 1]]
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = ["compose_masks", "paint_masks", "majority_objects", "close_id_gaps", "rename_objects", "snap_to_masks"]


def compose_masks(
    masks: Sequence[np.ndarray] | np.ndarray,
    *,
    background: np.ndarray | None = None,
    max_overlap: float,
    min_area: int,
) -> tuple[np.ndarray, dict[str, Any]]:
    """Resolve one view's masks into a label image.

    Parameters
    ----------
    masks : list of bool ``[H, W]``, bool ``[K, H, W]``, or int label image ``[H, W]``
        Possibly overlapping masks (SAM style), or labels (0 = none, k = mask k - 1).
    background : bool ``[H, W]``, optional
        The background class.
    max_overlap : float
        Drop masks with ``|mask & background| / |mask| >= max_overlap``; a mask
        with no background pixel is never dropped (so ``max_overlap=0`` drops
        every mask that touches the background, not every mask).
    min_area : int
        Drop masks with fewer visible pixels after painting.

    Returns
    -------
    labels : int32 ``[H, W]``
        ``mask_id + 1`` per pixel, 0 = none / background.
    info : dict
        ``num_input``, ``dropped_background`` (mask ids), ``dropped_small``
        (mask ids), ``kept`` (mask ids).

    Notes
    -----
    O(K H W) for K boolean masks; O(H W) for a label image.
    """
    arr = masks if isinstance(masks, np.ndarray) else None
    fresh = True  # whether ``labels`` is a new array (not the caller's)
    bg_any = background is not None and bool(np.any(background))
    if arr is not None and arr.ndim == 2 and arr.dtype.kind in "iu":
        # bincount / indexing take int32 and int64 as they are; other int types are widened
        lab_in = arr if arr.dtype in (np.dtype(np.int32), np.dtype(np.int64)) else arr.astype(np.int64)
        fresh = lab_in is not arr
        if lab_in.min() < 0:
            raise ValueError(f"expected label image values >= 0 (got {int(lab_in.min())})")
        k = int(lab_in.max())
        area = np.bincount(lab_in.ravel(), minlength=k + 1)[1:]
        if bg_any:
            bg_hits = np.bincount(lab_in[background].ravel(), minlength=k + 1)[1:]
        else:
            bg_hits = np.zeros(k, np.int64)
        present = np.flatnonzero(area > 0)
        with np.errstate(invalid="ignore", divide="ignore"):
            frac = bg_hits / np.maximum(area, 1)
        hit = (frac[present] >= max_overlap) & (bg_hits[present] > 0)
        drop_bg = present[hit] if background is not None else np.zeros(0, np.int64)
        if drop_bg.size:
            lut = np.arange(k + 1, dtype=np.int32)
            lut[drop_bg + 1] = 0
            labels = lut[lab_in]
            fresh = True
        else:  # nothing dropped: the labels are the input's (copied once, at the end)
            labels = lab_in
            vis_known = area
        num_input = int(present.size)
        shape = lab_in.shape
    else:
        stack = [np.asarray(m, bool) for m in masks]
        if not stack:
            raise ValueError("compose_masks needs at least one mask or a label image; use an all-zero label image for none")
        shape = stack[0].shape
        for i, m in enumerate(stack):
            if m.shape != shape:
                raise ValueError(f"expected every mask of shape {list(shape)} (mask {i} is {list(m.shape)})")
        area = np.array([int(m.sum()) for m in stack])
        num_input = len(stack)
        drop = []
        if background is not None:
            for i, m in enumerate(stack):
                hits = int((m & background).sum())
                if hits and hits / area[i] >= max_overlap:
                    drop.append(i)
        drop_bg = np.array(drop, np.int64)
        dropped = set(drop)
        labels = np.zeros(shape, np.int32)
        order = sorted(range(num_input), key=lambda i: (-area[i], i))
        for i in order:
            if i not in dropped and area[i]:
                labels[stack[i]] = i + 1
    if bg_any and background is not None:  # an all-False background clears nothing
        labels = np.where(background, 0, labels).astype(np.int32)
        fresh = True
    if not fresh and labels.size:
        vis = vis_known  # labels untouched since the areas were counted
    else:
        vis = np.bincount(labels.ravel(), minlength=1)[1:]
    small = np.flatnonzero((vis > 0) & (vis < min_area))
    if small.size:
        lut = np.arange(vis.size + 1, dtype=np.int32)
        lut[small + 1] = 0
        labels = lut[labels]
        fresh = True
        kept = np.flatnonzero(np.bincount(labels.ravel(), minlength=1)[1:] > 0)
    else:
        kept = np.flatnonzero(vis > 0)
    info = {
        "num_input": num_input,
        "dropped_background": drop_bg.tolist(),
        "dropped_small": small.tolist(),
        "kept": kept.tolist(),
    }
    return labels.astype(np.int32, copy=not fresh), info  # never the caller's array


def paint_masks(masks: Sequence[np.ndarray], mask_view: np.ndarray, mask_id: np.ndarray, values: np.ndarray, *, dtype: Any = np.int64) -> list[np.ndarray]:
    """Label images in which every composed mask's pixels carry that mask's value.

    Parameters
    ----------
    masks : list of int ``[H, W]``
        Composed mask images, ``mask_id + 1`` (0 = none), as :func:`compose_masks` gives.
    mask_view, mask_id : int ``[M]``
        View and id of every mask.
    values : int ``[M]``
        The value to paint (an object id; 0 = none).
    dtype : numpy dtype, keyword-only

    Returns
    -------
    list of ``[H, W]``
        Per view; 0 where no mask lies.

    Notes
    -----
    O(total pixels): one lookup table per view.

    Examples
    --------
    >>> [m.tolist() for m in paint_masks([np.array([[0, 1, 2]])], np.array([0, 0]), np.array([0, 1]), np.array([7, 0]))]
    [[[0, 7, 0]]]
    """
    out = []
    view = np.asarray(mask_view)
    for v, lab in enumerate(masks):
        lab = np.asarray(lab)
        sel = view == v
        lut = np.zeros(int(lab.max(initial=0)) + 1, dtype)
        ids = np.asarray(mask_id)[sel] + 1
        keep = ids < lut.size
        lut[ids[keep]] = np.asarray(values)[sel][keep]
        out.append(lut[lab])
    return out


def majority_objects(masks: Sequence[np.ndarray], labels: Sequence[np.ndarray], mask_view: np.ndarray, mask_id: np.ndarray, values: np.ndarray) -> np.ndarray:
    """The object that holds most of each mask's pixels in relabelled images (the inverse of :func:`paint_masks`).

    Parameters
    ----------
    masks : list of int ``[H, W]``
        Composed mask images, ``mask_id + 1`` (0 = none).
    labels : list of int ``[H, W]``
        Object ids per view (0 = none), e.g. after a per-pixel split.
    mask_view, mask_id : int ``[M]``
        View and id of every mask.
    values : int ``[M]``
        Each mask's current object; kept where the mask has no labelled pixel,
        and where it is 0 (a mask below the minimum support stays dropped).

    Returns
    -------
    int64 ``[M]``
        A new array.

    Notes
    -----
    O(total pixels): one joint histogram per view.

    Examples
    --------
    >>> m = [np.array([[1, 1, 1, 2, 2]])]
    >>> lab = [np.array([[3, 3, 4, 4, 4]])]
    >>> majority_objects(m, lab, np.array([0, 0]), np.array([0, 1]), np.array([3, 0])).tolist()
    [3, 0]
    """
    out = np.asarray(values, np.int64).copy()
    view = np.asarray(mask_view)
    ids = np.asarray(mask_id)
    for v, (mk, lab) in enumerate(zip(masks, labels)):
        mk = np.asarray(mk).ravel().astype(np.int64)
        lab = np.asarray(lab).ravel().astype(np.int64)
        keep = (mk > 0) & (lab > 0)
        if not keep.any():
            continue
        cols = int(lab.max()) + 1
        hist = np.bincount(mk[keep] * cols + lab[keep], minlength=(int(mk.max()) + 1) * cols).reshape(-1, cols)
        sel = np.flatnonzero((view == v) & (out > 0) & (ids + 1 < hist.shape[0]))
        rows = hist[ids[sel] + 1]
        has = rows.sum(1) > 0
        out[sel[has]] = rows[has].argmax(1)
    return out


def close_id_gaps(representative: np.ndarray, freed: np.ndarray) -> np.ndarray:
    """Consecutive ids after some objects were joined into others or emptied.

    Parameters
    ----------
    representative : int ``[T + 1]``
        The old id each old id now belongs to (``representative[0] == 0``;
        never a freed id).
    freed : bool ``[T + 1]``
        The old ids no longer in use.

    Returns
    -------
    int64 ``[T + 1]``
        The new id of every old id: the ids above a freed one move down.

    Notes
    -----
    O(T).

    Examples
    --------
    >>> close_id_gaps(np.array([0, 1, 1, 3]), np.array([False, False, True, False])).tolist()
    [0, 1, 1, 2]
    """
    rep = np.asarray(representative, np.int64)
    return rep - np.cumsum(np.asarray(freed, np.int64))[rep]


def rename_objects(labels: Sequence[np.ndarray], mapping: np.ndarray | None) -> list[np.ndarray]:
    """Object ids per view renamed by a lookup table; labels <= 0 are kept.

    Parameters
    ----------
    labels : list of int ``[H, W]``
        Object ids per view (<= 0 = none).
    mapping : int ``[T + 1]`` or None
        The new id of every old id ``0..T`` (labels above ``T`` take
        ``mapping[T]``); None copies the labels.

    Returns
    -------
    list of int ``[H, W]``
        New arrays of the input dtypes (the inputs are not modified).

    Notes
    -----
    O(total pixels).

    Examples
    --------
    >>> rename_objects([np.array([[0, 1, 2, 3, -1]], np.int32)], np.array([0, 1, 1, 2]))[0].tolist()
    [[0, 1, 1, 2, -1]]
    """
    if mapping is None:
        return [np.array(lab, copy=True) for lab in labels]
    table = np.asarray(mapping)
    top = table.size - 1
    return [np.where(lab > 0, table[np.clip(lab, 0, top).astype(np.int64)], lab).astype(lab.dtype) for lab in map(np.asarray, labels)]


def snap_to_masks(
    labels: Sequence[np.ndarray],
    masks: Sequence[np.ndarray],
    min_share: float,
    *,
    points: Sequence[np.ndarray] | None = None,
    voxel_size: float = 0.006,
    num_objects: int | None = None,
) -> tuple[list[np.ndarray], dict[str, Any]]:
    """Give the pixels a mask's main object lacks to that object, where the other views agree.

    After a per-pixel step (the 3D split) the border between two objects
    follows voxels, so it can cut a few pixels off a mask that lies almost
    wholly in one object. In a mask with at least ``min_share`` of its
    labelled pixels in one object (its main object), the pixels of other
    objects are relabelled to the main object; a mask split more evenly (one
    that straddles two touching objects) keeps its per-pixel labels.

    With ``points``, a pixel moves only where the other views agree: every
    labelled pixel of every view votes for the main object of its mask (the
    lower id on a tie), at its point's voxel, and a pixel moves when, in its voxel, the other views'
    votes for its mask's main object outnumber their votes for its own
    object. A mask that straddles two objects in this view (a superpixel over
    an object border, 85 / 15) keeps the cut when the other views' masks
    put the minority part in its own object; a mask that the voxel border
    cut (the other views' masks of the same surface vote for its main
    object) is given back. A pixel without a point, or whose voxel no other
    view sees, keeps its label.

    An object left without pixels frees its id, and the ids above it move
    down; its old id maps to the object that took most of its pixels (so a
    mask still pointing at it follows them).

    Parameters
    ----------
    labels : list of int ``[H, W]``
        Object ids per view (<= 0 = none; unlabelled pixels stay unlabelled).
    masks : list of int ``[H, W]``
        Composed mask images, ``mask_id + 1`` (0 = none).
    min_share : float
        Share of a mask's labelled pixels its main object must hold (in
        ``(0.5, 1]``; ``inf``: never snap).
    points : list of float ``[H, W, 3]``, optional, keyword-only
        World points per view (NaN = none): the other views' votes decide
        (None: every pixel of such a mask moves).
    voxel_size : float, default 0.006, keyword-only
        Edge of the voxels the votes are counted in (same unit as the points;
        a voxel is ``floor(point / voxel_size)``, the grid of the 3D split).
    num_objects : int, optional, keyword-only
        The largest object id in use (default: the largest in ``labels``).

    Returns
    -------
    labels : list of int ``[H, W]``
        New arrays of the input dtypes (the inputs are not modified).
    info : dict
        ``pixels``: pixels relabelled over all views; ``masks``: masks with a
        relabelled pixel; ``mapping``: int64 ``[T + 1]``, the new id of every
        old id, a freed one's being the new id of the object that took most of
        its pixels (None when no id was freed); ``num_objects``: the largest id now.

    Notes
    -----
    O(P log P) for P labelled pixels: the (mask, object) pairs of each view are
    counted by :func:`graphseg.graphs.pair_counts` (a dense count only when the
    ids are few, else one sort), so memory grows with the pixels, not with the ids;
    with ``points``, one voxel key per labelled pixel and a binary search
    among the voxels of the pixels that could move.

    Examples
    --------
    >>> m = [np.array([[1, 1, 1, 1, 1, 2, 2, 2, 2, 2]])]
    >>> lab = [np.array([[3, 3, 3, 3, 1, 1, 1, 3, 3, 0]])]   # mask 1: 4 of 5 in object 3; mask 2: 2 of 4 in 1
    >>> out, info = snap_to_masks(lab, m, 0.8)
    >>> out[0].tolist(), info["pixels"], info["mapping"]
    ([[3, 3, 3, 3, 3, 1, 1, 3, 3, 0]], 1, None)

    Two views of one row of points. View 0's mask holds 4 of 5 pixels in
    object 1; view 1's mask puts point 4 in object 1 too, so it moves (and
    object 2, left empty, frees its id):

    >>> pts = [np.arange(5.0).repeat(3).reshape(1, 5, 3)] * 2
    >>> lab = [np.array([[1, 1, 1, 1, 2]]), np.array([[1, 1, 1, 1, 1]])]
    >>> m = [np.array([[1, 1, 1, 1, 1]]), np.array([[1, 1, 1, 1, 1]])]
    >>> out, info = snap_to_masks(lab, m, 0.8, points=pts, voxel_size=0.5)
    >>> out[0].tolist(), info["mapping"].tolist()
    ([[1, 1, 1, 1, 1]], [0, 1, 1])

    When view 1's masks put point 4 in object 2, view 0's cut stands:

    >>> lab[1], m[1] = np.array([[1, 1, 1, 2, 2]]), np.array([[1, 1, 1, 2, 2]])
    >>> snap_to_masks(lab, m, 0.8, points=pts, voxel_size=0.5)[0][0].tolist()
    [[1, 1, 1, 1, 2]]
    """
    if not min_share > 0.5:
        raise ValueError(f"expected min_share > 0.5, so that one object holds the share (got {min_share})")
    if len(masks) != len(labels):
        raise ValueError(f"expected masks for the {len(labels)} views (got {len(masks)})")
    if points is not None and len(points) != len(labels):
        raise ValueError(f"expected points for the {len(labels)} views (got {len(points)})")
    if not voxel_size > 0:
        raise ValueError(f"expected voxel_size > 0 (got {voxel_size})")
    from ..graphs import pair_counts

    out = [np.array(lab, copy=True) for lab in labels]
    top = max(int(max((int(np.max(lab)) for lab in out if lab.size), default=0)), int(num_objects or 0))
    cols = top + 1
    size = np.zeros(cols, np.int64)  # pixels of each object before the snap
    moves: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []  # per view: pixels that may move, their masks, objects and targets
    voters: list[tuple[np.ndarray, np.ndarray]] = []  # per view: labelled pixels, the main object of their mask
    for v, (lab, mk) in enumerate(zip(out, masks)):
        mk = np.asarray(mk)
        if mk.shape != lab.shape:
            raise ValueError(f"expected masks of shape {list(lab.shape)} (got {list(mk.shape)})")
        if points is not None and np.shape(points[v]) != (*lab.shape, 3):
            raise ValueError(f"expected points of shape {[*lab.shape, 3]} (got {list(np.shape(points[v]))})")
        ob = np.clip(lab, 0, None).ravel().astype(np.int64)
        size += np.bincount(ob, minlength=cols)
        m = mk.ravel().astype(np.int64)
        keep = (m > 0) & (ob > 0)
        none = np.zeros(0, np.int64)
        if not keep.any() or not np.isfinite(min_share):
            moves.append((none, none, none, none))
            voters.append((none, none))
            continue
        mask_of, obj_of, n = pair_counts(m[keep], ob[keep], max(int(m.max()) + 1, cols))  # (mask, object) pairs, sorted
        total = np.bincount(mask_of, weights=n, minlength=int(m.max()) + 1)
        owner, owned = _largest_per_group(mask_of, obj_of, n)  # each mask's main object (ties: the lower id)
        best = np.zeros(total.size, np.int64)
        most = np.zeros(total.size, np.int64)
        best[owner], most[owner] = obj_of[owned], n[owned]
        snap = (total > 0) & (most >= min_share * total) & (most < total)
        idx = np.flatnonzero(keep & snap[m] & (ob != best[m]))
        moves.append((idx, m[idx], ob[idx], best[m[idx]]))
        if points is not None:
            vote = np.flatnonzero(keep)
            voters.append((vote, best[m[vote]]))
        else:
            voters.append((none, none))
    if points is not None and any(mv[0].size for mv in moves):
        moves = _agreed_moves(moves, voters, points, voxel_size, cols)
    pixels = changed = 0
    for lab, (idx, mask_id, _, target) in zip(out, moves):
        lab.reshape(-1)[idx] = target.astype(lab.dtype)
        pixels += idx.size
        changed += np.unique(mask_id).size
    src = np.concatenate([mv[2] for mv in moves]) if moves else np.zeros(0, np.int64)  # the old and new object of every moved pixel
    dst = np.concatenate([mv[3] for mv in moves]) if moves else np.zeros(0, np.int64)
    left = size - np.bincount(src, minlength=cols) + np.bincount(dst, minlength=cols)
    gone = (size > 0) & (left == 0)  # only ids this step emptied; an unused id stays as it was
    gone[0] = False
    mapping = None
    if gone.any():
        old_of, new_of, n = pair_counts(src, dst, cols)
        emptied, took = _largest_per_group(old_of, new_of, n)  # per old object: the new one that took most of its pixels (ties: the lower id)
        representative = np.arange(cols)
        take = gone[emptied]
        representative[emptied[take]] = new_of[took[take]]  # never an emptied id: those hold no pixels now
        mapping = close_id_gaps(representative, gone)
        out = rename_objects(out, mapping)
    num = top if mapping is None else int(mapping.max(initial=0))
    return out, {"pixels": pixels, "masks": changed, "mapping": mapping, "num_objects": num}


def _largest_per_group(group: np.ndarray, item: np.ndarray, count: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each group and the index of its row of largest ``count`` (ties: the lower ``item``)."""
    order = np.lexsort((item, -count, group))
    head = order[np.r_[True, group[order][1:] != group[order][:-1]]] if order.size else order
    return group[head], head


def _agreed_moves(
    moves: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]],
    voters: list[tuple[np.ndarray, np.ndarray]],
    points: Sequence[np.ndarray],
    voxel_size: float,
    cols: int,
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """The moves of :func:`snap_to_masks` that the other views' votes at the same voxel support."""
    from ..graphs import combine_keys

    def cells(view: int, idx: np.ndarray) -> np.ndarray:  # voxel coordinates of some pixels of a view (NaN rows: no point)
        return np.floor(np.asarray(points[view]).reshape(-1, 3)[idx].astype(np.float64) / voxel_size)

    empty = [(i[:0], m[:0], c[:0], t[:0]) for i, m, c, t in moves]  # no move agreed
    cand_cells = [cells(v, mv[0]) for v, mv in enumerate(moves)]
    vote_cells = [cells(v, idx) for v, (idx, _) in enumerate(voters)]
    usable = 2.0**52  # voxel coordinates beyond this do not survive the cast to int64: such a pixel has no point
    finite = [(np.abs(c) < usable).all(1) for c in cand_cells]  # NaN compares False
    seen = [(np.abs(c) < usable).all(1) for c in vote_cells]
    parts = [c[f] for c, f in zip(cand_cells, finite)] + [c[f] for c, f in zip(vote_cells, seen)]
    everything = np.concatenate(parts).astype(np.int64)
    if not everything.size:
        return empty
    low = everything.min(0)
    every_key = combine_keys(list((everything - low).T), (everything.max(0) - low + 1).tolist())  # one call: keys agree across views
    split_at = np.cumsum([len(c) for c in parts])[:-1]
    all_keys = np.split(every_key, split_at)
    cand_keys, vote_keys = all_keys[: len(cand_cells)], all_keys[len(cand_cells) :]
    voxels = np.unique(np.concatenate(cand_keys))  # the voxels where a pixel could move
    if not voxels.size:  # no pixel that could move has a point
        return empty
    votes = []  # per view: (voxel, object) keys of its votes in those voxels, sorted, and their counts
    for k, f, (_, vote) in zip(vote_keys, seen, voters):
        pos = np.minimum(np.searchsorted(voxels, k), voxels.size - 1)
        hit = voxels[pos] == k
        votes.append(np.unique(pos[hit] * cols + vote[f][hit], return_counts=True))
    every = np.concatenate([k for k, _ in votes])
    weight = np.concatenate([n for _, n in votes])
    total_keys, inverse = np.unique(every, return_inverse=True)
    total = np.bincount(inverse, weights=weight).astype(np.int64)

    def count(query: np.ndarray, table: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
        k, n = table
        if not k.size:
            return np.zeros(query.size, np.int64)
        i = np.minimum(np.searchsorted(k, query), k.size - 1)
        return np.where(k[i] == query, n[i], 0)

    agreed = []
    for mv, f, k, own in zip(moves, finite, cand_keys, votes):
        idx, mask_id, current, target = (a[f] for a in mv)
        at = np.searchsorted(voxels, k) * cols
        want, have = at + target, at + current
        go = count(want, (total_keys, total)) - count(want, own) > count(have, (total_keys, total)) - count(have, own)
        agreed.append((idx[go], mask_id[go], current[go], target[go]))
    return agreed
