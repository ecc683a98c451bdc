"""The ``convexity`` segmenter: ``geometric`` segments, cut again along concave creases.

Objects that touch (a box on a box, a can against a block) often meet without
a depth jump or a colour edge, but always at a *concave* crease, while the
surface of one (convex) object only folds convexly. This segmenter runs the
weight-free ``geometric`` segmenter, marks every pixel where the surface folds
concavely towards a neighbour (LCCP's test on camera-frame normals:
``(n_p - n_q) . (x_p - x_q) / |x_p - x_q| < -threshold``), removes those
pixels from the segments, splits each segment into its connected pieces and
gives the crease pixels back to the nearest piece.

The defaults live in :class:`ConvexitySegmenter.Options`; the pure functions
take every option as a required keyword.

Examples
--------
>>> import numpy as np
>>> ys, xs = np.mgrid[0:40, 0:40].astype(np.float32)
>>> x, y = (xs - 19.5) * 0.002, (ys - 20) * 0.002
>>> valley = np.stack([x, y, 0.5 - 0.5 * np.abs(x)], -1)      # two planes meeting in a concave crease
>>> seg = np.zeros((40, 40), np.int32); seg[8:32] = 1          # away from the borders (no normals there)
>>> out = split_concave(seg, valley, threshold=0.2, normal_step=4, reach=3, min_area=200)
>>> sorted(np.unique(out).tolist()), bool(out[20, 5] != out[20, 34])
([0, 1, 2], True)
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from ...geometry import point_normals
from ...scene import SceneError, View
from ..options import Backend
from .geometric import GeometricOptions, geometric_segments

__all__ = ["concave_creases", "split_concave", "ConvexitySegmenter"]


def concave_creases(points: np.ndarray, *, threshold: float, normal_step: int, reach: int) -> np.ndarray:
    """Pixels where the surface folds concavely (bool ``[H, W]``).

    Parameters
    ----------
    points : float ``[H, W, 3]``
        Camera-frame points (OpenCV convention: x right, y down, z forward),
        NaN = invalid.
    threshold : float
        A pixel pair ``reach`` pixels apart along a row or column is concave
        below ``-threshold`` (about twice the sine of half the fold angle).
    normal_step : int
        Pixel step of the central differences for the normals.
    reach : int
        Pixel distance of the compared pairs (larger = less noise, thicker creases).

    Returns
    -------
    numpy.ndarray
        bool ``[H, W]``; both pixels of a concave pair are marked. O(H W).

    Examples
    --------
    >>> concave_creases(np.zeros((4, 4, 3), np.float32), threshold=0.2, normal_step=4, reach=3).any()
    np.False_
    """
    p = np.asarray(points, np.float32)
    if p.ndim != 3 or p.shape[2] != 3:
        raise ValueError(f"expected points of shape [H, W, 3] (got {list(p.shape)})")
    n = -point_normals(p, normal_step)  # towards the camera
    out = np.zeros(p.shape[:2], bool)
    r = int(reach)
    for sl_a, sl_b in (((slice(None), slice(None, -r)), (slice(None), slice(r, None))), ((slice(None, -r), slice(None)), (slice(r, None), slice(None)))):
        d = p[sl_a] - p[sl_b]
        dist = np.linalg.norm(d, axis=-1)
        with np.errstate(invalid="ignore", divide="ignore"):
            conv = np.einsum("...k,...k->...", n[sl_a] - n[sl_b], d) / dist
        bad = conv < -threshold
        out[sl_a] |= bad
        out[sl_b] |= bad
    return out


def split_concave(segments: np.ndarray, points: np.ndarray, *, threshold: float, normal_step: int, reach: int, min_area: int) -> np.ndarray:
    """Split each segment of a label image along its concave creases.

    Parameters
    ----------
    segments : int ``[H, W]``
        Label image (0 = none).
    points : float ``[H, W, 3]``
        Camera-frame points.
    threshold, normal_step, reach
        See :func:`concave_creases`.
    min_area : int
        Pieces smaller than this are not kept apart: their pixels, like the
        crease pixels, go to the nearest kept piece of the same segment.

    Returns
    -------
    numpy.ndarray
        int32 ``[H, W]`` label image, ``1..K`` (0 = none); same covered pixels
        as ``segments``. O(H W) plus one distance transform per split segment.
    """
    from scipy import ndimage

    seg = np.asarray(segments)
    if seg.shape != np.asarray(points).shape[:2]:
        raise ValueError(f"expected points of shape [{seg.shape[0]}, {seg.shape[1]}, 3] (got {list(np.asarray(points).shape)})")
    crease = concave_creases(points, threshold=threshold, normal_step=normal_step, reach=reach)
    out = np.zeros(seg.shape, np.int32)
    nxt = 1
    for k in np.unique(seg[seg > 0]):
        m = seg == k
        pieces, n = ndimage.label(m & ~crease)
        sizes = np.bincount(pieces.ravel(), minlength=n + 1)
        keep = np.flatnonzero(sizes >= min_area)
        keep = keep[keep > 0]
        if keep.size <= 1:
            out[m] = nxt
            nxt += 1
            continue
        lut = np.zeros(n + 1, np.int32)
        lut[keep] = np.arange(nxt, nxt + keep.size, dtype=np.int32)
        lab = lut[pieces]
        # every other pixel of the segment goes to the nearest kept piece
        _, idx = ndimage.distance_transform_edt(lab == 0, return_indices=True)
        filled = lab[idx[0], idx[1]]
        out[m] = filled[m]
        nxt += keep.size
    return out


class ConvexitySegmenter(Backend):
    """The ``convexity`` segmenter: :func:`geometric_segments`, then :func:`split_concave`.

    Options ``threshold``, ``normal_step``, ``reach``, ``min_area`` go to
    :func:`split_concave`; the other :class:`~graphseg.backends.segmenters.geometric.GeometricOptions`
    go to :func:`geometric_segments`, which runs with its own default ``min_area``.
    """
    parallel = True  # weight-free: views (pairs) may run in worker processes

    name = "convexity"

    class Options(GeometricOptions):
        seed: int | None = Field(0, ge=0, description="the table plane's RANSAC (None: fresh entropy)")
        threshold: float = Field(0.2, ge=0, description="concavity below -threshold is a crease (about twice the sine of half the fold angle)")
        normal_step: int = Field(4, ge=1, description="pixel step of the normals' central differences")
        reach: int = Field(3, ge=1, description="pixel distance of the compared pairs")
        min_area: int = Field(200, ge=0, description="split_concave: smaller pieces are not kept apart (geometric_segments keeps its own min_area)")

    def __call__(self, view: View) -> np.ndarray:
        try:
            pts = view.camera_points()
        except SceneError as err:
            raise SceneError("the convexity segmenter needs depth + K or a point map", where=view.name, field="depth") from err
        o = self.options
        # min_area is split_concave's here; the geometric segments keep GeometricOptions' own
        geometric = GeometricOptions(**{**o.geometric_kwargs(), "min_area": GeometricOptions.model_fields["min_area"].default})
        seg = geometric_segments(pts, view.rgb, geometric, rng=o.seed)
        return split_concave(seg, pts, threshold=o.threshold, normal_step=o.normal_step, reach=o.reach, min_area=o.min_area)
