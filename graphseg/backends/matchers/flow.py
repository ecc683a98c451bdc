"""The ``flow`` matcher: OpenCV DIS optical flow, certainty from forward-backward consistency (RGB only).

Keeps up to ``num_matches`` matches by certainty
(:func:`~graphseg.backends.matchers.sampling.subsample_matches`). For small
baselines; wide baselines break optical flow.

Examples
--------
>>> import numpy as np
>>> from graphseg.scene import View
>>> rgb = np.random.default_rng(0).integers(0, 255, (32, 48, 3), dtype=np.uint8)
>>> m = FlowMatcher(num_matches=None, stride=4)(View("a", rgb), View("b", rgb))
>>> len(m) > 0, bool(np.abs(m.xy_i - m.xy_j).max() < 0.5)
(True, True)
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from ...scene import Matches, View
from ..imaging import gray
from ..options import Backend
from .sampling import MatcherOptions, subsample_matches

__all__ = ["flow_matches", "FlowMatcher"]


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

    gi, gj = gray(view_i.rgb), gray(view_j.rgb)
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


class FlowMatcher(Backend):
    """The ``flow`` matcher (see :func:`flow_matches`)."""
    parallel = True  # weight-free: views (pairs) may run in worker processes

    name = "flow"

    class Options(MatcherOptions):
        max_fb_error: float = Field(1.0, gt=0, description="pixels")
        stride: int = Field(2, ge=1, description="use every stride-th pixel of view i")

    def __call__(self, view_i: View, view_j: View) -> Matches:
        o = self.options
        return subsample_matches(flow_matches(view_i, view_j, max_fb_error=o.max_fb_error, stride=o.stride), o.num_matches, rng=o.seed)
