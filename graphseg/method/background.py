"""The background class: the table plane, what lies beyond it, and what is far away.

The table plane is fitted by RANSAC on the views' world point maps (no model
needed). A pixel is background when its point lies within ``plane_tolerance``
of the plane, on the far side of the plane from the cameras (floor, table
legs), farther from its camera than ``max_distance``, or (``beyond_table``)
when its foot on the plane lies outside the table's outline: the convex hull of
the largest connected patch of plane points, grown by ``table_margin`` of its
size. The outline is measured in units of the table itself, so it holds
whatever the scale of the points (metric or not). Background is one class; it
never becomes an object.

Examples
--------
>>> import numpy as np
>>> ys, xs = np.mgrid[0:20, 0:20] / 20.0
>>> table = np.dstack([xs, ys, np.zeros_like(xs)]).astype(np.float32)
>>> table[8:12, 8:12, 2] = 0.1                       # a small box on the table
>>> bg, info = background_masks([table], [np.array([0.5, 0.5, 1.0])], rng=0)
>>> bool(bg[0][0, 0]), bool(bg[0][10, 10]), info.plane is not None
(True, False, True)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..config import BackgroundConfig
from ..geometry import fit_table_plane, point_normals

# fit_table_plane (now in geometry: the geometric segmenter uses it too) stays importable from here
__all__ = ["background_masks", "fit_table_plane", "table_outline", "TableOutline", "BackgroundInfo"]


@dataclass
class BackgroundInfo:
    """What the background step found."""

    plane: tuple[float, float, float, float] | None = None
    max_distance: float | None = None
    fraction: list[float] = field(default_factory=list)
    outline: TableOutline | None = None
    beyond_table: list[float] = field(default_factory=list)


def _plane_basis(normal: np.ndarray) -> np.ndarray:
    """Two orthonormal vectors ``[2, 3]`` spanning the plane with unit ``normal``."""
    n = np.asarray(normal, np.float64)
    a = np.eye(3)[int(np.argmin(np.abs(n)))]
    u = np.cross(n, a)
    u /= np.linalg.norm(u)
    return np.stack([u, np.cross(n, u)])


@dataclass
class TableOutline:
    """The table's outline on its plane: a filled convex polygon on a grid.

    Attributes
    ----------
    basis : float64 ``[2, 3]``
        Plane coordinates of a point ``x`` are ``basis @ x``.
    origin : float64 ``[2]``
        Plane coordinates of the grid's corner.
    cell : float
        Grid cell size (in the points' units).
    inside : bool ``[Gy, Gx]``
        Cells inside the grown outline.
    """

    basis: np.ndarray
    origin: np.ndarray
    cell: float
    inside: np.ndarray

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Whether the foot on the plane of each point ``[P, 3]`` lies inside the outline (bool ``[P]``)."""
        uv = (np.asarray(points, np.float64) @ self.basis.T - self.origin) / self.cell
        ij = np.floor(uv).astype(np.int64)
        gy, gx = self.inside.shape
        ok = (ij[:, 0] >= 0) & (ij[:, 0] < gx) & (ij[:, 1] >= 0) & (ij[:, 1] < gy)
        out = np.zeros(len(ij), bool)
        out[ok] = self.inside[ij[ok, 1], ij[ok, 0]]
        return out


def table_outline(plane_points: np.ndarray, normal: np.ndarray, *, margin: float = 0.05, grid: int | None = None) -> TableOutline | None:
    """The outline of the table from points on its plane.

    The points' plane coordinates are binned on a ``grid x grid`` raster over
    their 0.5-99.5 percentile range (by default ``sqrt(P / 8)`` cells a side,
    clipped to 8..128, so that a cell holds about 8 points); the largest 8-connected patch of occupied
    cells (after a 3x3 closing, which bridges the gaps of sparse points) is the
    table, and its convex hull, grown by ``margin`` of the patch's larger side,
    is the outline. Other patches (a floor or a shelf at the same height) stay
    outside. Everything is in units of the table, so the rule does not depend
    on the scale of the points.

    Parameters
    ----------
    plane_points : float ``[P, 3]``
        Points on the table plane (finite).
    normal : float ``[3]``
        The plane's unit normal.
    margin : float, keyword-only
        Growth as a fraction of the outline's size.
    grid : int, optional, keyword-only
        Raster resolution (cells along the larger side).

    Returns
    -------
    TableOutline or None
        None with fewer than 3 points or a degenerate (collinear) patch.

    Notes
    -----
    O(P + grid^2).

    Examples
    --------
    >>> g = np.random.default_rng(0).uniform(-1, 1, (4000, 2))
    >>> table = np.c_[g, np.zeros(4000)]
    >>> out = table_outline(table, np.array([0, 0, 1.0]))
    >>> out.contains(np.array([[0.0, 0.0, 0.3], [0.98, -0.98, 0.1], [1.6, 0.0, 0.2]])).tolist()
    [True, True, False]
    """
    import cv2
    from scipy import ndimage

    pts = np.asarray(plane_points, np.float64).reshape(-1, 3)
    if len(pts) < 3:
        return None
    basis = _plane_basis(normal)
    uv = pts @ basis.T
    lo, hi = np.percentile(uv, 0.5, axis=0), np.percentile(uv, 99.5, axis=0)
    side = float(np.max(hi - lo))
    if not side > 0:
        return None
    if grid is None:
        grid = int(np.clip(np.sqrt(len(pts) / 8), 8, 128))
    cell = side / grid
    pad = int(np.ceil(margin * grid)) + 2
    origin = lo - pad * cell
    shape = (int(np.ceil((hi[1] - lo[1]) / cell)) + 1 + 2 * pad, int(np.ceil((hi[0] - lo[0]) / cell)) + 1 + 2 * pad)
    ij = np.floor((uv - origin) / cell).astype(np.int64)
    ok = (ij[:, 0] >= 0) & (ij[:, 0] < shape[1]) & (ij[:, 1] >= 0) & (ij[:, 1] < shape[0])
    occ = np.zeros(shape, bool)
    occ[ij[ok, 1], ij[ok, 0]] = True
    occ = ndimage.binary_closing(occ, structure=np.ones((3, 3), bool))
    comp, n = ndimage.label(occ, structure=np.ones((3, 3), bool))
    if n == 0:
        return None
    sizes = np.bincount(comp.ravel())[1:]
    ys, xs = np.nonzero(comp == int(np.argmax(sizes)) + 1)
    cells = np.stack([xs, ys], 1).astype(np.int32)
    span = int(max(np.ptp(xs), np.ptp(ys))) + 1
    if min(np.ptp(xs), np.ptp(ys)) == 0:
        return None
    hull = cv2.convexHull(cells)
    filled = np.zeros(shape, np.uint8)
    cv2.fillConvexPoly(filled, hull, 1)
    grow = int(round(margin * span))
    if grow > 0:
        filled = np.asarray(cv2.dilate(filled, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * grow + 1, 2 * grow + 1))))
    return TableOutline(basis, origin, cell, filled.astype(bool))


