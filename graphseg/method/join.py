"""Join the pieces of one object that share most of their image border, continuous in depth.

Objects are pieces of one body when, in the views that see them, the border
between them is long against their own outline and the surface runs on across
it: the stripes of a striped box that the colour segmenter parted, a label
and the can it is printed on, a fragment beside its object. Two touching
objects also share a border without a depth step, but only along their contact
line: a short share of the smaller one's outline. :func:`border_contact`
counts, over all views, the 4-neighbour pixel pairs that join two objects
with no depth step between their points (``depth_abs + depth_rel * distance``
to the camera, the geometric segmenter's cut rule), and every object's outline;
:func:`join_objects` joins each object to the object with a longer outline
whose contact is the largest share of its own outline, when that share is at
least ``min_shared``: a piece joins one object, so a fragment never bridges two
objects larger than itself (smaller pieces may still join it first).
It is an image-space complement to
:func:`graphseg.method.split.merge_objects`, which needs a few hundred voxels
per object and misses small or interleaved pieces.

:func:`join_by_masks` joins pieces by the masks instead: the 3D split can cut
one object along a concave crease of its own surface (a curved banana) when
no view's mask does. An object whose pixels lie mostly in masks that hold a
large share of another object, and whose mean colour is that object's, joins
it. Touching objects that the masks do not part (geometric masks straddle
them where no depth step divides them) differ in colour, and stay apart.

Examples
--------
Two interleaved stripe sets of one flat surface are joined; two side-by-side
halves stay apart:

>>> import numpy as np
>>> pts = np.zeros((20, 20, 3)); pts[..., 0] = np.arange(20) * 0.002; pts[..., 2] = 0.5
>>> cam = (np.eye(3), np.eye(4))
>>> stripes = np.zeros((20, 20), np.int32)
>>> stripes[5:15, 2:18] = np.where(np.arange(2, 18) // 2 % 2 == 0, 1, 2)
>>> out, info = join_objects([stripes], [pts], [cam])
>>> np.unique(out[0]).tolist(), [j["ids"] for j in info["joins"]]
([0, 1], [[1, 2]])
>>> halves = np.zeros((20, 20), np.int32)
>>> halves[5:15, 2:10], halves[5:15, 10:18] = 1, 2
>>> out, info = join_objects([halves], [pts], [cam])
>>> np.unique(out[0]).tolist(), info["joins"]
([0, 1, 2], [])
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..backends.imaging import to_lab
from .masks import close_id_gaps, rename_objects

__all__ = ["border_contact", "join_objects", "join_by_masks"]


def border_contact(
    labels: Sequence[np.ndarray],
    points: Sequence[np.ndarray],
    cameras: Sequence[tuple[Any, Any]],
    *,
    depth_abs: float = 0.01,
    depth_rel: float = 0.02,
    num_objects: int | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Border of every object and contact of every pair, counted in pixel pairs over all views.

    Parameters
    ----------
    labels : list of int ``[H, W]``
        Object ids per view (<= 0 = none), consistent across views.
    points : list of float ``[H, W, 3]``
        World point maps (NaN = invalid).
    cameras : list of ``(K, cam_to_world [4, 4])``
        Only the camera centres are read; a view whose ``cam_to_world`` is None
        is skipped.
    depth_abs, depth_rel : float
        Two neighbouring points further apart than ``depth_abs + depth_rel *``
        (the nearer one's distance to the camera) are not in contact.
    num_objects : int, optional
        The largest object id (default: the largest in ``labels``).

    Returns
    -------
    outline : int64 ``[T + 1]``
        Per object id, its 4-neighbour pixel pairs whose other pixel holds
        another id (0 included); ``outline[0]`` is 0.
    between : int64 ``[T + 1, T + 1]``
        Symmetric; the pixel pairs whose two pixels hold the two ids (both > 0).
    contact : int64 ``[T + 1, T + 1]``
        Symmetric; those of ``between`` with both points finite and no depth step.

    Notes
    -----
    O(H W) per view, vectorized; ``[T + 1, T + 1]`` tables for T objects.

    Examples
    --------
    >>> pts = np.zeros((2, 4, 3)); pts[..., 0] = np.arange(4) * 0.002; pts[..., 2] = 0.5
    >>> pts[:, 3, 2] = 0.6                                    # a 10 cm step before the last column
    >>> lab = np.array([[1, 1, 2, 3], [1, 1, 2, 3]], np.int32)
    >>> outline, between, contact = border_contact([lab], [pts], [(np.eye(3), np.eye(4))])
    >>> outline.tolist(), between[2].tolist(), contact[2].tolist()
    ([0, 2, 4, 2], [0, 2, 0, 2], [0, 2, 0, 0])
    """
    n = len(labels)
    if not (len(points) == len(cameras) == n):
        raise ValueError(f"expected labels, points and cameras for the same views (got {n}, {len(points)}, {len(cameras)})")
    if depth_abs < 0 or depth_rel < 0:
        raise ValueError(f"expected depth_abs >= 0 and depth_rel >= 0 (got {depth_abs}, {depth_rel})")
    top = max(int(max((int(np.max(lab)) for lab in labels if np.size(lab)), default=0)), int(num_objects or 0))
    k = top + 1
    outline = np.zeros(k, np.int64)
    between = np.zeros(k * k, np.int64)
    contact = np.zeros(k * k, np.int64)
    for lab, pts, (_, pose) in zip(labels, points, cameras):
        if pose is None:
            continue
        L = np.clip(np.asarray(lab), 0, None).astype(np.int64)
        P = np.asarray(pts, np.float64)
        if L.shape != P.shape[:2]:
            raise ValueError(f"expected points of shape [{L.shape[0]}, {L.shape[1]}, 3] (got {list(P.shape)})")
        eye = np.asarray(pose, np.float64)[:3, 3]
        for sa, sb in (((slice(None), slice(None, -1)), (slice(None), slice(1, None))), ((slice(None, -1), slice(None)), (slice(1, None), slice(None)))):
            a, b = L[sa], L[sb]
            diff = a != b
            outline += np.bincount(a[diff], minlength=k) + np.bincount(b[diff], minlength=k)
            both = diff & (a > 0) & (b > 0)
            if not both.any():
                continue
            pa, pb = P[sa][both], P[sb][both]
            gap = np.linalg.norm(pa - pb, axis=-1)
            near = np.minimum(np.linalg.norm(pa - eye, axis=-1), np.linalg.norm(pb - eye, axis=-1))
            touch = np.isfinite(gap) & (gap <= depth_abs + depth_rel * np.nan_to_num(near))
            lo, hi = np.minimum(a[both], b[both]), np.maximum(a[both], b[both])
            between += np.bincount(lo * k + hi, minlength=k * k)
            contact += np.bincount((lo * k + hi)[touch], minlength=k * k)
    outline[0] = 0
    pairs, touching = between.reshape(k, k), contact.reshape(k, k)
    return outline, pairs + pairs.T, touching + touching.T


