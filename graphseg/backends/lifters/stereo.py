"""Dense depth from calibrated view pairs: rectification + semi-global matching (OpenCV).

For a pair with known intrinsics and relative pose, both images are rectified
(``cv2.stereoRectify``; vertical baselines are transposed, right-to-left ones
mirrored, so the matcher always sees a left/right pair), ``cv2.StereoSGBM``
gives the disparity of both images, and a left-right check keeps pixels whose
two disparities agree within ``lr_tolerance`` pixels. Per view, the estimates
of several neighbours are fused: a pixel is kept when at least ``min_agree``
pairs agree on its depth within ``rel_tolerance`` (cross-pair check).

Measured on renders (``docs/results.md``): neighbours about 10 degrees apart
on a narrow arc give well under 1% median depth error; views 40 degrees apart
are unusable (the lifter does not pair them, see ``max_pair_angle``).

Examples
--------
>>> import numpy as np
>>> pts = sparse_point_maps(np.array([[0.0, 0, 1]]), [(np.array([[2.0, 1]]), np.array([0]))], (4, 5), radius=0)
>>> np.isfinite(pts[0][..., 0]).sum(), pts[0][1, 2].tolist()
(np.int64(1), [0.0, 0.0, 1.0])
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...parallel import parallel_map

__all__ = ["pair_points", "SgbmOptions", "stereo_depths", "fuse_depths", "sparse_point_maps", "select_neighbours", "view_consistency"]


def _canon(img: np.ndarray, vertical: bool, flip: bool) -> np.ndarray:
    out = img.swapaxes(0, 1) if vertical else img
    return np.ascontiguousarray(out[:, ::-1] if flip else out)


def _uncanon(img: np.ndarray, vertical: bool, flip: bool) -> np.ndarray:
    out = img[:, ::-1] if flip else img
    return np.ascontiguousarray(out.swapaxes(0, 1) if vertical else out)


def _sgbm(left: np.ndarray, right: np.ndarray, min_disp: int, num_disp: int, block: int) -> np.ndarray:
    import cv2

    cn = left.shape[2] if left.ndim == 3 else 1
    m = cv2.StereoSGBM_create(  # type: ignore[attr-defined]
        minDisparity=min_disp,
        numDisparities=num_disp,
        blockSize=block,
        P1=8 * cn * block * block,
        P2=32 * cn * block * block,
        uniquenessRatio=10,
        speckleWindowSize=100,
        speckleRange=2,
        disp12MaxDiff=-1,
        mode=cv2.STEREO_SGBM_MODE_SGBM_3WAY,
    )
    d = m.compute(left, right).astype(np.float32) / 16.0
    d[d <= min_disp - 0.5] = np.nan  # SGBM marks failures with minDisparity - 1
    return d


def _lr_check(dl: np.ndarray, dr: np.ndarray, tol: float) -> np.ndarray:
    """Keep left disparities ``dl`` that the right image's ``dr`` confirms (x_r = x_l - d)."""
    h, w = dl.shape
    xs = np.arange(w)[None, :] - np.nan_to_num(dl, nan=1e9)
    xr = np.rint(xs).astype(np.int64)
    ok = np.isfinite(dl) & (xr >= 0) & (xr < w)
    rows = np.broadcast_to(np.arange(h)[:, None], (h, w))
    other = np.full((h, w), np.nan, np.float32)
    other[ok] = dr[rows[ok], xr[ok]]
    keep = ok & (np.abs(other - dl) <= tol)
    return np.where(keep, dl, np.float32(np.nan))


