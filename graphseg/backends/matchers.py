"""Matchers: a pair of views -> pixel matches with certainty.

* ``reprojection``: exact when 3D is known. Every pixel's world point is
  projected into the other view and kept where the other view's depth agrees
  (visibility test); certainty falls off with the depth disagreement. The
  weight-free stand-in for RoMa.
* ``flow``: OpenCV DIS optical flow with forward-backward consistency as
  certainty (RGB only).
* ``sift``: SIFT + Lowe ratio test + ``cv2.USAC_MAGSAC`` verification (sparse).

All subsample to ``num_matches`` by certainty (ties broken at random). Each
matcher is a :class:`~graphseg.backends.options.Backend`: its ``Options`` hold
the defaults, and the pure functions take every option as a required keyword.

Examples
--------
>>> import numpy as np
>>> from graphseg.scene import View, backproject
>>> K = np.array([[50.0, 0, 16], [0, 50, 12], [0, 0, 1]])
>>> T = np.eye(4)
>>> depth = np.full((24, 32), 2.0, np.float32)
>>> v = View("a", np.zeros((24, 32, 3), np.uint8), depth=depth, points=backproject(depth, K, T), K=K, cam_to_world=T)
>>> m = ReprojectionMatcher(num_matches=None)(v, v)        # or ReprojectionMatcher(ReprojectionMatcher.Options(num_matches=None))
>>> len(m), bool(np.abs(m.xy_i - m.xy_j).max() < 1e-4)
(768, True)
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from ..scene import Matches, SceneError, View
from .options import Backend

__all__ = [
    "reprojection_matches",
    "flow_matches",
    "sift_matches",
    "subsample_matches",
    "ReprojectionMatcher",
    "FlowMatcher",
    "SiftMatcher",
]


def subsample_matches(m: Matches, n: int | None, *, rng: Any = None) -> Matches:
    """Keep the ``n`` most certain matches; equal certainties are ordered at random.

    Examples
    --------
    >>> m = Matches(np.zeros((5, 2)), np.zeros((5, 2)), np.ones(5))
    >>> len(subsample_matches(m, 3, rng=0))
    3
    """
    if n is None or len(m) <= n:
        return m
    gen = np.random.default_rng(rng)
    key = m.certainty.astype(np.float64) + gen.uniform(0, 1e-6, len(m))
    idx = np.argpartition(-key, n - 1)[:n]
    idx = np.sort(idx)
    return Matches(m.xy_i[idx], m.xy_j[idx], m.certainty[idx])


def reprojection_matches(
    view_i: View,
    view_j: View,
    *,
    abs_tol: float,
    rel_tol: float,
    stride: int,
    mask_i: np.ndarray | None = None,
) -> Matches:
    """Dense matches by projecting view i's world points into view j.

    Parameters
    ----------
    view_i, view_j : View
        Need ``points`` (view i), ``K`` and ``cam_to_world`` (view j), and depth or
        points for view j's visibility test.
    abs_tol, rel_tol, stride
        Required; the defaults are those of :class:`ReprojectionMatcher.Options`.
    abs_tol, rel_tol : float
        A projected point is visible when ``|z_proj - depth_j| <= abs_tol + rel_tol * z_proj``.
    stride : int
        Use every ``stride``-th pixel of view i.
    mask_i : bool ``[H, W]``, optional
        Only pixels of view i where this holds.

    Returns
    -------
    Matches
        ``xy_i`` are integer pixel centres of view i; ``xy_j`` the subpixel
        projections; certainty ``1 - |dz| / tol`` in ``(0, 1]``.

    Notes
    -----
    O(H W), fully vectorized.
    """
    if view_i.points is None:
        raise SceneError("reprojection needs a point map", where=view_i.name, field="points")
    if view_j.K is None or view_j.cam_to_world is None:
        raise SceneError("reprojection needs K and cam_to_world", where=view_j.name, field="K" if view_j.K is None else "cam_to_world")
    P = np.asarray(view_i.points, np.float32)[::stride, ::stride]
    h, w = P.shape[:2]
    ys, xs = np.mgrid[0:h, 0:w]
    xs, ys = xs * stride, ys * stride
    ok = np.isfinite(P).all(-1)
    if mask_i is not None:
        ok &= np.asarray(mask_i, bool)[::stride, ::stride]
    P, xs, ys = P[ok].astype(np.float64), xs[ok], ys[ok]
    T = np.asarray(view_j.cam_to_world, np.float64)
    K = np.asarray(view_j.K, np.float64)
    cam = (P - T[:3, 3]) @ T[:3, :3]
    z = cam[:, 2]
    front = z > 1e-6
    cam, z, xs, ys = cam[front], z[front], xs[front], ys[front]
    u = K[0, 0] * cam[:, 0] / z + K[0, 1] * cam[:, 1] / z + K[0, 2]
    v = K[1, 1] * cam[:, 1] / z + K[1, 2]
    H, W = view_j.shape
    ui, vi = np.rint(u).astype(np.int64), np.rint(v).astype(np.int64)
    inside = (ui >= 0) & (ui < W) & (vi >= 0) & (vi < H)
    u, v, ui, vi, z, xs, ys = u[inside], v[inside], ui[inside], vi[inside], z[inside], xs[inside], ys[inside]
    dj = view_j.z_depth()[vi, ui]
    tol = abs_tol + rel_tol * z
    dz = np.abs(z - dj)
    vis = np.isfinite(dj) & (dz <= tol)
    cert = 1.0 - dz[vis] / tol[vis]
    return Matches(
        np.stack([xs[vis], ys[vis]], 1).astype(np.float32),
        np.stack([u[vis], v[vis]], 1).astype(np.float32),
        np.clip(cert, 1e-3, 1.0).astype(np.float32),
    )


def _gray(rgb: np.ndarray) -> np.ndarray:
    import cv2

    return cv2.cvtColor(np.ascontiguousarray(rgb), cv2.COLOR_RGB2GRAY)


def flow_matches(view_i: View, view_j: View, *, max_fb_error: float, stride: int) -> Matches:
    """Dense matches from OpenCV DIS optical flow, certainty from forward-backward consistency.

    Parameters
    ----------
    view_i, view_j : View
        RGB only.
    max_fb_error : float
        Pixels; matches whose forward-backward flow misses by more are dropped.
    stride : int
        Use every ``stride``-th pixel of view i.

    Both options are required; the defaults are those of :class:`FlowMatcher.Options`.

    Returns
    -------
    Matches

    Notes
    -----
    Needs only RGB. Works for small baselines; wide baselines break optical flow.
    """
    import cv2

    gi, gj = _gray(view_i.rgb), _gray(view_j.rgb)
    if gi.shape != gj.shape:
        gj = cv2.resize(gj, (gi.shape[1], gi.shape[0]))
    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)  # type: ignore[attr-defined]
    fwd = dis.calc(gi, gj, None)
    bwd = dis.calc(gj, gi, None)
    h, w = gi.shape
    ys, xs = np.mgrid[0:h:stride, 0:w:stride]
    f = fwd[ys, xs]
    xj, yj = xs + f[..., 0], ys + f[..., 1]
    inside = (xj >= 0) & (xj <= w - 1) & (yj >= 0) & (yj <= h - 1)
    b = cv2.remap(bwd, xj.astype(np.float32), yj.astype(np.float32), cv2.INTER_LINEAR)
    err = np.hypot(f[..., 0] + b[..., 0], f[..., 1] + b[..., 1])
    ok = inside & (err <= max_fb_error)
    cert = np.exp(-err[ok] / max(max_fb_error, 1e-6))
    return Matches(np.stack([xs[ok], ys[ok]], 1), np.stack([xj[ok], yj[ok]], 1), cert)


def sift_matches(view_i: View, view_j: View, *, ratio: float, ransac_threshold: float) -> Matches:
    """Sparse SIFT matches: Lowe ratio test, then ``cv2.USAC_MAGSAC`` fundamental-matrix verification.

    Parameters
    ----------
    view_i, view_j : View
        RGB only.
    ratio : float
        Lowe's ratio test: the best match must be closer than ``ratio`` times the second best.
    ransac_threshold : float
        Pixels; the epipolar distance of an inlier.

    Both options are required; the defaults are those of :class:`SiftMatcher.Options`.

    Returns
    -------
    Matches
        Empty when fewer than 8 matches pass the ratio test.

    Notes
    -----
    O(K_i K_j) descriptor comparisons for ``K`` keypoints per view.
    """
    import cv2

    sift = cv2.SIFT_create()  # type: ignore[attr-defined]
    ki, di = sift.detectAndCompute(_gray(view_i.rgb), None)
    kj, dj = sift.detectAndCompute(_gray(view_j.rgb), None)
    empty = Matches(np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0))
    if di is None or dj is None or len(ki) < 2 or len(kj) < 2:
        return empty
    knn = cv2.BFMatcher(cv2.NORM_L2).knnMatch(di, dj, k=2)
    good = [m[0] for m in knn if len(m) == 2 and m[0].distance < ratio * m[1].distance]
    if len(good) < 8:
        return empty
    pi = np.array([ki[m.queryIdx].pt for m in good], np.float32)
    pj = np.array([kj[m.trainIdx].pt for m in good], np.float32)
    dist = np.array([m.distance for m in good], np.float32)
    _, inl = cv2.findFundamentalMat(pi, pj, cv2.USAC_MAGSAC, ransac_threshold, 0.999, 10000)
    if inl is None:
        return empty
    keep = inl.ravel().astype(bool)
    cert = 1.0 - dist[keep] / max(float(dist.max()), 1e-6)
    return Matches(pi[keep], pj[keep], np.clip(cert, 1e-3, 1.0))


class _MatcherOptions(BaseModel):
    """The run-wide settings every built-in matcher takes (filled from the config when unset)."""

    model_config = ConfigDict(extra="forbid")
    num_matches: int | None = Field(10_000, ge=1, description="matches kept per pair, most certain first (None: all)")
    seed: int | None = Field(0, description="breaks certainty ties at random (None: fresh entropy)")


class ReprojectionMatcher(Backend):
    """The ``reprojection`` matcher (see :func:`reprojection_matches`)."""

    name = "reprojection"

    class Options(_MatcherOptions):
        abs_tol: float = Field(0.005, ge=0, description="metres")
        rel_tol: float = Field(0.01, ge=0, description="fraction of the projected depth")
        stride: int = Field(1, ge=1, description="use every stride-th pixel of view i")

    def __call__(self, view_i: View, view_j: View) -> Matches:
        o = self.options
        m = reprojection_matches(view_i, view_j, abs_tol=o.abs_tol, rel_tol=o.rel_tol, stride=o.stride)
        return subsample_matches(m, o.num_matches, rng=o.seed)


class FlowMatcher(Backend):
    """The ``flow`` matcher (see :func:`flow_matches`)."""

    name = "flow"

    class Options(_MatcherOptions):
        max_fb_error: float = Field(1.0, gt=0, description="pixels")
        stride: int = Field(2, ge=1, description="use every stride-th pixel of view i")

    def __call__(self, view_i: View, view_j: View) -> Matches:
        o = self.options
        return subsample_matches(flow_matches(view_i, view_j, max_fb_error=o.max_fb_error, stride=o.stride), o.num_matches, rng=o.seed)


class SiftMatcher(Backend):
    """The ``sift`` matcher (see :func:`sift_matches`)."""

    name = "sift"

    class Options(_MatcherOptions):
        ratio: float = Field(0.8, gt=0, le=1, description="Lowe's ratio test")
        ransac_threshold: float = Field(1.5, gt=0, description="pixels")

    def __call__(self, view_i: View, view_j: View) -> Matches:
        o = self.options
        m = sift_matches(view_i, view_j, ratio=o.ratio, ransac_threshold=o.ransac_threshold)
        return subsample_matches(m, o.num_matches, rng=o.seed)
