"""Depth transfer between views: a pixel that its own stereo left empty takes a point another view measured.

Rectified two-view stereo (:mod:`graphseg.backends.lifters.stereo`) leaves a
pixel empty when its neighbour pairs disagree or see it at a grazing angle:
wide steps between the views of a ring, weakly textured faces. Another view
has often measured that surface. :func:`transfer_points` projects every
view's confident points into each other view and gives an empty pixel the
nearest point that lands on it (a z-buffer), when

* the surface faces this view's camera: the source view's normal puts both
  cameras on the same side of the surface, so the back of an object seen by
  a view across the ring is never taken for its front, and
* the colours agree: the source pixel and the target pixel differ by at most
  ``max_color_distance`` in CIE Lab (OpenCV's 8-bit scaling, L times 2.55),
  so a point hidden behind a surface that
  has no depth of its own (an occluder) is not taken either.

When the nearest point fails either test the pixel stays empty; points
further behind it are not tried. The region fill that runs afterwards
(:func:`graphseg.backends.lifters.densify.fill_depth_by_regions`) then fits its
planes to these measured points as well.

Examples
--------
>>> import numpy as np
>>> from graphseg.scene import backproject
>>> K = np.array([[40.0, 0, 15.5], [0, 40, 11.5], [0, 0, 1]])
>>> T = np.eye(4); T2 = np.eye(4); T2[0, 3] = 0.05                 # two cameras 5 cm apart
>>> depth = np.full((24, 32), 1.0, np.float32)                       # a wall 1 m away
>>> pts = [backproject(depth, K, T), backproject(depth, K, T2)]
>>> pts[1][:, :16] = np.nan                                          # view 1 measured only its right half
>>> conf = [np.ones((24, 32), np.float32), np.ones((24, 32), np.float32)]
>>> rgb = [np.full((24, 32, 3), 128, np.uint8)] * 2
>>> out, c, added = transfer_points(pts, conf, rgb, [K, K], [T, T2], min_confidence=0.5, max_color_distance=30.0, color_blur=0.0, confidence_out=0.5)
>>> round(added[1], 2), bool(np.isfinite(out[1][2:-2, :16]).all()), float(np.nanmax(np.abs(out[1][..., 2] - 1)))
(0.42, True, 0.0)
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ...geometry import point_normals, project_points
from ..imaging import to_lab

__all__ = ["transfer_points"]


def transfer_points(
    points: Sequence[np.ndarray],
    confidence: Sequence[np.ndarray],
    images: Sequence[np.ndarray],
    Ks: Sequence[np.ndarray],
    poses: Sequence[np.ndarray],
    *,
    min_confidence: float,
    max_color_distance: float | None,
    color_blur: float,
    confidence_out: float,
    normal_step: int = 2,
) -> tuple[list[np.ndarray], list[np.ndarray], list[float]]:
    """Fill each view's empty pixels with the points the other views measured there.

    Parameters
    ----------
    points : list of float ``[H, W, 3]``
        World point maps, one per view, NaN = empty. Not modified.
    confidence : list of float ``[H, W]``
        Per-pixel confidence of ``points``; only points of at least
        ``min_confidence`` are transferred.
    images : list of uint8 ``[H, W, 3]``
        The views' RGB images, for the colour test.
    Ks : list of ``[3, 3]``; poses : list of ``[4, 4]``
        Intrinsics and ``cam_to_world`` of each view.
    min_confidence : float
        Source points below it are not transferred.
    max_color_distance : float, optional
        CIE Lab distance (OpenCV's 8-bit scaling, after a Gaussian blur of
        ``color_blur`` pixels) above which the nearest point is refused
        (None: no colour test).
    color_blur : float
        Pixels.
    confidence_out : float
        Confidence given to a transferred point.
    normal_step : int
        Pixel step of the source normals (:func:`graphseg.geometry.point_normals`);
        points without a normal (next to empty pixels and at the image border)
        are not transferred.

    Returns
    -------
    points : list of float32 ``[H, W, 3]``
        Copies, with the transferred points written into empty pixels.
    confidence : list of float32 ``[H, W]``
    added : list of float
        The fraction of each view's pixels that received a point.

    Notes
    -----
    O(V^2 H W) for V views: every view's points are projected into every
    other view; the nearest point per pixel comes from one sort. The
    projection is pinhole: lens distortion (``sfm`` camera models other than
    the default ``SIMPLE_PINHOLE``) is ignored here. About
    0.3 s per view for 8 views at 640 x 480 on one core.
    """
    n = len(points)
    if not (len(confidence) == len(images) == len(Ks) == len(poses) == n):
        raise ValueError(f"expected one confidence, image, K and pose per point map (got {n} point maps, {len(confidence)}, {len(images)}, {len(Ks)}, {len(poses)})")
    out_p = [np.array(p, np.float32, copy=True, order="C") for p in points]  # C order: the writes below go through reshape views
    out_c = [np.array(c, np.float32, copy=True, order="C") for c in confidence]
    for j in range(n):
        if out_p[j].ndim != 3 or out_p[j].shape[2] != 3 or out_c[j].shape != out_p[j].shape[:2] or np.shape(images[j])[:2] != out_p[j].shape[:2]:
            raise ValueError(
                f"view {j}: expected points [H, W, 3] with confidence [H, W] and an image [H, W, 3] of the same size "
                f"(got {list(out_p[j].shape)}, {list(out_c[j].shape)} and {list(np.shape(images[j]))})"
            )
    if n < 2:
        return out_p, out_c, [0.0] * n
    labs = [to_lab(im, color_blur) for im in images] if max_color_distance is not None else []
    centres = [np.asarray(T, np.float64)[:3, 3] for T in poses]
    # the sources: confident points with a normal, oriented towards the camera that measured them;
    # all views' sources in one array, view j's at rows start[j]:start[j + 1]
    src_x, src_n, src_lab = [], [], []
    for j in range(n):
        P = out_p[j]
        nrm = point_normals(P, normal_step)
        ok = np.isfinite(P).all(-1) & np.isfinite(nrm).all(-1) & (out_c[j] >= min_confidence)
        X = P[ok].astype(np.float64)
        N = nrm[ok].astype(np.float64)
        N *= np.where(np.einsum("ij,ij->i", centres[j] - X, N) < 0, -1.0, 1.0)[:, None]
        src_x.append(X)
        src_n.append(N)
        if labs:
            src_lab.append(labs[j][ok].astype(np.float32))
    start = np.r_[0, np.cumsum([len(x) for x in src_x])]
    all_x, all_n = np.concatenate(src_x), np.concatenate(src_n)
    all_lab = np.concatenate(src_lab) if labs else None
    added = []
    for i in range(n):
        h, w = out_p[i].shape[:2]
        empty = ~np.isfinite(out_p[i]).all(-1).ravel()
        if not empty.any():
            added.append(0.0)
            continue
        # candidates: points of the other views that land on one of camera i's empty pixels
        cand_pix, cand_z, cand_row = [], [], []
        for j in range(n):
            if j == i or start[j] == start[j + 1]:
                continue
            u, v, z, ok = project_points(src_x[j], Ks[i], poses[i], (h, w))
            pix = v * w + u
            ok[ok] &= empty[pix[ok]]
            k = np.flatnonzero(ok)
            cand_pix.append(pix[k])
            cand_z.append(z[k])
            cand_row.append(start[j] + k)
        if not cand_pix:
            added.append(0.0)
            continue
        pix, z, row = (np.concatenate(a) for a in (cand_pix, cand_z, cand_row))
        # the nearest point per pixel: sort by pixel, then depth; the first of each pixel wins
        order = np.lexsort((z, pix))
        first = np.r_[True, pix[order][1:] != pix[order][:-1]] if order.size else np.zeros(0, bool)
        win = order[first]
        X = all_x[row[win]]
        keep = np.einsum("ij,ij->i", centres[i] - X, all_n[row[win]]) > 0  # the nearest surface faces camera i
        if all_lab is not None:
            keep &= np.linalg.norm(all_lab[row[win]] - labs[i].reshape(-1, 3)[pix[win]].astype(np.float32), axis=1) <= max_color_distance
        win, X = win[keep], X[keep]
        out_p[i].reshape(-1, 3)[pix[win]] = X.astype(np.float32)
        out_c[i].reshape(-1)[pix[win]] = confidence_out
        added.append(float(win.size / (h * w)))
    return out_p, out_c, added
