"""Tests of graphseg.method.grow: objects take the background pixels at their rim up to the colour edge."""

import numpy as np
import pytest

from graphseg.method.grow import grow_rims
from graphseg.testing.scenes import rim_scene


def _short_scene(h=20, w=24, short=3):
    """A bright object (columns 12:) on a dark table, labelled from ``short`` columns too far right."""
    return rim_scene(short, h, w)


def test_shape_dtype_and_inputs_untouched():
    lab, rgb = _short_scene()
    lab0, rgb0 = lab.copy(), rgb.copy()
    out, info = grow_rims([lab], [rgb])
    assert len(out) == 1 and out[0].shape == lab.shape and out[0].dtype == lab.dtype
    assert out[0] is not lab
    np.testing.assert_array_equal(lab, lab0)
    np.testing.assert_array_equal(rgb, rgb0)
    assert set(info) == {"grown", "per_view"} and info["per_view"] == [info["grown"]]


@pytest.mark.parametrize("short", [1, 3, 5])
def test_object_grows_exactly_to_its_colour_edge(short):
    """By hand: the unlabelled object columns 13 .. 12 + short - 1 are labelled, the table (columns < 12) is not.

    Column 12, the first of the object, is on the gradient's ridge: the watershed line may fall on it.
    """
    lab, rgb = _short_scene(short=short)
    out, info = grow_rims([lab], [rgb], band=6, blur=1.0)
    np.testing.assert_array_equal(out[0][:, :12], 0)
    np.testing.assert_array_equal(out[0][:, 13:], 3)
    assert set(np.unique(out[0][:, 12]).tolist()) <= {0, 3}
    assert info["grown"] == int((out[0][:, 12:12 + short] == 3).sum()) >= (short - 1) * lab.shape[0]


def test_no_edge_in_the_band_keeps_part_of_the_ring_and_never_passes_the_band():
    """A uniform image: the object and the outside meet somewhere in the ring; no pixel beyond the band is taken."""
    rgb = np.full((16, 30, 3), 90, np.uint8)
    lab = np.zeros((16, 30), np.int32)
    lab[:, 20:] = 1
    out, info = grow_rims([lab], [rgb], band=4, blur=0.0)
    np.testing.assert_array_equal(out[0][:, :16], 0)
    np.testing.assert_array_equal(out[0][:, 20:], 1)
    assert (out[0][:, 16:20] == 0).any(1).all()  # every row keeps at least one ring pixel (the line or beyond)
    assert 0 < info["grown"] < 4 * lab.shape[0]


def test_correct_border_is_kept():
    """Labels that end at the colour edge do not move (the edge pixel is the watershed line)."""
    lab, rgb = _short_scene(short=0)
    out, info = grow_rims([lab], [rgb], band=6)
    np.testing.assert_array_equal(out[0], lab)
    assert info["grown"] == 0


def test_labelled_and_negative_pixels_never_change():
    """Two objects whose seam is off the colour edge, and negative ids inside the strip an object should take."""
    rgb = np.zeros((16, 16, 3), np.uint8)
    rgb[:, 8:] = 220
    lab = np.ones((16, 16), np.int32)
    lab[:, 6:] = 2
    lab[:, 12:] = 0  # object 2 (bright, columns 8-15) is labelled only up to column 11
    lab[3:6, 13] = -1
    out, info = grow_rims([lab], [rgb], band=4)
    np.testing.assert_array_equal(out[0][:, :12], lab[:, :12])  # the seam between 1 and 2 stays off the edge
    np.testing.assert_array_equal(out[0][3:6, 13], -1)
    assert info["grown"] > 0 and np.all(out[0][lab == 0] >= 0)


def test_two_objects_each_take_their_own_rim():
    """Two objects of different colours, both labelled short: each takes its own columns, up to its own edge."""
    rgb = np.full((12, 40, 3), 20, np.uint8)
    rgb[:, 5:15] = (220, 40, 40)
    rgb[:, 25:35] = (40, 40, 220)
    lab = np.zeros((12, 40), np.int32)
    lab[:, 7:15] = 1
    lab[:, 25:32] = 2
    out, _ = grow_rims([lab], [rgb], band=5)
    np.testing.assert_array_equal(out[0][:, 5:15], 1)
    np.testing.assert_array_equal(out[0][:, 25:35], 2)
    np.testing.assert_array_equal(out[0][:, 15:25], 0)


def test_small_hole_is_filled_and_a_wide_hole_keeps_its_inside():
    """Documented behaviour: a hole no wider than two rings has no outside seed; a wider one keeps its inside."""
    rgb = np.full((30, 30, 3), 200, np.uint8)
    rgb[11:19, 11:19] = 20
    lab = np.zeros((30, 30), np.int32)
    lab[5:25, 5:25] = 1
    lab[11:19, 11:19] = 0
    out, _ = grow_rims([lab], [rgb], band=6)
    np.testing.assert_array_equal(out[0][11:19, 11:19], 1)
    rgb = np.full((60, 60, 3), 200, np.uint8)
    rgb[15:45, 15:45] = 20  # a dark hole 30 px wide, the object labelled 2 px short around it
    lab = np.zeros((60, 60), np.int32)
    lab[5:55, 5:55] = 1
    lab[13:47, 13:47] = 0
    out, _ = grow_rims([lab], [rgb], band=6)
    np.testing.assert_array_equal(out[0][13:15, 20:40], 1)  # the object's own missed rim is taken
    np.testing.assert_array_equal(out[0][18:42, 18:42], 0)  # the dark inside is not


