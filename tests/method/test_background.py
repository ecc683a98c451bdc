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


def _table_and_shelf(scale=1.0):
    """A 1 x 1 table at z = 0 and, beyond its edge, a shelf 0.3 above it (points [P, 3])."""
    g = np.random.default_rng(0)
    table = np.c_[g.uniform(-0.5, 0.5, (6000, 2)), np.zeros(6000)]
    shelf = np.c_[g.uniform(0.9, 1.4, (800, 1)), g.uniform(-0.5, 0.5, (800, 1)), np.full((800, 1), 0.3)]
    box = np.c_[g.uniform(-0.1, 0.1, (300, 2)), g.uniform(0.02, 0.2, (300, 1))]  # an object on the table
    return table * scale, shelf * scale, box * scale


def test_table_outline_keeps_the_table_and_drops_what_lies_beyond():
    from graphseg.method.background import table_outline

    table, shelf, box = _table_and_shelf()
    floor_patch = np.c_[np.random.default_rng(1).uniform(1.6, 2.0, (500, 2)), np.zeros(500)]  # same height, apart
    out = table_outline(np.concatenate([table, floor_patch]), np.array([0, 0, 1.0]))
    assert out.contains(table).mean() == 1.0 and out.contains(box).all()
    assert not out.contains(shelf).any() and not out.contains(floor_patch).any()
    assert table_outline(np.zeros((2, 3)), np.array([0, 0, 1.0])) is None  # too few points
    line = np.c_[np.linspace(0, 1, 100), np.zeros(100), np.zeros(100)]
    assert table_outline(line, np.array([0, 0, 1.0])) is None  # degenerate


@pytest.mark.parametrize("scale", [0.001, 1.0, 1000.0])
def test_table_outline_is_scale_free(scale):
    """The same scene at any scale (SfM without poses has none) gives the same outline decisions."""
    from graphseg.method.background import table_outline

    table, shelf, box = _table_and_shelf()
    ref = table_outline(table, np.array([0, 0, 1.0]))
    out = table_outline(table * scale, np.array([0, 0, 1.0]))
    probe = np.concatenate([table, shelf, box])
    assert (out.contains(probe * scale) == ref.contains(probe)).all()


def test_background_drops_points_beyond_the_table():
    """Before ``beyond_table`` a shelf beyond the table's edge (above the plane band) stayed foreground."""
    table, shelf, box = _table_and_shelf()
    pts = np.concatenate([table, shelf, box]).astype(np.float32)[None]
    cams = [np.array([0.0, 0.0, 1.5])]
    cfg = BackgroundConfig(plane_normal_angle=None, max_distance=None)
    bg, info = background_masks([pts], cams, cfg, rng=0)
    n_t, n_s = len(table), len(shelf)
    assert bg[0][0, :n_t].all() and bg[0][0, n_t : n_t + n_s].all() and not bg[0][0, n_t + n_s :].any()
    assert info.outline is not None and info.beyond_table[0] == pytest.approx(n_s / pts.shape[1], abs=0.01)
    bg_off, _ = background_masks([pts], cams, cfg.model_copy(update={"beyond_table": False}), rng=0)
    assert not bg_off[0][0, n_t : n_t + n_s].any()
