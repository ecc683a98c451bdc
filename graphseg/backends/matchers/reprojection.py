"""The ``reprojection`` matcher: exact matches when 3D is known (the weight-free stand-in for RoMa).

Every pixel's world point is projected into the other view and kept where the
other view's depth agrees (visibility test); certainty falls off with the
depth disagreement. Like every matcher it keeps up to ``num_matches`` matches
by certainty (:func:`~graphseg.backends.matchers.sampling.subsample_matches`,
ties broken at random). Its ``Options`` hold the defaults, and
:func:`reprojection_matches` takes every option as a required keyword.

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
from pydantic import Field

from ...scene import Matches, SceneError, View
from ..imaging import to_lab, view_rgb
from ..options import Backend
from .sampling import MatcherOptions, subsample_matches

__all__ = ["reprojection_matches", "lab_image", "ReprojectionMatcher"]


def reprojection_matches(
    view_i: View,
    view_j: View,
    *,
    abs_tol: float,
    rel_tol: float,
    stride: int,
    max_color_distance: float | None,
    color_blur: float,
    mask_i: np.ndarray | None = None,
    lab: tuple[np.ndarray, np.ndarray] | None = None,
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
    max_color_distance : float, optional
        Photometric consistency: drop a match whose two pixels differ by more
        than this CIE Lab distance after a Gaussian blur of ``color_blur``
        pixels (None: no colour test). Estimated point maps (structure from
        motion) put some pixels on the wrong surface, and their reprojections
        land on another object; the colour test removes most of those.
    color_blur : float
        Sigma of the blur before the colour test, in pixels (0: none).
    mask_i : bool ``[H, W]``, optional
        Only pixels of view i where this holds.
    lab : (uint8 ``[H, W, 3]``, uint8 ``[H, W, 3]``), optional
        Both views' blurred Lab images (:func:`lab_image`), when the caller
        already has them; computed here otherwise.

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
    if max_color_distance is not None:
        lab_i, lab_j = lab if lab is not None else (lab_image(view_i, color_blur), lab_image(view_j, color_blur))
        a = lab_i[ys[vis], xs[vis]].astype(np.float32)
        b = lab_j[vi[vis], ui[vis]].astype(np.float32)
        vis[vis] = np.linalg.norm(a - b, axis=1) <= max_color_distance
    cert = 1.0 - dz[vis] / tol[vis]
    return Matches(
        np.stack([xs[vis], ys[vis]], 1).astype(np.float32),
        np.stack([u[vis], v[vis]], 1).astype(np.float32),
        np.clip(cert, 1e-3, 1.0).astype(np.float32),
    )


def lab_image(view: View, blur: float) -> np.ndarray:
    """The view's image in CIE Lab, uint8 ``[H, W, 3]`` (OpenCV's 8-bit scaling), after a Gaussian blur of ``blur`` pixels (0: none). O(H W)."""
    return to_lab(view_rgb(view), blur)


class ReprojectionMatcher(Backend):
    """The ``reprojection`` matcher (see :func:`reprojection_matches`)."""
    parallel = True  # weight-free: views (pairs) may run in worker processes

    name = "reprojection"

    class Options(MatcherOptions):
        abs_tol: float = Field(0.005, ge=0, description="metres")
        rel_tol: float = Field(0.01, ge=0, description="fraction of the projected depth")
        stride: int = Field(1, ge=1, description="use every stride-th pixel of view i")
        max_color_distance: float | None = Field(None, gt=0, description="CIE Lab distance above which a match is dropped (None: no colour test)")
        color_blur: float = Field(2.0, ge=0, description="pixels of Gaussian blur before the colour test")

    def __init__(self, options: Any = None, /, **kwargs: Any) -> None:
        super().__init__(options, **kwargs)
        self._lab_cache: dict[str, tuple[Any, np.ndarray]] = {}  # view name -> (its rgb array, lab_image)

    def __call__(self, view_i: View, view_j: View) -> Matches:
        o = self.options
        lab = None if o.max_color_distance is None else (self._lab(view_i), self._lab(view_j))
        m = reprojection_matches(
            view_i, view_j, abs_tol=o.abs_tol, rel_tol=o.rel_tol, stride=o.stride, max_color_distance=o.max_color_distance, color_blur=o.color_blur, lab=lab
        )
        return subsample_matches(m, o.num_matches, rng=o.seed)

    def _lab(self, view: View) -> np.ndarray:
        """:func:`lab_image` once per view image: each view is in several pairs (cache keyed by name, checked by identity, up to 64 views)."""
        cache = self._lab_cache
        hit = cache.get(view.name)
        if hit is not None and hit[0] is view.rgb:
            return hit[1]
        if len(cache) >= 64:
            cache.pop(next(iter(cache)))
        out = cache[view.name] = (view.rgb, lab_image(view, self.options.color_blur))
        return out[1]