def join_objects(
    labels: Sequence[np.ndarray],
    points: Sequence[np.ndarray],
    cameras: Sequence[tuple[Any, Any]],
    *,
    min_shared: float = 0.3,
    depth_abs: float = 0.01,
    depth_rel: float = 0.02,
    num_objects: int | None = None,
) -> tuple[list[np.ndarray], dict[str, Any]]:
    """Join every object to the larger object it shares most of its outline with, when that share is at least ``min_shared``.

    The share of a pair is their contact (:func:`border_contact`) over the
    smaller of their two outlines. Each object joins at most one object with a
    longer outline (ties: the larger id), the one of highest share, so a
    fragment goes to one object by its strongest evidence and never bridges
    two objects with longer outlines than its own: those are joined only by
    their own contact. Joins chain upwards (a smaller piece joined to the
    fragment comes along). The shares are measured once, on the objects as
    given.

    Parameters
    ----------
    labels, points, cameras, depth_abs, depth_rel, num_objects
        As in :func:`border_contact`.
    min_shared : float
        An object joins its best larger partner when their share is at least
        this (and above 0; ``inf``: never join).

    Returns
    -------
    labels : list of int ``[H, W]``
        New arrays of the input dtypes (the inputs are not modified): each
        group of joined objects takes its smallest id, and the ids above a
        freed one move down to close the gap. Labels <= 0 are kept.
    info : dict
        ``joins``: ``{"ids": [piece, object], "shared"}`` per join, highest
        share first, with the ids as given; ``mapping``: int64 ``[T + 1]``, the
        new id of every old id (0 stays 0); ``num_objects``: the largest id now.

    Notes
    -----
    One :func:`border_contact`, then O(T^2) for T objects.

    Examples
    --------
    >>> pts = np.zeros((4, 4, 3)); pts[..., 0] = np.arange(4) * 0.002; pts[..., 2] = 0.5
    >>> lab = np.array([[1, 1, 1, 1], [1, 2, 2, 1], [1, 2, 2, 1], [1, 1, 1, 1]], np.int32)  # a label on its box
    >>> out, info = join_objects([lab], [pts], [(np.eye(3), np.eye(4))])
    >>> out[0].tolist()[1], info["joins"], info["mapping"].tolist()  # equal outlines: 1 joins the larger id
    ([1, 1, 1, 1], [{'ids': [1, 2], 'shared': 1.0}], [0, 1, 1])
    """
    if not min_shared >= 0:
        raise ValueError(f"expected min_shared >= 0 (got {min_shared})")
    outline, _, contact = border_contact(labels, points, cameras, depth_abs=depth_abs, depth_rel=depth_rel, num_objects=num_objects)
    top = outline.size - 1
    ids = np.arange(top + 1)
    small = np.minimum.outer(outline, outline).astype(np.float64)
    share = np.divide(contact, small, out=np.zeros_like(small), where=small > 0)
    larger = (outline[None, :] > outline[:, None]) | ((outline[None, :] == outline[:, None]) & (ids[None, :] > ids[:, None]))
    share = np.where(larger, share, 0.0)
    share[0], share[:, 0] = 0.0, 0.0
    best = share.argmax(1)  # each object's larger partner of highest share (the first of equal shares: smallest id)
    value = share[ids, best]
    piece = np.flatnonzero((value >= min_shared) & (value > 0))  # shares are at most 1: inf never joins
    piece = piece[np.argsort(-value[piece], kind="stable")]
    joins = [{"ids": [int(a), int(best[a])], "shared": round(float(value[a]), 6)} for a in piece]
    mapping = _join_mapping(best, piece)  # the pointers run to a longer outline
    return rename_objects(labels, mapping if joins else None), {"joins": joins, "mapping": mapping, "num_objects": int(mapping.max(initial=0))}


