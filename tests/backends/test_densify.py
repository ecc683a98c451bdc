import numpy as np
import pytest

from graphseg.backends.lifters.densify import color_regions, fill_depth_by_regions


def test_plane_in_inverse_depth_is_recovered():
    h, w = 30, 40
    v, u = np.mgrid[0:h, 0:w]
    true = 1.0 / (0.5 + 0.002 * u + 0.001 * v)  # a plane seen by a pinhole camera
    z = np.full((h, w), np.nan)
    rng = np.random.default_rng(0)
    idx = rng.choice(h * w, 20, replace=False)
    z.flat[idx] = true.flat[idx]
    out = fill_depth_by_regions(z, np.zeros((h, w), np.int64))
    assert out.shape == (h, w) and out.dtype == np.float32
    np.testing.assert_allclose(out, true, rtol=1e-4)


def test_regions_are_independent_and_empty_regions_stay_unknown():
    z = np.full((2, 6), np.nan)
    z[:, 0] = 1.0
    z[:, 3] = 2.0
    regions = np.array([[0, 0, 0, 1, 1, 2]] * 2)
    out = fill_depth_by_regions(z, regions, min_points=3)
    assert np.allclose(out[:, :3], 1.0) and np.allclose(out[:, 3:5], 2.0)
    assert np.isnan(out[:, 5]).all()


def test_replace_and_clipping():
    z = np.array([[1.0, 1.0, 1.0, 5.0, np.nan]])
    out = fill_depth_by_regions(z, np.zeros((1, 5), np.int64), min_points=99, replace=True, margin=0.0)
    assert out[0, 4] == pytest.approx(1.0)  # median; known pixels kept without a plane fit
    assert out[0, 3] == 5.0


def test_shape_mismatch():
    with pytest.raises(ValueError, match="one shape"):
        fill_depth_by_regions(np.zeros((2, 2)), np.zeros((2, 3), np.int64))


def test_color_regions_split_at_colour_edges():
    rgb = np.zeros((20, 20, 3), np.uint8)
    rgb[:, 10:] = 200
    lab = color_regions(rgb, scale=50, min_size=5)
    assert lab.shape == (20, 20)
    assert set(lab[:, :10].ravel()).isdisjoint(lab[:, 10:].ravel())
