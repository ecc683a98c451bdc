import numpy as np
import pytest

from graphseg.backends.lifters.rgbd import NO_DEPTH_MESSAGE, RGBDLifter
from graphseg.backends.registry import features, lifters, segmenters
from graphseg.backends.segmenters.geometric import GeometricSegmenter
from graphseg.backends.segmenters.oracle_parts import OraclePartsSegmenter
from graphseg.backends.segmenters.precomputed import (
    PrecomputedSegmenter,
    load_precomputed,
    save_precomputed,
)
from graphseg.backends.segmenters.superpixel import SuperpixelSegmenter
from graphseg.scene import Scene, SceneError, View
from graphseg.sim.boxes import Box
from graphseg.testing.scenes import box_scene


def test_registry_lists_all_backends():
    assert {"superpixel", "geometric", "precomputed", "oracle-parts"} <= set(segmenters.names())
    assert {"reprojection", "flow", "sift"} <= set(matchers_names())
    assert "rgbd" in lifters.names() and "color" in features.names()


def matchers_names():
    from graphseg.backends.registry import matchers

    return matchers.names()


def test_geometric_does_not_merge_two_separate_boxes():
    boxes = [Box((-0.06, 0.0, 0.04), (0.08, 0.08, 0.08), 0.0, (200, 60, 60)), Box((0.06, 0.0, 0.04), (0.08, 0.08, 0.08), 0.0, (200, 60, 60))]
    scene = box_scene(boxes, views=1, shape=(120, 160), arc_deg=0)
    v = scene[0]
    lab = GeometricSegmenter()(v)
    assert lab.shape == v.shape and lab.dtype == np.int32
    for k in (1, 2):
        ids = np.unique(lab[v.instances == k])
        ids = ids[ids > 0]
        assert ids.size >= 1
        other = np.unique(lab[v.instances == 3 - k])
        assert not set(ids) & set(other), "a part spans both boxes"
    assert (lab[v.instances == 0] == 0).mean() > 0.98  # the table is not segmented
    covered = (lab[v.instances > 0] > 0).mean()
    assert covered > 0.9


def test_geometric_needs_3d():
    with pytest.raises(SceneError, match="depth"):
        GeometricSegmenter()(View("x", np.zeros((4, 4, 3), np.uint8)))


def test_superpixel_shapes_and_options():
    scene = box_scene([Box((0, 0, 0.04), (0.08, 0.08, 0.08))], views=1, shape=(60, 80), arc_deg=0)
    lab = SuperpixelSegmenter()(scene[0])
    assert lab.shape == (60, 80) and lab.min() >= 1
    slic = SuperpixelSegmenter(method="slic", n_segments=20)(scene[0])
    assert 2 <= len(np.unique(slic)) <= 40
    with pytest.raises(ValueError, match="unknown superpixel method"):
        SuperpixelSegmenter(method="watershed")


def test_precomputed_roundtrip(tmp_path):
    v = View("000", np.zeros((5, 6, 3), np.uint8))
    lab = np.arange(30).reshape(5, 6) % 4
    save_precomputed(tmp_path, "000", lab)
    assert np.array_equal(PrecomputedSegmenter(tmp_path)(v), lab)
    masks = [lab == 1, lab >= 2]
    save_precomputed(tmp_path / "b", "000", masks)
    back = PrecomputedSegmenter(tmp_path / "b")(v)
    assert len(back) == 2 and all(np.array_equal(a, b) for a, b in zip(masks, back))
    with pytest.raises(SceneError, match="no masks for view '001'"):
        load_precomputed(tmp_path, "001")
    with pytest.raises(SceneError, match="masks are"):
        PrecomputedSegmenter(tmp_path)(View("000", np.zeros((3, 3, 3), np.uint8)))
    with pytest.raises(ValueError, match="needs folder"):
        PrecomputedSegmenter()


def test_oracle_parts_is_seeded_and_needs_ground_truth():
    scene = box_scene([Box((0, 0, 0.04), (0.1, 0.1, 0.08))], views=1, shape=(60, 80), arc_deg=0)
    a = OraclePartsSegmenter(parts=3, seed=1)(scene[0])
    b = OraclePartsSegmenter(parts=3, seed=1)(scene[0])
    assert len(a) == 3 and all(np.array_equal(x, y) for x, y in zip(a, b))
    assert np.array_equal(np.logical_or.reduce(a), scene[0].instances == 1)
    with pytest.raises(SceneError, match="evaluation only"):
        OraclePartsSegmenter()(scene[0].replace(instances=None))


def test_rgbd_lifter_and_message():
    scene = box_scene([Box((0, 0, 0.04), (0.1, 0.1, 0.08))], views=2, shape=(30, 40))
    lifted = RGBDLifter()(Scene([v.replace(points=None) for v in scene.views]))
    for a, b in zip(scene.views, lifted.views):
        np.testing.assert_allclose(np.nan_to_num(a.points), np.nan_to_num(b.points), atol=1e-5)
        assert b.confidence.shape == a.shape
    with pytest.raises(SceneError, match="no depth; choose a lifter"):
        RGBDLifter()(Scene([scene[0].replace(depth=None)]))
    for choice in ("--lifter sfm", "--lifter dust3r", "--lifter da3", "--points DIR"):
        assert choice in NO_DEPTH_MESSAGE


def test_color_features_shape():
    f = features.resolve("color")(View("0", np.zeros((16, 20, 3), np.uint8)))
    assert f.shape == (4, 5, 3)
