import numpy as np
import pytest

from graphseg.backends.convexity import ConvexitySegmenter, concave_creases, split_concave
from graphseg.backends.registry import segmenters
from graphseg.scene import View


def surface(z):
    ys, xs = np.mgrid[0:40, 0:40].astype(np.float32)
    x, y = (xs - 19.5) * 0.002, (ys - 20) * 0.002
    return np.stack([x, y, z(x)], -1).astype(np.float32)


def test_creases_shape_and_sign():
    valley = surface(lambda x: 0.5 - 0.5 * np.abs(x))
    ridge = surface(lambda x: 0.5 + 0.5 * np.abs(x))
    c = concave_creases(valley)
    assert c.shape == (40, 40) and c.dtype == bool
    assert c[20, 17:23].any() and not c[20, :10].any()
    assert not concave_creases(ridge).any()  # a convex edge is no crease


def test_split_keeps_coverage_and_splits_only_concave():
    seg = np.zeros((40, 40), np.int32)
    seg[8:32] = 7
    out = split_concave(seg, surface(lambda x: 0.5 - 0.5 * np.abs(x)))
    assert ((out > 0) == (seg > 0)).all() and np.unique(out[out > 0]).size == 2
    out = split_concave(seg, surface(lambda x: 0.5 + 0.5 * np.abs(x)))
    assert np.unique(out[out > 0]).tolist() == [1]


def test_bad_points_shape():
    with pytest.raises(ValueError, match=r"points of shape \[H, W, 3\]"):
        concave_creases(np.zeros((4, 4)))
    with pytest.raises(ValueError, match=r"points of shape \[2, 2, 3\]"):
        split_concave(np.zeros((2, 2), int), np.zeros((3, 3, 3)))


def test_registered_segmenter_runs_on_a_view():
    seg = segmenters.resolve("convexity")
    assert isinstance(seg, ConvexitySegmenter)
    pts = surface(lambda x: 0.5 - 0.5 * np.abs(x))
    rgb = np.full((40, 40, 3), 128, np.uint8)
    out = seg(View("v", rgb, points=pts))
    assert out.shape == (40, 40)


def test_unknown_option_is_reported_when_built():
    with pytest.raises(TypeError, match="unknown option 'bogus' of the convexity segmenter; valid options: threshold, normal_step, reach, min_area, background"):
        segmenters.resolve("convexity", bogus=1)
    assert segmenters.resolve("convexity", threshold=0.3, min_area=50, color_regions=None).split["threshold"] == 0.3
