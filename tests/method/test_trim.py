"""Tests of graphseg.method.trim: rim pixels that look like the background go back to it."""

import numpy as np
import pytest

from graphseg.method.trim import trim_rims
from graphseg.testing.scenes import rim_scene


def _halo_scene(h=20, w=24, halo=2):
    """A bright object (columns 12:) on a dark table, labelled ``halo`` columns too far left."""
    return rim_scene(-halo, h, w)


def test_shape_dtype_and_inputs_untouched():
    lab, rgb = _halo_scene()
    lab0, rgb0 = lab.copy(), rgb.copy()
    out, info = trim_rims([lab], [rgb])
    assert len(out) == 1 and out[0].shape == lab.shape and out[0].dtype == lab.dtype
    assert out[0] is not lab
    np.testing.assert_array_equal(lab, lab0)
    np.testing.assert_array_equal(rgb, rgb0)
    assert set(info) == {"trimmed", "per_view"} and info["per_view"] == [info["trimmed"]]


def test_halo_removed_exactly():
    """By hand: the two dark labelled columns are unlabelled, the object keeps every pixel."""
    lab, rgb = _halo_scene(halo=2)
    out, info = trim_rims([lab], [rgb], window=5, rim=3, blur=0.0)
    np.testing.assert_array_equal(out[0][:, :12], 0)
    np.testing.assert_array_equal(out[0][:, 12:], 3)
    assert info["trimmed"] == 2 * lab.shape[0]


def test_rim_depth_is_inclusive_with_the_default_window():
    """By hand: a 3-column halo and rim 3 (window 7 reaches 3 pixels out): exactly columns 9-11 are unlabelled."""
    lab, rgb = _halo_scene(halo=3)
    out, info = trim_rims([lab], [rgb], blur=0.0)
    np.testing.assert_array_equal(out[0][:, :12], 0)
    np.testing.assert_array_equal(out[0][:, 12:], 3)
    assert info["trimmed"] == 3 * lab.shape[0]


def test_correct_border_is_kept():
    """Without a halo nothing changes: the object's rim looks like the object."""
    lab, rgb = _halo_scene(halo=0)
    out, info = trim_rims([lab], [rgb], window=5, rim=3, blur=0.0)
    np.testing.assert_array_equal(out[0], lab)
    assert info["trimmed"] == 0


def test_border_between_two_objects_is_not_touched():
    """Two labelled objects of different colours meeting: no unlabelled pixel beside the seam, nothing trimmed there."""
    rgb = np.zeros((16, 16, 3), np.uint8)
    rgb[:, 8:] = 220
    lab = np.ones((16, 16), np.int32)
    lab[:, 7:] = 2  # the seam is one column off, but both sides are objects
    out, info = trim_rims([lab], [rgb], window=5, rim=3, blur=0.0)
    np.testing.assert_array_equal(out[0], lab)
    assert info["trimmed"] == 0


def test_edge_cases_empty_full_and_missing_image():
    rgb = np.zeros((8, 8, 3), np.uint8)
    empty = np.zeros((8, 8), np.int32)
    full = np.ones((8, 8), np.int32)
    lab, rgb2 = _halo_scene()
    out, info = trim_rims([empty, full, lab], [rgb, rgb, None])
    np.testing.assert_array_equal(out[0], empty)
    np.testing.assert_array_equal(out[1], full)
    np.testing.assert_array_equal(out[2], lab)
    assert info["per_view"] == [0, 0, 0]


def test_bad_inputs_name_the_field():
    lab, rgb = _halo_scene()
    with pytest.raises(ValueError, match="one image per label image"):
        trim_rims([lab], [])
    with pytest.raises(ValueError, match="view 0: expected an image of shape"):
        trim_rims([lab], [rgb[:, :5]])
    with pytest.raises(ValueError, match="window, rim and min_pixels"):
        trim_rims([lab], [rgb], window=0)
    with pytest.raises(ValueError, match="odd window"):
        trim_rims([lab], [rgb], window=4)
    with pytest.raises(ValueError, match="view 0: expected a uint8 image"):
        trim_rims([lab], [rgb.astype(np.float32) / 255])
    from pydantic import ValidationError

    from graphseg.config import Config

    with pytest.raises(ValidationError, match="odd window"):
        Config(trim={"window": 8})


def test_segment_trims_only_when_enabled():
    """segment() records the trim in info only when config.trim is on; estimated points get it through lifted.trim."""
    from graphseg.config import Config
    from graphseg.method.segment import segment
    from graphseg.testing.scenes import two_boxes_scene

    scene, masks, matches = two_boxes_scene()
    off = segment(scene, masks, matches, Config())
    on = segment(scene, masks, matches, Config(trim={"enabled": True}))
    assert off.info["trim"] is None and "trim" not in off.info["timings"]
    assert on.info["trim"]["trimmed"] > 0 and on.info["trim"]["trimmed"] == sum(on.info["trim"]["per_view"]) and "trim" in on.info["timings"]
    for a, b in zip(off.labels, on.labels):  # trimming only unlabels pixels
        assert np.all((b == a) | (b == 0))
    assert "trim" in Config().for_lifter("sfm").step_names() and "trim" not in Config().for_lifter("rgbd").step_names()
    # the trim section's other fields reach estimated points; lifted.trim turns it off
    assert Config(trim={"window": 9}).for_lifter("sfm").trim.window == 9
    assert "trim" not in Config(lifted={"trim": {"enabled": False}}).for_lifter("sfm").step_names()
