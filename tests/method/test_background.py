import numpy as np
import pytest

from graphseg.config import BackgroundConfig
from graphseg.geometry import fit_plane_ransac, point_normals
from graphseg.method.background import background_masks
from graphseg.testing.scenes import two_boxes_scene


def test_ransac_recovers_tilted_plane_with_outliers():
    rng = np.random.default_rng(0)
    n = np.array([0.2, -0.1, 1.0])
    n /= np.linalg.norm(n)
    xy = rng.uniform(-1, 1, (2000, 2))
    z = -(n[0] * xy[:, 0] + n[1] * xy[:, 1] + 0.3) / n[2]
    pts = np.c_[xy, z] + rng.normal(0, 0.001, (2000, 3))
    pts = np.concatenate([pts, rng.uniform(-1, 1, (600, 3))])
    normal, offset, inl = fit_plane_ransac(pts, threshold=0.005, rng=1)
    assert normal.shape == (3,) and inl.shape == (2600,)
    s = np.sign(normal @ n)
    np.testing.assert_allclose(s * normal, n, atol=2e-3)
    assert s * offset == pytest.approx(0.3, abs=2e-3)
    assert inl[:2000].mean() > 0.97


def test_ransac_errors():
    with pytest.raises(ValueError, match=r"\[P, 3\]"):
        fit_plane_ransac(np.zeros((5, 2)))
    with pytest.raises(ValueError, match="at least 3"):
        fit_plane_ransac(np.zeros((2, 3)))


def test_background_on_box_scene_keeps_objects_and_drops_table():
    scene, _, _ = two_boxes_scene(shape=(240, 320))
    pts = [v.points for v in scene.views]
    bg, info = background_masks(pts, [v.camera_center for v in scene.views], BackgroundConfig(), rng=0)
    assert info.plane is not None and abs(info.plane[2]) > 0.999  # z = 0 plane
    for v, b in zip(scene.views, bg):
        assert b.shape == v.shape and b.dtype == bool
        table = (v.instances == 0) & (v.depth > 0)
        assert b[table].mean() > 0.98  # table pixels at object edges have mixed normals
        assert b[v.instances > 0].mean() < 0.01  # bottom rims stay object thanks to the normal test


def test_below_plane_and_far_points():
    K_pts = np.zeros((1, 3, 3), np.float32)
    K_pts[0, 0] = [0, 0, 0.0]  # on plane z = 0
    K_pts[0, 1] = [0, 0, -0.5]  # below the plane
    K_pts[0, 2] = [0, 0, 0.2]  # above: object
    plane_pts = np.c_[np.random.default_rng(0).uniform(-1, 1, (400, 2)), np.zeros(400)].astype(np.float32)
    views = [K_pts, plane_pts.reshape(20, 20, 3)]
    cams = [np.array([0, 0, 1.0]), np.array([0, 0, 1.0])]
    cfg = BackgroundConfig(plane_normal_angle=None, max_distance=None)
    bg, _ = background_masks(views, cams, cfg, rng=0)
    assert bg[0].tolist() == [[True, True, False]]
    cfg = BackgroundConfig(plane_normal_angle=None, max_distance=0.9, plane=False)
    bg, info = background_masks(views, cams, cfg, rng=0)  # distances 1.0, 1.5, 0.8
    assert bg[0].tolist() == [[True, True, False]] and info.max_distance == 0.9
    bg, _ = background_masks(views, cams, BackgroundConfig(enabled=False))
    assert not bg[0].any()


def test_invalid_points_are_never_background():
    p = np.full((4, 4, 3), np.nan, np.float32)
    bg, info = background_masks([p], [np.zeros(3)], BackgroundConfig())
    assert not bg[0].any() and info.plane is None


def test_point_normals_shape_and_nan_border():
    n = point_normals(np.zeros((6, 7, 3), np.float32))
    assert n.shape == (6, 7, 3) and np.isnan(n).all()  # equal points (and borders) have no normal