def _rectify(K1: np.ndarray, D1: np.ndarray, K2: np.ndarray, D2: np.ndarray, R: np.ndarray, T: np.ndarray, size: tuple[int, int], *, max_zoom: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Rectifying rotations (``cv2.stereoRectify``) and one shared projection that holds both whole images.

    Returns ``R1, R2, P1, P2`` where ``P`` is ``[3, 4]`` whose last column
    holds the canvas ``(width, height)`` (the caller replaces it).
    OpenCV's own ``alpha`` scaling breaks down (negative or tiny focal lengths)
    when the pair moves forward a lot, as converging views around a table do.
    """
    import cv2

    h, w = size
    R1, R2, *_ = cv2.stereoRectify(K1, D1, K2, D2, (w, h), R, T.reshape(3, 1), flags=cv2.CALIB_ZERO_DISPARITY, alpha=-1)
    f = float(np.mean([K1[0, 0], K1[1, 1], K2[0, 0], K2[1, 1]]))
    t = np.linspace(0, 1, 9)
    border = np.concatenate([np.c_[t * (w - 1), np.zeros(9)], np.c_[t * (w - 1), np.full(9, h - 1)], np.c_[np.zeros(9), t * (h - 1)], np.c_[np.full(9, w - 1), t * (h - 1)]])
    unit = np.array([[f, 0, 0], [0, f, 0], [0, 0, 1.0]])
    pts = np.concatenate([cv2.undistortPoints(border.reshape(-1, 1, 2), K, D, R=Rr, P=unit).reshape(-1, 2) for K, D, Rr in ((K1, D1, R1), (K2, D2, R2))])
    lo, hi = pts.min(0), pts.max(0)
    span = np.maximum(hi - lo, 1.0)
    scale = float(min(1.0, max_zoom * w / span[0], max_zoom * h / span[1]))
    P = np.zeros((3, 4))
    P[0, 0] = P[1, 1] = f * scale
    P[:2, 2] = -lo * scale
    P[2, 2] = 1
    P[0, 3], P[1, 3] = int(np.ceil(span[0] * scale)) + 1, int(np.ceil(span[1] * scale)) + 1
    return R1, R2, P, P.copy()


def _to_camera(depth_rect: np.ndarray, K: np.ndarray, D: np.ndarray, R: np.ndarray, P: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """Camera-frame points ``[H, W, 3]`` of every original pixel from a depth map on the rectified grid."""
    import cv2

    h, w = size
    u, v = np.meshgrid(np.arange(w, dtype=np.float32), np.arange(h, dtype=np.float32))
    uv = np.stack([u.ravel(), v.ravel()], 1).reshape(-1, 1, 2)
    rect = cv2.undistortPoints(uv, K, D, R=R, P=P).reshape(h, w, 2)
    z = cv2.remap(depth_rect.astype(np.float32), rect[..., 0], rect[..., 1], cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT, borderValue=float("nan"))
    f, cx, cy = P[0, 0], P[0, 2], P[1, 2]
    xr = np.stack([(rect[..., 0] - cx) / f * z, (rect[..., 1] - cy) / P[1, 1] * z, z], -1)
    cam = xr @ R.astype(np.float32)  # R^T applied on the left: rectified -> original camera
    cam[~(z > 0)] = np.nan
    return cam.astype(np.float32)


@dataclass(frozen=True)
class SgbmOptions:
    """Settings of :func:`pair_points`' semi-global block matching.

    Attributes
    ----------
    block_size : int
        SGBM matching block (odd).
    lr_tolerance : float
        Pixels; left-right consistency.
    max_disparities : int
        Cap on the disparity search width.
    max_zoom : float
        The rectified canvas is at most this many times the image width and
        height (the focal length shrinks to fit when the pair's rectified
        images would be larger, as with strong forward motion).
    """

    block_size: int = 5
    lr_tolerance: float = 1.0
    max_disparities: int = 256
    max_zoom: float = 1.5


def pair_points(
    img1: np.ndarray,
    img2: np.ndarray,
    K1: np.ndarray,
    K2: np.ndarray,
    R: np.ndarray,
    T: np.ndarray,
    *,
    D1: np.ndarray | None = None,
    D2: np.ndarray | None = None,
    depth_range: tuple[float, float] | None = None,
    sgbm: SgbmOptions | None = None,
) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
    """Camera-frame point maps of both images of a calibrated pair.

    Parameters
    ----------
    img1, img2 : uint8 ``[H, W, 3]``
    K1, K2 : ``[3, 3]``
    R, T : ``[3, 3]``, ``[3]``
        Relative pose, ``x_2 = R x_1 + T`` for camera-frame points.
    D1, D2 : OpenCV distortion coefficients, optional
    depth_range : (near, far), optional
        Sets the disparity search range (with 20% margin); without it 0..128 px.
    sgbm : SgbmOptions, optional
        The matcher's settings (None: :class:`SgbmOptions`' defaults).

    Returns
    -------
    points1, points2 : float32 ``[H, W, 3]``
        Camera-frame points of each image, NaN where no consistent disparity.
    info : dict
        ``{"vertical", "flip", "baseline", "focal"}`` of the rectified pair;
        ``skipped`` when the disparity range lies off the rectified image (a
        pair whose cameras are far off): then both maps are all NaN.

    Notes
    -----
    O(H W D) for ``D`` disparities; about 0.05 s per 640 x 480 pair.
    """
    import cv2

    opt = sgbm if sgbm is not None else SgbmOptions()
    block_size, lr_tolerance, max_disparities, max_zoom = opt.block_size, opt.lr_tolerance, opt.max_disparities, opt.max_zoom
    R = np.asarray(R, np.float64)
    T = np.asarray(T, np.float64).reshape(3)
    h, w = img1.shape[:2]
    D1 = np.zeros(5) if D1 is None else np.asarray(D1, np.float64)
    D2 = np.zeros(5) if D2 is None else np.asarray(D2, np.float64)
    K1 = np.asarray(K1, np.float64)
    K2 = np.asarray(K2, np.float64)
    R1, R2, P1, P2 = _rectify(K1, D1, K2, D2, R, T, (h, w), max_zoom=max_zoom)
    c2r = R1 @ (-R.T @ T)  # camera 2 in the rectified frame: (B, 0, 0) or (0, B, 0)
    vertical = abs(c2r[1]) > abs(c2r[0])
    f = float(P1[0, 0])
    baseline = float(abs(c2r[1] if vertical else c2r[0]))
    flip = bool((c2r[1] if vertical else c2r[0]) < 0)  # camera 1 is right of (below) camera 2
    size = (int(P1[0, 3]), int(P1[1, 3]))
    P1 = P1.copy()
    P1[:2, 3] = 0
    P2 = P2.copy()
    P2[:2, 3] = 0
    P2[0 if not vertical else 1, 3] = -f * (c2r[1] if vertical else c2r[0])
    m1 = cv2.initUndistortRectifyMap(K1, D1, R1, P1[:, :3], size, cv2.CV_32FC1)
    m2 = cv2.initUndistortRectifyMap(K2, D2, R2, P2[:, :3], size, cv2.CV_32FC1)
    r1 = cv2.remap(np.ascontiguousarray(img1), m1[0], m1[1], cv2.INTER_LINEAR)
    r2 = cv2.remap(np.ascontiguousarray(img2), m2[0], m2[1], cv2.INTER_LINEAR)
    left, right = _canon(r1, vertical, flip), _canon(r2, vertical, flip)
    if depth_range is not None and depth_range[0] > 0:
        dmin = int(np.floor(f * baseline / (depth_range[1] * 1.2)))
        dmax = int(np.ceil(f * baseline / (depth_range[0] * 0.8)))
    else:
        dmin, dmax = 0, 128
    num = int(min(max(16, int(np.ceil((dmax - dmin) / 16.0)) * 16), max_disparities))
    width = int(left.shape[1])
    if not -width < dmin < width:  # the search range lies off the rectified image (a pair posed far off): no match can exist
        info = {"vertical": bool(vertical), "flip": bool(flip), "baseline": baseline, "focal": f, "skipped": f"disparities from {dmin} px, off the {width} px image"}
        return np.full((h, w, 3), np.nan, np.float32), np.full((h, w, 3), np.nan, np.float32), info
    dl = _sgbm(left, right, dmin, num, block_size)
    # the right image's disparity: mirror both images so it becomes a left image
    dr = _sgbm(np.ascontiguousarray(right[:, ::-1]), np.ascontiguousarray(left[:, ::-1]), dmin, num, block_size)[:, ::-1]
    dl_ok = _lr_check(dl, dr, lr_tolerance)
    dr_ok = _lr_check(dr[:, ::-1], dl[:, ::-1], lr_tolerance)[:, ::-1]
    with np.errstate(divide="ignore", invalid="ignore"):
        z1 = _uncanon(np.where(dl_ok > 0, f * baseline / dl_ok, np.nan).astype(np.float32), vertical, flip)
        z2 = _uncanon(np.where(dr_ok > 0, f * baseline / dr_ok, np.nan).astype(np.float32), vertical, flip)
    p1 = _to_camera(z1, K1, D1, R1, P1[:, :3], (h, w))
    p2 = _to_camera(z2, K2, D2, R2, P2[:, :3], (h, w))
    return p1, p2, {"vertical": bool(vertical), "flip": bool(flip), "baseline": baseline, "focal": f}


def fuse_depths(estimates: Sequence[np.ndarray], *, rel_tolerance: float = 0.02, min_agree: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Fuse camera-frame point maps of one view from several pairs (cross-pair check).

    Parameters
    ----------
    estimates : list of float32 ``[H, W, 3]``
        NaN where a pair gave nothing.
    rel_tolerance : float
        Estimates within ``rel_tolerance * z`` of the per-pixel median depth agree.
    min_agree : int
        Agreeing estimates needed (capped at the number of estimates).

    Returns
    -------
    points : float32 ``[H, W, 3]``
        Mean of the agreeing estimates, NaN elsewhere.
    agree : float32 ``[H, W]``
        Fraction of the estimates that agree (0 where rejected).

    Examples
    --------
    >>> a = np.ones((1, 2, 3), np.float32); b = a.copy(); b[0, 1] = 2
    >>> p, c = fuse_depths([a, b], min_agree=2)
    >>> np.isfinite(p[0, :, 2]).tolist(), c.tolist()
    ([True, False], [[1.0, 0.0]])
    """
    if not estimates:
        raise ValueError("expected at least one estimate")
    stack = np.stack([np.asarray(e, np.float32) for e in estimates])  # [K, H, W, 3]
    z = stack[..., 2]
    valid = np.isfinite(z)
    with np.errstate(all="ignore"):
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            med = np.nanmedian(np.where(valid, z, np.nan), axis=0)
    agree = valid & (np.abs(z - med[None]) <= rel_tolerance * np.abs(med[None]))
    count = agree.sum(0)
    need = min(min_agree, len(estimates))
    keep = count >= need
    total = np.where(agree[..., None], stack, 0).sum(0)
    with np.errstate(divide="ignore", invalid="ignore"):
        pts = total / count[..., None]
    pts[~keep] = np.nan
    conf = np.where(keep, count / len(estimates), 0).astype(np.float32)
    return pts.astype(np.float32), conf


