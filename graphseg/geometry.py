"""Geometry shared by the method and the backends: plane fitting and surface normals.

Examples
--------
>>> import numpy as np
>>> rng = np.random.default_rng(0)
>>> pts = np.c_[rng.uniform(-1, 1, (500, 2)), np.zeros(500)]  # the plane z = 0
>>> normal, offset, inliers = fit_plane_ransac(pts, threshold=0.01, rng=0)
>>> np.round(np.abs(normal), 3).tolist(), round(abs(offset), 6), int(inliers.sum())
([0.0, 0.0, 1.0], 0.0, 500)
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["fit_plane_ransac", "point_normals"]


def point_normals(points: np.ndarray, step: int = 2) -> np.ndarray:
    """Unit surface normals ``[H, W, 3]`` of a point map (NaN where unknown).

    Central differences over ``step`` pixels. At a depth edge the difference
    spans both surfaces, so the normal there matches neither: pixels at the
    foot of an object are not mistaken for table. Pixels within ``step`` of
    the border are NaN. O(H W).

    Examples
    --------
    >>> ys, xs = np.mgrid[0:5, 0:5].astype(np.float32)
    >>> plane = np.stack([xs, ys, np.zeros_like(xs)], -1)
    >>> np.abs(point_normals(plane, 1)[2, 2]).tolist()
    [0.0, 0.0, 1.0]
    """
    p = np.asarray(points, np.float32)
    if p.ndim != 3 or p.shape[-1] != 3:
        raise ValueError(f"expected points of shape [H, W, 3] (got {list(p.shape)})")
    if int(step) < 1:
        raise ValueError(f"expected step >= 1 (got {step})")
    h, w = p.shape[:2]
    out = np.full(p.shape, np.nan, np.float32)
    if w > 2 * step and h > 2 * step:  # only interior pixels have both differences
        dx = p[step:-step, 2 * step :] - p[step:-step, : -2 * step]
        dy = p[2 * step :, step:-step] - p[: -2 * step, step:-step]
        n = np.empty_like(dx)  # dx x dy, written out (np.cross copies its inputs)
        n[..., 0] = dx[..., 1] * dy[..., 2] - dx[..., 2] * dy[..., 1]
        n[..., 1] = dx[..., 2] * dy[..., 0] - dx[..., 0] * dy[..., 2]
        n[..., 2] = dx[..., 0] * dy[..., 1] - dx[..., 1] * dy[..., 0]
        norm = np.sqrt(np.einsum("...i,...i->...", n, n))[..., None]
        with np.errstate(invalid="ignore", divide="ignore"):
            out[step:-step, step:-step] = n / norm
    return out


def fit_plane_ransac(
    points: np.ndarray,
    *,
    threshold: float = 0.01,
    iterations: int = 256,
    rng: Any = None,
    block: int = 64,
) -> tuple[np.ndarray, float, np.ndarray]:
    """Fit a plane ``n . x + d = 0`` (unit ``n``) by RANSAC, then least squares on the inliers.

    Parameters
    ----------
    points : float ``[P, 3]``
        Finite points.
    threshold : float
        Inlier distance.
    iterations : int
        Hypotheses (each from 3 random points), scored in blocks.
    rng : None, int or Generator, keyword-only

    Returns
    -------
    normal : float64 ``[3]``
    offset : float
    inliers : bool ``[P]``

    Raises
    ------
    ValueError
        With fewer than 3 points.

    Notes
    -----
    O(iterations x P) distance evaluations, vectorized in blocks of hypotheses.
    """
    p = np.asarray(points, np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"expected points of shape [P, 3] (got {list(p.shape)})")
    if len(p) < 3:
        raise ValueError(f"RANSAC needs at least 3 points (got {len(p)})")
    gen = np.random.default_rng(rng)
    idx = gen.integers(0, len(p), (iterations, 3))
    a, b, c = p[idx[:, 0]], p[idx[:, 1]], p[idx[:, 2]]
    n = np.cross(b - a, c - a)
    norm = np.linalg.norm(n, axis=1)
    ok = norm > 1e-12
    n = n[ok] / norm[ok, None]
    d = -np.einsum("ij,ij->i", n, a[ok])
    best, best_count = -1, -1
    for s in range(0, len(n), block):
        dist = np.abs(p @ n[s : s + block].T + d[s : s + block])
        counts = (dist <= threshold).sum(0)
        k = int(np.argmax(counts)) if counts.size else -1
        if k >= 0 and counts[k] > best_count:
            best, best_count = s + k, int(counts[k])
    if best < 0:
        raise ValueError("RANSAC found no plane (all samples degenerate)")
    normal, offset = n[best], float(d[best])
    inliers = np.abs(p @ normal + offset) <= threshold
    if inliers.sum() >= 3:  # least-squares refinement on the inliers
        q = p[inliers]
        centroid = q.mean(0)
        _, _, vt = np.linalg.svd(q - centroid, full_matrices=False)
        normal = vt[-1]
        offset = float(-normal @ centroid)
        inliers = np.abs(p @ normal + offset) <= threshold
    return normal, offset, inliers
