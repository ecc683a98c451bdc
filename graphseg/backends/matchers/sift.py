"""The ``sift`` matcher: SIFT, Lowe's ratio test and ``cv2.USAC_MAGSAC`` verification (sparse, RGB only).

Keeps up to ``num_matches`` matches by certainty
(:func:`~graphseg.backends.matchers.sampling.subsample_matches`).

Examples
--------
>>> import numpy as np
>>> from graphseg.scene import View
>>> blank = View("a", np.zeros((32, 32, 3), np.uint8))
>>> len(SiftMatcher()(blank, blank))                  # no texture, no keypoints: no matches
0
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from ...scene import Matches, View
from ..imaging import gray
from ..options import Backend
from .sampling import MatcherOptions, subsample_matches

__all__ = ["epipolar_inliers", "sift_matches", "SiftMatcher"]


def epipolar_inliers(pts_i: np.ndarray, pts_j: np.ndarray, *, threshold: float) -> np.ndarray | None:
    """Inliers of a fundamental matrix fitted by ``cv2.USAC_MAGSAC``, or None when no model is found.

    Parameters
    ----------
    pts_i, pts_j : float32 ``[N, 2]``
        Matched pixels (x, y), ``N >= 8``.
    threshold : float, keyword-only
        Pixels; the epipolar distance of an inlier.

    Returns
    -------
    bool ``[N]`` or None
        None also where OpenCV fails an assertion on a degenerate set (for
        example most matches landing on one pixel of a plain surface) instead
        of returning no model.

    Examples
    --------
    >>> g = np.random.default_rng(0).uniform(0, 100, (20, 2)).astype(np.float32)
    >>> epipolar_inliers(g, g + np.float32([5, 0]), threshold=1.0).all()
    np.True_
    """
    import cv2

    try:
        _, inl = cv2.findFundamentalMat(pts_i, pts_j, cv2.USAC_MAGSAC, threshold, 0.999, 10000)
    except cv2.error:
        return None
    return None if inl is None else inl.ravel().astype(bool)


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
        Empty when fewer than 8 matches pass the ratio test, or when no
        fundamental matrix is found (:func:`epipolar_inliers`).

    Notes
    -----
    O(K_i K_j) descriptor comparisons for ``K`` keypoints per view.
    """
    import cv2

    sift = cv2.SIFT_create()  # type: ignore[attr-defined]
    ki, di = sift.detectAndCompute(gray(view_i.rgb), None)
    kj, dj = sift.detectAndCompute(gray(view_j.rgb), None)
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
    keep = epipolar_inliers(pi, pj, threshold=ransac_threshold)
    if keep is None:
        return empty
    cert = 1.0 - dist[keep] / max(float(dist.max()), 1e-6)
    return Matches(pi[keep], pj[keep], np.clip(cert, 1e-3, 1.0))


class SiftMatcher(Backend):
    """The ``sift`` matcher (see :func:`sift_matches`)."""
    parallel = True  # weight-free: views (pairs) may run in worker processes

    name = "sift"

    class Options(MatcherOptions):
        ratio: float = Field(0.8, gt=0, le=1, description="Lowe's ratio test")
        ransac_threshold: float = Field(1.5, gt=0, description="pixels")

    def __call__(self, view_i: View, view_j: View) -> Matches:
        o = self.options
        m = sift_matches(view_i, view_j, ratio=o.ratio, ransac_threshold=o.ransac_threshold)
        return subsample_matches(m, o.num_matches, rng=o.seed)