def _join_mapping(best: np.ndarray, piece: np.ndarray) -> np.ndarray:
    """New id of every old id ``[T + 1]`` after each ``piece`` joined ``best[piece]`` (pointers that only run upwards).

    The chains are followed to their ends; each group takes its smallest id and
    the ids above a freed one move down (:func:`close_id_gaps`).
    """
    ids = np.arange(best.size)
    root = ids.copy()
    root[piece] = best[piece]
    while True:
        nxt = root[root]
        if np.array_equal(nxt, root):
            break
        root = nxt
    first = np.full(best.size, best.size, np.int64)
    np.minimum.at(first, root, ids)  # each group's smallest id
    representative = first[root]
    return close_id_gaps(representative, representative != ids)


def join_by_masks(
    labels: Sequence[np.ndarray],
    masks: Sequence[np.ndarray],
    images: Sequence[np.ndarray],
    *,
    min_cover: float = 0.5,
    max_color: float = 10.0,
    straddle: float = 0.3,
    num_objects: int | None = None,
) -> tuple[list[np.ndarray], dict[str, Any]]:
    """Join every object to the larger object that the views' masks hold it together with, when the two look alike.

    A mask *holds* an object when at least ``straddle`` of the mask's labelled
    pixels lie in it. The cover of object ``a`` by object ``b`` is the share of
    ``a``'s labelled pixels (all views) that lie in masks holding ``b``. Each
    object takes one partner: the larger object (more labelled pixels; equal
    counts: the larger id) that covers it most (equal covers: the smaller id).
    It joins that partner when the cover is at least ``min_cover`` and the mean
    CIE Lab colours of the two (over their labelled pixels) are at most
    ``max_color`` apart; another, closer-coloured object is not tried. So a
    piece goes to one object by its strongest evidence and never bridges two
    larger objects; joins chain upwards. The covers and colours are measured
    once, on the objects as given.

    Parameters
    ----------
    labels : list of int ``[H, W]``
        Object ids per view (<= 0 = none), consistent across views.
    masks : list of int ``[H, W]``
        The composed masks per view, ``mask_id + 1`` (0 = none).
    images : list of uint8 ``[H, W, 3]``
        The views' RGB images.
    min_cover : float
        Least cover of the smaller object for a join (``inf``: never join).
    max_color : float
        Largest distance of the two mean colours (CIE Lab, L in 0..100).
    straddle : float
        Share of a mask's labelled pixels that make it hold an object.
    num_objects : int, optional
        The largest object id; the larger of this and the largest id in
        ``labels`` is used (default: the labels' largest).

    Returns
    -------
    labels : list of int ``[H, W]``
        New arrays of the input dtypes (the inputs are not modified): each
        group of joined objects takes its smallest id, and the ids above a
        freed one move down. Labels <= 0 are kept.
    info : dict
        ``joins``: ``{"ids": [piece, object], "cover", "color"}`` per join,
        highest cover first, with the ids as given; ``mapping``: int64
        ``[T + 1]``, the new id of every old id (0 stays 0); ``num_objects``:
        the largest id now.

    Notes
    -----
    O(total pixels): one colour conversion and one (mask, object) count per
    view, plus, per mask, its objects times its holders (at most
    ``1 / straddle``); then O(T^2) for T objects.

    Examples
    --------
    Two halves of one yellow object in one mask are joined; the blue object
    in a mask of its own stays apart, and so it does when one mask spans all
    three:

    >>> lab = np.array([[1, 1, 2, 2, 3, 3]], np.int32)
    >>> mk = np.array([[1, 1, 1, 1, 2, 2]])
    >>> img = np.zeros((1, 6, 3), np.uint8); img[0, :4] = (230, 200, 40); img[0, 4:] = (40, 60, 200)
    >>> out, info = join_by_masks([lab], [mk], [img])
    >>> out[0].tolist(), [j["ids"] for j in info["joins"]], info["mapping"].tolist()
    ([[1, 1, 1, 1, 2, 2]], [[1, 2]], [0, 1, 1, 2])
    >>> mk2 = np.array([[1, 1, 1, 1, 1, 1]])                  # one mask over all three
    >>> join_by_masks([lab], [mk2], [img])[1]["mapping"].tolist()
    [0, 1, 1, 2]
    """
    from ..graphs import pair_counts

    n = len(labels)
    if not (len(masks) == len(images) == n):
        raise ValueError(f"expected labels, masks and images for the same views (got {n}, {len(masks)}, {len(images)})")
    if not min_cover >= 0 or not max_color >= 0:
        raise ValueError(f"expected min_cover >= 0 and max_color >= 0 (got {min_cover}, {max_color})")
    if not 0 < straddle <= 1:
        raise ValueError(f"expected 0 < straddle <= 1 (got {straddle})")
    top = max(int(max((int(np.max(lab)) for lab in labels if np.size(lab)), default=0)), int(num_objects or 0))
    k = top + 1
    size = np.zeros(k, np.int64)
    color = np.zeros((k, 3))
    cover = np.zeros((k, k))
    for v, (lab, mk, im) in enumerate(zip(labels, masks, images)):
        ob = np.clip(np.asarray(lab), 0, None).astype(np.int64)
        mk = np.asarray(mk).astype(np.int64)
        im = np.asarray(im)
        if mk.shape != ob.shape:
            raise ValueError(f"view {v}: expected masks of shape {list(ob.shape)} (got {list(mk.shape)})")
        if im.shape != (*ob.shape, 3) or im.dtype != np.uint8:
            raise ValueError(f"view {v}: expected a uint8 image of shape {[*ob.shape, 3]} (got {im.dtype} {list(im.shape)})")
        sel = ob > 0
        if not sel.any():
            continue
        o = ob[sel]
        size += np.bincount(o, minlength=k)
        col = to_lab(im)[sel].astype(np.float64) - (0.0, 128.0, 128.0)  # OpenCV's 8-bit Lab -> L 0..255, a, b signed
        for c in range(3):
            color[:, c] += np.bincount(o, weights=col[:, c], minlength=k)
        m = mk[sel]
        keep = m > 0
        if not keep.any():
            continue
        mask_of, obj_of, cnt = pair_counts(m[keep], o[keep], max(int(m.max()) + 1, k))  # (mask, object) pairs, sorted by mask
        total = np.bincount(mask_of, weights=cnt)
        holder = np.flatnonzero(cnt + 1e-9 * total[mask_of] >= straddle * total[mask_of])  # rows whose object the mask holds
        # every (row, holder of the same mask) pair, at most 1 / straddle holders a mask: a's pixels in a mask that holds b
        start = np.searchsorted(mask_of, mask_of[holder], side="left")
        span = np.searchsorted(mask_of, mask_of[holder], side="right") - start
        other = np.repeat(holder, span)
        rows = np.repeat(start, span) + np.arange(int(span.sum())) - np.repeat(np.cumsum(span) - span, span)
        pick = obj_of[rows] != obj_of[other]
        np.add.at(cover, (obj_of[rows[pick]], obj_of[other[pick]]), cnt[rows[pick]])
    color[:, 0] *= 100.0 / 255.0
    color /= np.maximum(size, 1)[:, None]
    share = cover / np.maximum(size, 1)[:, None]
    ids = np.arange(k)
    larger = (size[None, :] > size[:, None]) | ((size[None, :] == size[:, None]) & (ids[None, :] > ids[:, None]))
    share = np.where(larger & (size[None, :] > 0), share, 0.0)
    share[0], share[:, 0] = 0.0, 0.0
    best = share.argmax(1)
    value = share[ids, best]
    dist = np.linalg.norm(color - color[best], axis=1)
    piece = np.flatnonzero((value >= min_cover) & (value > 0) & (dist <= max_color))
    piece = piece[np.argsort(-value[piece], kind="stable")]
    joins = [{"ids": [int(a), int(best[a])], "cover": round(float(value[a]), 6), "color": round(float(dist[a]), 3)} for a in piece]
    mapping = _join_mapping(best, piece)  # the pointers run to a larger object
    return rename_objects(labels, mapping if joins else None), {"joins": joins, "mapping": mapping, "num_objects": int(mapping.max(initial=0))}
