import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from graphseg.geometry import point_normals, project_points


def reference_normals(p, step):
    """The textbook form: NaN-padded central differences, np.cross, np.linalg.norm."""
    p = np.asarray(p, np.float32)
    h, w = p.shape[:2]
    dx = np.full_like(p, np.nan)
    dy = np.full_like(p, np.nan)
    if w > 2 * step:
        dx[:, step:-step] = p[:, 2 * step :] - p[:, : -2 * step]
    if h > 2 * step:
        dy[step:-step] = p[2 * step :] - p[: -2 * step]
    n = np.cross(dx, dy)
    with np.errstate(invalid="ignore", divide="ignore"):
        return n / np.linalg.norm(n, axis=-1, keepdims=True)


def test_point_normals_shape_dtype_and_border():
    pts = np.random.default_rng(0).normal(size=(7, 9, 3))
    n = point_normals(pts, 2)
    assert n.shape == (7, 9, 3) and n.dtype == np.float32
    assert np.isnan(n[:2]).all() and np.isnan(n[-2:]).all() and np.isnan(n[:, :2]).all() and np.isnan(n[:, -2:]).all()
    assert np.isfinite(n[2:-2, 2:-2]).all()


def test_point_normals_of_a_tilted_plane():
    # z = x: the normal is (1, 0, -1) / sqrt(2) up to sign; with x right and y down it is dx x dy = (-1, 0, 1) / sqrt(2)
    ys, xs = np.mgrid[0:6, 0:6].astype(np.float32)
    n = point_normals(np.stack([xs, ys, xs], -1), 1)
    assert np.allclose(n[2, 3], [-np.sqrt(0.5), 0.0, np.sqrt(0.5)])


def test_point_normals_small_images_and_invalid_points():
    assert np.isnan(point_normals(np.zeros((2, 50, 3)), 1)).all()  # too few rows for a vertical difference
    ys, xs = np.mgrid[0:7, 0:7].astype(np.float32)
    pts = np.stack([xs, ys, np.zeros_like(xs)], -1)
    pts[3, 3] = np.nan
    n = point_normals(pts, 1)
    # the NaN point spoils the normals of its four neighbours, not its own (it is no one's difference there)
    assert np.isnan(n[2, 3]).all() and np.isnan(n[3, 2]).all() and np.isfinite(n[3, 3]).all() and np.isfinite(n[2, 2]).all()


@settings(max_examples=60, deadline=None)
@given(
    arrays(np.float32, st.tuples(st.integers(1, 9), st.integers(1, 9), st.just(3)), elements=st.floats(-10, 10, width=32) | st.just(np.float32("nan"))),
    st.integers(1, 3),
)
def test_point_normals_equals_the_reference(pts, step):
    with np.errstate(invalid="ignore"):
        assert np.array_equal(point_normals(pts, step), reference_normals(pts, step), equal_nan=True)


def test_point_normals_bad_input():
    with pytest.raises(ValueError, match=r"expected points of shape \[H, W, 3\] \(got \[4, 5, 4\]\)"):
        point_normals(np.zeros((4, 5, 4)))
    with pytest.raises(ValueError, match=r"got \[4, 5\]"):
        point_normals(np.zeros((4, 5)))
    with pytest.raises(ValueError, match=r"expected step >= 1 \(got 0\)"):
        point_normals(np.zeros((4, 5, 3)), 0)


def test_project_points_shape_values_and_edges():
    K = np.array([[100.0, 0, 49.5], [0, 100, 29.5], [0, 0, 1]])
    T = np.eye(4)
    T[:3, 3] = [0.0, 0.0, -1.0]  # camera 1 m behind the origin, looking along +z
    P = np.array([[0.0, 0.0, 1.0], [0.1, -0.2, 1.0], [0.0, 0.0, -2.0], [5.0, 0.0, 0.0], [np.nan, 0, 0]])
    u, v, z, ok = project_points(P, K, T, (60, 100))
    assert u.dtype == v.dtype == np.int64 and u.shape == v.shape == z.shape == ok.shape == (5,)
    # (0, 0, 1) is 2 m ahead: centre; (0.1, -0.2, 1): 100 * 0.05 = 5 px right, 10 px up
    assert (u[0], v[0], u[1], v[1]) == (50, 30, 54, 20) and z[:2].tolist() == [2.0, 2.0]
    assert ok.tolist() == [True, True, False, False, False]  # behind, outside (u = 49.5 + 500), NaN
    assert u[2] == -1 and v[2] == -1 and z[2] == -1.0
