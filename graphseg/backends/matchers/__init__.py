"""Matchers: a pair of views -> pixel matches with certainty.

One module per matcher; the classical ones need no weights, the model
adapters load the user's files and import their packages only when built.

* ``reprojection`` (:mod:`.reprojection`): exact when 3D is known. Every
  pixel's world point is projected into the other view and kept where the
  other view's depth agrees (visibility test); certainty falls off with the
  depth disagreement. The weight-free stand-in for RoMa.
* ``flow`` (:mod:`.flow`): OpenCV DIS optical flow with forward-backward
  consistency as certainty (RGB only).
* ``sift`` (:mod:`.sift`): SIFT + Lowe ratio test + ``cv2.USAC_MAGSAC``
  verification (sparse).
* ``precomputed-matches`` (:mod:`.precomputed`): matches computed elsewhere.
* ``loftr`` (:mod:`.loftr`) and ``roma`` (:mod:`.roma`, importing ``romatch``
  through :mod:`.romatch_compat`): learned matchers with the user's weights.

All keep up to ``num_matches`` matches by certainty (:mod:`.sampling`). Each
matcher is a :class:`~graphseg.backends.options.Backend`: its ``Options`` hold
the defaults, and the pure functions take every option as a required keyword.
This package re-exports the public names of the old
``graphseg.backends.matchers`` module and every matcher class.

Examples
--------
>>> import numpy as np
>>> from graphseg.scene import View, backproject
>>> K = np.array([[50.0, 0, 16], [0, 50, 12], [0, 0, 1]])
>>> T = np.eye(4)
>>> depth = np.full((24, 32), 2.0, np.float32)
>>> v = View("a", np.zeros((24, 32, 3), np.uint8), depth=depth, points=backproject(depth, K, T), K=K, cam_to_world=T)
>>> m = ReprojectionMatcher(num_matches=None)(v, v)
>>> len(m), bool(np.abs(m.xy_i - m.xy_j).max() < 1e-4)
(768, True)
"""

from .flow import FlowMatcher, flow_matches
from .loftr import LoFTRMatcher
from .precomputed import PrecomputedMatcher
from .reprojection import ReprojectionMatcher, reprojection_matches
from .roma import RoMaMatcher
from .sampling import sample_by_certainty, subsample_matches
from .sift import SiftMatcher, sift_matches

__all__ = [
    "reprojection_matches",
    "flow_matches",
    "sift_matches",
    "subsample_matches",
    "ReprojectionMatcher",
    "FlowMatcher",
    "SiftMatcher",
    "sample_by_certainty",
    "PrecomputedMatcher",
    "LoFTRMatcher",
    "RoMaMatcher",
]
