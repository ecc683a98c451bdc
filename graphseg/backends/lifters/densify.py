"""Fill depth holes region by region: colour superpixels, one plane (in inverse depth) per region.

Stereo leaves holes on untextured surfaces and at occlusions, and views with
no close neighbour only have the sparse SfM points. Inside one colour
superpixel (Felzenszwalb) the surface is taken as a plane: inverse depth is
then affine in the pixel coordinates, ``1 / z = a u + b v + c``, fitted by
least squares to the region's known pixels. Regions with fewer than
``min_points`` distinct known pixels, or a degenerate fit, get the median
depth of their points; regions with none stay unknown. Predicted depths are
clipped to the range of the region's known depths (with ``margin``).

Examples
--------
>>> import numpy as np
>>> z = np.full((4, 6), np.nan, np.float32)
>>> z[0, 0], z[0, 5], z[3, 0] = 1.0, 1.0, 1.0
>>> out = fill_depth_by_regions(z, np.zeros((4, 6), np.int64))
>>> np.isfinite(out).all(), float(out[2, 3])
(np.True_, 1.0)
"""

from __future__ import annotations

import numpy as np

__all__ = ["fill_depth_by_regions", "color_regions"]


def color_regions(rgb: np.ndarray, *, scale: float = 100.0, min_size: int = 60) -> np.ndarray:
    """Felzenszwalb superpixels ``[H, W]`` int64 (``scale`` and ``min_size`` given for 640 x 480, scaled with the area)."""
    from skimage.segmentation import felzenszwalb

    area = rgb.shape[0] * rgb.shape[1] / (640 * 480)
    return felzenszwalb(np.asarray(rgb), scale=scale, sigma=0.8, min_size=max(4, int(min_size * area))).astype(np.int64)


def fill_depth_by_regions(depth: np.ndarray, regions: np.ndarray, *, min_points: int = 6, margin: float = 0.1, replace: bool = False) -> np.ndarray:
    """A copy of ``depth`` ``[H, W]`` (NaN = unknown) with unknown pixels filled per region.

    Parameters
    ----------
    depth : float ``[H, W]``
        z-depth, NaN or <= 0 where unknown.
    regions : int ``[H, W]``
        Region id per pixel (>= 0).
    min_points : int
        Known pixels a region needs for a plane fit (else its median depth).
    replace : bool
        Also replace the known pixels of every region with a plane fit by the
        fitted plane (a piecewise-planar depth map whose edges follow colour edges).
    margin : float
        Filled depths are clipped to ``[(1 - margin) min, (1 + margin) max]`` of
        the region's known depths.

    Returns
    -------
    float32 ``[H, W]``
        Known pixels unchanged.

    Notes
    -----
    O(H W): per-region normal equations by ``bincount``, one batched 3 x 3 solve.
    """
    z = np.asarray(depth, np.float64)
    lab = np.asarray(regions, np.int64)
    if z.shape != lab.shape:
        raise ValueError(f"expected depth and regions of one shape [H, W] (got {list(z.shape)} and {list(lab.shape)})")
    h, w = z.shape
    k = int(lab.max()) + 1 if lab.size else 0
    known = np.isfinite(z) & (z > 0)
    out = np.where(known, z, np.nan)
    if k == 0 or not known.any():
        return out.astype(np.float32)
    v, u = np.mgrid[0:h, 0:w]
    u = (u - w / 2) / w  # conditioned coordinates
    v = (v - h / 2) / w
    L, U, V, Wi = lab[known], u[known], v[known], 1.0 / z[known]
    n = np.bincount(L, minlength=k).astype(np.float64)

    def s(x: np.ndarray) -> np.ndarray:
        return np.bincount(L, weights=x, minlength=k)

    A = np.stack([np.stack([s(U * U), s(U * V), s(U)], -1), np.stack([s(U * V), s(V * V), s(V)], -1), np.stack([s(U), s(V), n], -1)], 1)
    b = np.stack([s(U * Wi), s(V * Wi), s(Wi)], -1)
    det = np.abs(np.linalg.det(A))
    fit = (n >= min_points) & (det > 1e-12 * np.maximum(n, 1) ** 3)
    coef = np.zeros((k, 3))
    if fit.any():
        coef[fit] = np.linalg.solve(A[fit], b[fit][..., None])[..., 0]
    zmin = np.full(k, np.inf)
    zmax = np.zeros(k)
    np.minimum.at(zmin, L, z[known])
    np.maximum.at(zmax, L, z[known])
    order = np.argsort(L, kind="stable")
    zs = z[known][order]
    starts = np.r_[0, np.cumsum(n.astype(np.int64))[:-1]]
    med = np.full(k, np.nan)
    has = n > 0
    for r in np.nonzero(has)[0]:
        med[r] = np.median(zs[starts[r] : starts[r] + int(n[r])])
    hole = (~known | fit[lab]) & has[lab] if replace else ~known & has[lab]
    lh = lab[hole]
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = coef[lh, 0] * u[hole] + coef[lh, 1] * v[hole] + coef[lh, 2]
        pred = np.where(fit[lh] & (inv > 0), 1.0 / inv, med[lh])
    pred = np.clip(pred, (1 - margin) * zmin[lh], (1 + margin) * zmax[lh])
    out[hole] = pred
    return out.astype(np.float32)