def _subsample(idx: list[np.ndarray], counts: list[int], size: int, gen: np.random.Generator) -> list[np.ndarray]:
    """At most ``size`` of the indices in total, drawn uniformly, split per view (sorted)."""
    total = sum(counts)
    if total <= size:
        return idx
    pick = np.sort(gen.choice(total, size=size, replace=False))
    bounds = np.cumsum([0, *counts])
    return [i[pick[(pick >= lo) & (pick < hi)] - lo] for i, lo, hi in zip(idx, bounds[:-1], bounds[1:])]


def background_masks(
    points: Sequence[np.ndarray],
    cam_centers: Sequence[np.ndarray] | None,
    config: BackgroundConfig | None = None,
    *,
    rng: Any = None,
) -> tuple[list[np.ndarray], BackgroundInfo]:
    """Per-view boolean background masks ``[H, W]``.

    Parameters
    ----------
    points : list of float ``[H, W, 3]``
        World point maps (NaN = invalid).
    cam_centers : list of ``[3]`` or None
        Camera positions: orient the plane (cameras on its positive side) and
        measure distances. Without them only the plane band is used.
    config : BackgroundConfig
    rng : seed for RANSAC

    Returns
    -------
    masks : list of bool ``[H, W]``
        True = background. Invalid points are never background.
    info : BackgroundInfo
        The plane ``(nx, ny, nz, d)`` and the distance limit used.

    Notes
    -----
    The plane (RANSAC on ``ransac_sample`` points) and the median camera
    distance are estimated on a random subsample of at most ``4 x
    ransac_sample`` valid pixels drawn over all views; then O(H W) per view.
    """
    cfg = config or BackgroundConfig()
    info = BackgroundInfo()
    shapes = [p.shape[:2] for p in points]
    if not cfg.enabled:
        return [np.zeros(s, bool) for s in shapes], info
    gen = np.random.default_rng(rng)
    flat = [np.asarray(p, np.float32).reshape(-1, 3) for p in points]
    valid = [np.isfinite(f).all(1) for f in flat]
    counts = [int(v.sum()) for v in valid]
    total = sum(counts)
    bg = [np.zeros(f.shape[0], bool) for f in flat]
    if total == 0:
        return [b.reshape(s) for b, s in zip(bg, shapes)], info
    # estimates (plane, median distance) use a random subsample of the valid pixels
    idx = [np.flatnonzero(v) for v in valid]
    pool = _subsample(idx, counts, 4 * cfg.ransac_sample, gen)
    plane = fit_table_plane(flat, pool, cam_centers, cfg, rng=gen) if cfg.plane and total >= 3 else None
    if plane is not None:
        info.plane = (float(plane[0][0]), float(plane[0][1]), float(plane[0][2]), float(plane[1]))
    max_dist = None
    if cam_centers is not None and cfg.max_distance is not None:
        if cfg.max_distance == "auto":
            meds = []
            for f, i, c in zip(flat, pool, cam_centers):
                if i.size:
                    meds.append(float(np.median(np.linalg.norm(f[i] - np.asarray(c, np.float32), axis=1))))
            max_dist = cfg.auto_distance_factor * float(np.median(meds)) if meds else None
        else:
            max_dist = float(cfg.max_distance)
        info.max_distance = max_dist
    cos_max = None if cfg.plane_normal_angle is None else float(np.cos(cfg.plane_normal_angle))
    outline = None
    if plane is not None and cfg.beyond_table:
        sample = np.concatenate([f[i] for f, i in zip(flat, pool)]).astype(np.float64)
        on = np.abs(sample @ plane[0] + plane[1]) <= cfg.plane_tolerance
        outline = table_outline(sample[on], plane[0], margin=cfg.table_margin)
        info.outline = outline
    for k, (f, i) in enumerate(zip(flat, idx)):
        pv = f[i].astype(np.float64)
        b = np.zeros(len(pv), bool)
        if plane is not None:
            sd = pv @ plane[0] + plane[1]
            band = np.abs(sd) <= cfg.plane_tolerance
            if outline is not None:
                beyond = ~outline.contains(pv)
                info.beyond_table.append(float(beyond.mean()) if beyond.size else 0.0)
                b |= beyond
            if cos_max is not None and band.any():
                nrm = point_normals(np.asarray(points[k], np.float32), cfg.normal_step).reshape(-1, 3)[i[band]]
                cos = np.abs(nrm @ plane[0].astype(np.float32))
                band[band] = ~(cos < cos_max)  # unknown normals (NaN) count as plane
            b |= band
            if cfg.below_plane and cam_centers is not None:
                b |= sd < -cfg.plane_tolerance
        if max_dist is not None and cam_centers is not None:
            d = pv - np.asarray(cam_centers[k], np.float64)
            b |= np.einsum("ij,ij->i", d, d) > max_dist * max_dist
        bg[k][i] = b
    out = [b.reshape(s) for b, s in zip(bg, shapes)]
    info.fraction = [float(m.mean()) for m in out]
    return out, info