def select_neighbours(poses: Sequence[np.ndarray], *, max_angle: float = 20.0, max_neighbours: int = 4) -> list[list[int]]:
    """Per view, the other views whose optical axes lie within ``max_angle`` degrees, closest camera first.

    Examples
    --------
    >>> T = [np.eye(4), np.eye(4), np.eye(4)]
    >>> T[1][:3, 3] = [0.1, 0, 0]; T[2][:3, 3] = [0.3, 0, 0]
    >>> select_neighbours(T, max_neighbours=1)
    [[1], [0], [1]]
    """
    n = len(poses)
    axes = np.array([np.asarray(T)[:3, 2] for T in poses])
    centres = np.array([np.asarray(T)[:3, 3] for T in poses])
    cos = np.clip(axes @ axes.T, -1, 1)
    ang = np.degrees(np.arccos(cos))
    dist = np.linalg.norm(centres[:, None] - centres[None], axis=-1)
    out = []
    for i in range(n):
        cand = [j for j in range(n) if j != i and ang[i, j] <= max_angle and dist[i, j] > 1e-9]
        out.append(sorted(cand, key=lambda j: dist[i, j])[:max_neighbours])
    return out


def stereo_depths(
    images: Sequence[np.ndarray],
    Ks: Sequence[np.ndarray],
    dists: Sequence[np.ndarray | None],
    poses: Sequence[np.ndarray],
    *,
    max_pair_angle: float,
    max_neighbours: int,
    depth_ranges: Sequence[tuple[float, float] | None] | None = None,
    rel_tolerance: float = 0.02,
    min_agree: int = 2,
) -> tuple[list[np.ndarray], list[np.ndarray], dict[str, Any]]:
    """World point maps ``[H, W, 3]`` and confidences ``[H, W]`` from fused stereo pairs.

    ``max_pair_angle`` (degrees) and ``max_neighbours`` are required: their
    defaults live in ``SfmLifter.Options`` (:mod:`graphseg.backends.lifters.sfm`).

    Every unordered neighbour pair (:func:`select_neighbours`) is matched once
    and gives depth to both views; each view then fuses its pairs with
    :func:`fuse_depths`. A view with no neighbour gets all-NaN points.

    Returns
    -------
    points : list of float32 ``[H, W, 3]`` (world frame, NaN = unknown)
    confidence : list of float32 ``[H, W]``
    info : dict
        ``{"pairs": number of stereo pairs, "dense_fraction": per-view covered fraction}``.
    """
    n = len(images)
    h, w = images[0].shape[:2]
    nbrs = select_neighbours(poses, max_angle=max_pair_angle, max_neighbours=max_neighbours)
    pairs = sorted({(min(i, j), max(i, j)) for i in range(n) for j in nbrs[i]})
    est: list[list[np.ndarray]] = [[] for _ in range(n)]

    def one_pair(pair: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
        i, j = pair
        Ti, Tj = np.asarray(poses[i], np.float64), np.asarray(poses[j], np.float64)
        rel = np.linalg.inv(Tj) @ Ti  # camera i -> camera j
        rng_ij = None
        if depth_ranges is not None and depth_ranges[i] is not None and depth_ranges[j] is not None:
            rng_ij = (min(depth_ranges[i][0], depth_ranges[j][0]), max(depth_ranges[i][1], depth_ranges[j][1]))  # type: ignore[index]
        p1, p2, _ = pair_points(images[i], images[j], Ks[i], Ks[j], rel[:3, :3], rel[:3, 3], D1=dists[i], D2=dists[j], depth_range=rng_ij)
        return p1, p2

    for (i, j), (p1, p2) in zip(pairs, parallel_map(one_pair, pairs)):  # each pair on its own: any order, same result
        est[i].append(p1)
        est[j].append(p2)
    pts, conf = [], []
    for i in range(n):
        if not est[i]:
            pts.append(np.full((h, w, 3), np.nan, np.float32))
            conf.append(np.zeros((h, w), np.float32))
            continue
        cam, c = fuse_depths(est[i], rel_tolerance=rel_tolerance, min_agree=min_agree)
        T = np.asarray(poses[i], np.float32)
        pts.append((cam @ T[:3, :3].T + T[:3, 3]).astype(np.float32))
        conf.append(c)
    return pts, conf, {"pairs": len(pairs), "dense_fraction": [float(np.isfinite(p).all(-1).mean()) for p in pts]}


def view_consistency(
    points: Sequence[np.ndarray],
    Ks: Sequence[np.ndarray],
    poses: Sequence[np.ndarray],
    neighbours: Sequence[Sequence[int]],
    *,
    images: Sequence[np.ndarray] | None = None,
    rel_tolerance: float = 0.01,
    pixel_tolerance: float = 1.0,
    color_tolerance: float = 30.0,
) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Multi-view geometric (and photometric) consistency of per-view point maps.

    For every pixel ``p`` of view ``i`` with a point ``X``, and every neighbour
    ``j``: ``X`` is projected into ``j``; the point ``j`` has there is projected
    back into ``i``. The pair agrees when it lands within ``pixel_tolerance``
    pixels of ``p`` at a depth within ``rel_tolerance`` of ``X``'s (the
    forward-backward test of multi-view stereo fusion) and, with ``images``,
    when the two pixels' colours (CIE Lab, summed absolute difference) differ
    by at most ``color_tolerance``: a point bled across an object's border by
    a stereo window lands on the object in the other view, whose colour is
    not the table's.

    Parameters
    ----------
    points : list of float ``[H, W, 3]``
        World points per view (NaN = none).
    Ks : list of ``[3, 3]``
    poses : list of ``[4, 4]`` camera-to-world
    neighbours : list of lists of int
        The views each view is checked against (:func:`select_neighbours`).
    images : list of uint8 ``[H, W, 3]``, optional, keyword-only
        RGB images for the colour test (None: geometry only).
    rel_tolerance, pixel_tolerance, color_tolerance : float, keyword-only

    Returns
    -------
    agree : list of int32 ``[H, W]``
        Neighbours that confirm each pixel.
    checked : list of int32 ``[H, W]``
        Neighbours that could (the point projects into them, where they have a point).

    Notes
    -----
    O(H W) per (view, neighbour) pair.

    Examples
    --------
    >>> K = np.array([[50.0, 0, 8], [0, 50, 8], [0, 0, 1]])
    >>> T0, T1 = np.eye(4), np.eye(4); T1[0, 3] = 0.05
    >>> u, v = np.meshgrid(np.arange(16.0), np.arange(16.0))
    >>> wall = np.dstack([(u - 8) / 50, (v - 8) / 50, np.ones_like(u)]).astype(np.float32)   # z = 1, seen by camera 0
    >>> wall1 = wall.copy(); wall1[..., 0] += 0.05                                        # the same wall from camera 1
    >>> agree, checked = view_consistency([wall, wall1], [K, K], [T0, T1], [[1], [0]])
    >>> int(agree[0][8, 8]), int(checked[0][8, 0])   # (8, 0) projects outside view 1: not checked
    (1, 0)
    """
    import cv2

    n = len(points)
    flat_pts = [np.ascontiguousarray(np.asarray(p, np.float32).reshape(-1, 3)) for p in points]
    labs = None
    if images is not None:
        labs = [cv2.cvtColor(cv2.GaussianBlur(np.ascontiguousarray(im), (3, 3), 0), cv2.COLOR_RGB2LAB).astype(np.int16).reshape(-1, 3) for im in images]
    agree_out, checked_out = [], []
    for i in range(n):
        h, w = points[i].shape[:2]
        idx = np.flatnonzero(np.isfinite(flat_pts[i]).all(1))
        Pi = flat_pts[i][idx]
        Ti = np.asarray(poses[i], np.float64)
        # world -> camera i -> pixels of i, as one affine map of homogeneous world points
        Mi = np.asarray(Ks[i], np.float64) @ Ti[:3, :3].T
        bi = -Mi @ Ti[:3, 3]
        Ri, ti = Ti[:3, :3].astype(np.float32), Ti[:3, 3].astype(np.float32)
        zi = (Pi - ti) @ Ri[:, 2]
        agree = np.zeros(h * w, np.int32)
        checked = np.zeros(h * w, np.int32)
        for j in neighbours[i]:
            hj, wj = points[j].shape[:2]
            Tj = np.asarray(poses[j], np.float64)
            Mj = np.asarray(Ks[j], np.float64) @ Tj[:3, :3].T
            uvj = Pi @ Mj.T.astype(np.float32) + (-Mj @ Tj[:3, 3]).astype(np.float32)
            with np.errstate(divide="ignore", invalid="ignore"):
                uj = np.rint(uvj[:, 0] / uvj[:, 2])
                vj = np.rint(uvj[:, 1] / uvj[:, 2])
            sel = np.flatnonzero((uvj[:, 2] > 0) & (uj >= 0) & (uj < wj) & (vj >= 0) & (vj < hj))
            fj = vj[sel].astype(np.int64) * wj + uj[sel].astype(np.int64)
            Q = flat_pts[j][fj]
            qok = np.isfinite(Q[:, 0])
            sel, fj, Q = sel[qok], fj[qok], Q[qok]
            uvb = Q @ Mi.T.astype(np.float32) + bi.astype(np.float32)
            pix = idx[sel]
            with np.errstate(divide="ignore", invalid="ignore"):
                du = uvb[:, 0] / uvb[:, 2] - (pix % w)
                dv = uvb[:, 1] / uvb[:, 2] - (pix // w)
            ok = (du * du + dv * dv <= pixel_tolerance**2) & (np.abs(uvb[:, 2] - zi[sel]) <= rel_tolerance * zi[sel])
            if labs is not None:
                ok &= np.abs(labs[i][pix] - labs[j][fj]).sum(1) <= color_tolerance
            checked[pix] += 1
            agree[pix[ok]] += 1
        agree_out.append(agree.reshape(h, w))
        checked_out.append(checked.reshape(h, w))
    return agree_out, checked_out


def sparse_point_maps(points: np.ndarray, observations: Sequence[tuple[np.ndarray, np.ndarray]], size: tuple[int, int], *, radius: int = 1) -> list[np.ndarray]:
    """Per-view world point maps ``[H, W, 3]`` holding triangulated points at their observations.

    Each observed point fills the ``(2 radius + 1)^2`` pixel block around its
    rounded pixel (NaN elsewhere), so a gather with a pixel stride up to
    ``radius + 1`` still sees it.
    """
    h, w = size
    out = []
    P = np.asarray(points, np.float32)
    for xy, pid in observations:
        m = np.full((h, w, 3), np.nan, np.float32)
        if len(pid):
            c = np.rint(np.asarray(xy)).astype(np.int64)
            for dy in range(-radius, radius + 1):
                for dx in range(-radius, radius + 1):
                    x, y = c[:, 0] + dx, c[:, 1] + dy
                    ok = (x >= 0) & (x < w) & (y >= 0) & (y < h)
                    m[y[ok], x[ok]] = P[pid[ok]]
            # the centre pixel wins over a neighbour's block
            x, y = c[:, 0], c[:, 1]
            ok = (x >= 0) & (x < w) & (y >= 0) & (y < h)
            m[y[ok], x[ok]] = P[pid[ok]]
        out.append(m)
    return out
