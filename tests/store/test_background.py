"""The store's background rule: each view's background from that view alone."""

import numpy as np

from graphseg.config import BackgroundConfig
from graphseg.method.background import background_masks
from graphseg.store.background import per_view_background, view_background, view_seed
from graphseg.testing.scenes import TWO_BOXES, box_scene


def _views():
    s = box_scene(TWO_BOXES, views=3, shape=(48, 64))
    return [np.asarray(v.points) for v in s.views], [v.camera_center for v in s.views]


def test_shape_and_the_rule_of_one_view():
    pts, cen = _views()
    bg, info = view_background(pts[0], cen[0], BackgroundConfig(), seed=3)
    ref, ref_info = background_masks([pts[0]], [cen[0]], BackgroundConfig(), rng=view_seed(pts[0], 3))
    assert bg.shape == pts[0].shape[:2] and bg.dtype == bool
    np.testing.assert_array_equal(bg, ref[0])
    assert info["plane"] == list(ref_info.plane) and 0 < info["fraction"] < 1


def test_a_view_background_does_not_depend_on_the_other_views_or_their_order():
    pts, cen = _views()
    alone = [per_view_background([p], [c])[0][0] for p, c in zip(pts, cen)]
    together, info = per_view_background(pts, cen)
    reversed_, _ = per_view_background(pts[::-1], cen[::-1])
    for a, b, r in zip(alone, together, reversed_[::-1]):
        np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(a, r)
    assert len(info.fraction) == 3


def test_no_camera_and_no_seed():
    pts, _ = _views()
    bg, info = view_background(pts[0], None, seed=None)  # fresh entropy: still a valid mask
    assert bg.shape == pts[0].shape[:2] and info["max_distance"] is None
    assert view_seed(pts[0], None) is None and view_seed(pts[0], 1) != view_seed(pts[1], 1)
