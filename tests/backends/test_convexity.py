import numpy as np
import pytest

from graphseg.backends.registry import segmenters
from graphseg.backends.segmenters.convexity import (
    ConvexitySegmenter,
    concave_creases,
    split_concave,
)
from graphseg.scene import SceneError, View

CREASE = {"threshold": 0.2, "normal_step": 4, "reach": 3}  # ConvexitySegmenter.Options' defaults
SPLIT = {**CREASE, "min_area": 200}


def surface(z):
    ys, xs = np.mgrid[0:40, 0:40].astype(np.float32)
    x, y = (xs - 19.5) * 0.002, (ys - 20) * 0.002
    return np.stack([x, y, z(x)], -1).astype(np.float32)


def test_creases_shape_and_sign():
    valley = surface(lambda x: 0.5 - 0.5 * np.abs(x))
    ridge = surface(lambda x: 0.5 + 0.5 * np.abs(x))
    c = concave_creases(valley, **CREASE)
    assert c.shape == (40, 40) and c.dtype == bool
    assert c[20, 17:23].any() and not c[20, :10].any()
    assert not concave_creases(ridge, **CREASE).any()  # a convex edge is no crease


def test_split_keeps_coverage_and_splits_only_concave():
    seg = np.zeros((40, 40), np.int32)
    seg[8:32] = 7
    out = split_concave(seg, surface(lambda x: 0.5 - 0.5 * np.abs(x)), **SPLIT)
    assert ((out > 0) == (seg > 0)).all() and np.unique(out[out > 0]).size == 2
    out = split_concave(seg, surface(lambda x: 0.5 + 0.5 * np.abs(x)), **SPLIT)
    assert np.unique(out[out > 0]).tolist() == [1]


def test_bad_points_shape():
    with pytest.raises(ValueError, match=r"points of shape \[H, W, 3\]"):
        concave_creases(np.zeros((4, 4)), **CREASE)
    with pytest.raises(ValueError, match=r"points of shape \[2, 2, 3\]"):
        split_concave(np.zeros((2, 2), int), np.zeros((3, 3, 3)), **SPLIT)


def test_registered_segmenter_runs_on_a_view():
    seg = segmenters.resolve("convexity")
    assert isinstance(seg, ConvexitySegmenter)
    pts = surface(lambda x: 0.5 - 0.5 * np.abs(x))
    rgb = np.full((40, 40, 3), 128, np.uint8)
    out = seg(View("v", rgb, points=pts))
    assert out.shape == (40, 40)


def test_unknown_option_is_reported_when_built():
    with pytest.raises(SceneError, match="^backends.options.convexity.bogus: unknown option 'bogus'; valid keys: background, .*threshold, normal_step, reach") as err:
        segmenters.resolve("convexity", bogus=1)
    assert "\n" not in str(err.value)
    seg = segmenters.resolve("convexity", threshold=0.3, min_area=50, color_regions=None)
    assert (seg.options.threshold, seg.options.min_area, seg.options.color_regions) == (0.3, 50, None)
    assert ConvexitySegmenter(ConvexitySegmenter.Options(threshold=0.3)).options.threshold == 0.3


def test_min_area_is_split_concaves_and_the_geometric_segments_keep_their_own():
    """As before the Options: ``min_area`` (200) goes to split_concave, geometric_segments runs with its own 60."""
    from graphseg.backends.segmenters.geometric import GeometricOptions

    o = ConvexitySegmenter.Options()
    assert (o.threshold, o.normal_step, o.reach, o.min_area, o.seed) == (0.2, 4, 3, 200, 0)
    assert GeometricOptions.model_fields["min_area"].default == 60