def test_touching_objects_leave_a_notch_at_their_junction():
    """Documented behaviour: two touching objects, both short of a bright strip below them; the seam keeps a notch."""
    rgb = np.full((20, 24, 3), 20, np.uint8)
    rgb[:15] = 200  # both objects end at row 15; the table below is dark
    lab = np.zeros((20, 24), np.int32)
    lab[:12, :12] = 1
    lab[:12, 12:] = 2
    out, _ = grow_rims([lab], [rgb], band=5)
    o = out[0]
    np.testing.assert_array_equal(o[15:], 0)  # the dark table stays
    assert (o[12:15, :9] == 1).all() and (o[12:15, 15:] == 2).all()
    assert (o[12:15, 9:15] == 0).any()  # the notch under the junction


def test_edge_cases_empty_full_and_missing_image():
    rgb = np.zeros((8, 8, 3), np.uint8)
    empty = np.zeros((8, 8), np.int32)
    full = np.ones((8, 8), np.int32)
    lab, _ = _short_scene()
    out, info = grow_rims([empty, full, lab], [rgb, rgb, None])
    np.testing.assert_array_equal(out[0], empty)
    np.testing.assert_array_equal(out[1], full)
    np.testing.assert_array_equal(out[2], lab)
    assert info["per_view"] == [0, 0, 0]
    assert grow_rims([], []) == ([], {"grown": 0, "per_view": []})


def test_bad_inputs_name_the_field():
    lab, rgb = _short_scene()
    with pytest.raises(ValueError, match="one image per label image"):
        grow_rims([lab], [])
    with pytest.raises(ValueError, match="view 0: expected an image of shape"):
        grow_rims([lab], [rgb[:, :5]])
    with pytest.raises(ValueError, match="view 0: expected a uint8 image"):
        grow_rims([lab], [rgb.astype(np.float32) / 255])
    with pytest.raises(ValueError, match=r"view 0: expected labels of shape \[H, W\]"):
        grow_rims([lab[None]], [rgb])
    with pytest.raises(ValueError, match="band >= 1"):
        grow_rims([lab], [rgb], band=0)
    with pytest.raises(ValueError, match="blur >= 0"):
        grow_rims([lab], [rgb], blur=-1.0)
    from pydantic import ValidationError

    from graphseg.config import Config

    with pytest.raises(ValidationError, match="band"):
        Config(grow={"band": 0})
    with pytest.raises(ValidationError, match="grow"):
        Config(lifted={"grow": {"bnad": 3}})


def test_segment_grows_only_when_enabled():
    """segment() records the growing in info only when config.grow is on; estimated points turn it on."""
    from graphseg.config import Config
    from graphseg.method.segment import segment
    from graphseg.testing.scenes import two_boxes_scene

    scene, masks, matches = two_boxes_scene()
    # masks two pixels short of each box, so there is a rim to grow into
    from scipy import ndimage

    short = [[ndimage.binary_erosion(np.asarray(m), iterations=2) for m in ms] for ms in masks]
    off = segment(scene, short, matches, Config())
    on = segment(scene, short, matches, Config(grow={"enabled": True}))
    assert off.info["grow"] is None and "grow" not in off.info["timings"]
    assert on.info["grow"]["grown"] > 0 and on.info["grow"]["grown"] == sum(on.info["grow"]["per_view"]) and "grow" in on.info["timings"]
    for a, b in zip(off.labels, on.labels):  # growing only labels unlabelled pixels
        assert np.all((b == a) | (a == 0))
    grown = [(b != a) for a, b in zip(off.labels, on.labels)]
    on_boxes = sum(int((g & (np.asarray(v.instances) > 0)).sum()) for g, v in zip(grown, scene.views))
    assert on_boxes >= 0.9 * on.info["grow"]["grown"]  # the grown pixels are the boxes' own
    assert "grow" not in Config.preset("rgbd").step_names() and "grow" not in Config().step_names()
    # estimated points are grown (then trimmed) whatever the preset; measured depth only when asked
    assert "grow" in Config().for_lifter("sfm").step_names() and "grow" not in Config().for_lifter("rgbd").step_names()
    assert "grow" in Config(grow={"enabled": True}).for_lifter("rgbd").step_names()  # an old config's switch becomes the operation
    assert Config(grow={"band": 9}).for_lifter("sfm").grow.band == 9
    assert "grow" not in Config.preset("rgbd", lifted={"grow": {"enabled": False}}).for_lifter("sfm").step_names()
