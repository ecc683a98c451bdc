"""Per-pixel refinement after contraction: every object pixel relabelled by multi-view 3D consensus.

After contraction a mask is one object, all or nothing, so a mask that
straddles two objects caps the result (the audit's majority-grouping
ceiling). :func:`refine_labels` lets the other views outvote such pixels: each
labelled pixel's 3D point is projected into every other view; where that view
sees the same surface (foreground at the same depth), the object it gives there
is a vote, weighted by that view's confidence. A pixel takes the object with
most votes when enough views agree and they outweigh its own label.

Examples
--------
>>> import numpy as np
>>> K = np.array([[10.0, 0, 2], [0, 10, 2], [0, 0, 1]])
>>> pm = np.zeros((5, 5, 3)); pm[..., 2] = 1.0          # three views of one plane
>>> lab = [np.full((5, 5), 1), np.full((5, 5), 2), np.full((5, 5), 2)]
>>> out, info = refine_labels(lab, [pm] * 3, [(K, np.eye(4))] * 3, min_views=2)
>>> [int(np.unique(x)[0]) for x in out], info["changed"]
([2, 2, 2], 25)
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..geometry import project_points

__all__ = ["project_to_view", "refine_labels"]


def project_to_view(
    pts: np.ndarray, K: np.ndarray, cam_to_world: np.ndarray, points: np.ndarray, *, tolerance: float = 0.02
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where world points land in a view, and whether that view sees them there.

    Parameters
    ----------
    pts : float ``[N, 3]``
        World points.
    K : float ``[3, 3]``; cam_to_world : float ``[4, 4]``
        The view's camera.
    points : float ``[H, W, 3]``
        The view's world point map (NaN = invalid).
    tolerance : float
        A point is seen when the view's own point at its pixel has the same
        camera depth within ``tolerance`` times that depth.

    Returns
    -------
    seen : bool ``[N]``
    v, u : int64 ``[N]``
        Pixel row and column (rounded); -1 for points behind the camera, and
        outside ``[0, H) x [0, W)`` for points beside the image.

    Notes
    -----
    O(N).

    Examples
    --------
    >>> K = np.array([[10.0, 0, 2], [0, 10, 2], [0, 0, 1]])
    >>> pm = np.zeros((5, 5, 3)); pm[..., 2] = 1.0
    >>> seen, v, u = project_to_view(np.array([[0.0, 0, 1], [0, 0, 2]]), K, np.eye(4), pm)
    >>> seen.tolist(), int(v[0]), int(u[0])
    ([True, False], 2, 2)
    """
    T = np.asarray(cam_to_world, np.float64)
    u, v, z, ok = project_points(pts, K, T, points.shape[:2])
    seen = np.zeros(len(z), bool)
    if ok.any():
        q = np.asarray(points[v[ok], u[ok]], np.float64)
        zq = (q - T[:3, 3]) @ T[:3, 2]
        seen[ok] = np.abs(zq - z[ok]) <= tolerance * z[ok]  # NaN (invalid pixel) compares False
    return seen, v, u


def refine_labels(
    labels: Sequence[np.ndarray],
    points: Sequence[np.ndarray],
    cameras: Sequence[tuple[Any, Any]],
    *,
    confidence: Sequence[np.ndarray | None] | None = None,
    tolerance: float = 0.02,
    self_weight: float = 1.0,
    min_views: int = 2,
) -> tuple[list[np.ndarray], dict[str, Any]]:
    """Relabel every object pixel by the objects other views give its 3D point.

    Parameters
    ----------
    labels : list of int ``[H, W]``
        Object ids per view (0 = none); pixels with 0 are left alone and do not vote.
    points : list of float ``[H, W, 3]``
        World point maps (NaN = invalid).
    cameras : list of ``(K [3, 3], cam_to_world [4, 4])``
        A view with either matrix None neither votes nor is refined.
    confidence : list of float ``[H, W]`` (or None per view), optional
        Weight of each view's votes per pixel (default 1).
    tolerance : float
        Relative depth agreement for a view to see a point (:func:`project_to_view`).
    self_weight : float
        Weight of a pixel's own label.
    min_views : int
        A pixel changes only when at least this many other views vote for the
        new object, and their weight exceeds its own label's (its own weight plus
        the votes for it).

    Returns
    -------
    labels : list of int ``[H, W]``
        New arrays (the inputs are not modified), same dtype.
    info : dict
        ``changed``: pixels relabelled over all views; ``per_view``: per view.

    Notes
    -----
    O(V^2 P) for V views of P labelled pixels each (one projection and lookup
    per pixel and other view): about 0.1-0.3 s for 10 views of 640x480 with
    objects on 10-20% of the pixels.
    """
    n = len(labels)
    if not (len(points) == len(cameras) == n):
        raise ValueError(f"expected labels, points and cameras for the same views (got {n}, {len(points)}, {len(cameras)})")
    if min_views < 1:
        raise ValueError(f"expected min_views >= 1 (got {min_views})")
    labs = [np.asarray(x) for x in labels]
    num = int(max((int(x.max()) for x in labs if x.size), default=0))
    out = [x.copy() for x in labs]
    per_view = [0] * n
    usable = [K is not None and T is not None for K, T in cameras]
    if num == 0 or sum(usable) < 2:
        return out, {"changed": 0, "per_view": per_view}
    for i in range(n):
        if not usable[i]:
            continue
        own_map = labs[i]
        rows, cols = np.nonzero(own_map > 0)
        if rows.size == 0:
            continue
        P = np.asarray(points[i], np.float64)[rows, cols]
        finite = np.isfinite(P).all(1)
        rows, cols, P = rows[finite], cols[finite], P[finite]
        own = own_map[rows, cols].astype(np.int64)
        m = rows.size
        cells = m * (num + 1)  # one (pixel, object) cell per vote target: flat index pixel * (num + 1) + object
        weight = np.zeros(cells)
        count = np.zeros(cells)
        for j in range(n):
            if j == i or not usable[j]:
                continue
            K, T = cameras[j]
            seen, v, u = project_to_view(P, K, T, np.asarray(points[j]), tolerance=tolerance)
            idx = np.flatnonzero(seen)
            if idx.size == 0:
                continue
            other = labs[j][v[idx], u[idx]].astype(np.int64)
            vote = other > 0
            idx, other = idx[vote], other[vote]
            flat = idx * (num + 1) + other
            c = confidence[j] if confidence is not None else None
            wgt = None if c is None else np.nan_to_num(np.asarray(c, np.float64)[v[idx], u[idx]], nan=0.0)
            weight += np.bincount(flat, weights=np.ones(flat.size) if wgt is None else wgt, minlength=cells)
            count += np.bincount(flat, minlength=cells)
        wgrid = weight.reshape(m, num + 1)
        cgrid = count.reshape(m, num + 1)
        pix = np.arange(m)
        wgrid[pix, own] += self_weight
        best = wgrid.argmax(1)
        change = (best != own) & (cgrid[pix, best] >= min_views) & (wgrid[pix, best] > wgrid[pix, own])
        if change.any():
            out[i][rows[change], cols[change]] = best[change].astype(out[i].dtype)
            per_view[i] = int(change.sum())
    return out, {"changed": int(sum(per_view)), "per_view": per_view}
