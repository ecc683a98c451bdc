import numpy as np
import pytest

from graphseg.scene import Matches, Scene, SceneError, View, backproject, is_rigid


def view(**kw):
    base = dict(name="v", rgb=np.zeros((4, 5, 3), np.uint8))
    base.update(kw)
    return View(**base)


def test_backproject_hand_computed_and_invalid():
    K = np.array([[2.0, 0, 1], [0, 4, 1], [0, 0, 1]])
    d = np.full((3, 3), 2.0, np.float32)
    d[0, 0] = 0
    p = backproject(d, K)
    assert p.shape == (3, 3, 3) and p.dtype == np.float32
    np.testing.assert_allclose(p[2, 2], [(2 - 1) / 2 * 2, (2 - 1) / 4 * 2, 2])
    assert np.isnan(p[0, 0]).all()
    T = np.eye(4)
    T[:3, 3] = [1, 2, 3]
    np.testing.assert_allclose(backproject(d, K, T)[2, 2], p[2, 2] + [1, 2, 3])


def test_camera_points_and_z_depth_agree_from_points_or_depth():
    K = np.array([[3.0, 0, 2], [0, 3, 1.5], [0, 0, 1]])
    T = np.eye(4)
    T[:3, :3] = np.diag([1, -1, -1])
    T[:3, 3] = [0.1, 0.2, 1.0]
    depth = np.linspace(0.5, 1.5, 20, dtype=np.float32).reshape(4, 5)
    from_points = view(points=backproject(depth, K, T), cam_to_world=T)
    from_depth = view(depth=depth, K=K)
    np.testing.assert_allclose(from_points.camera_points(), from_depth.camera_points(), atol=1e-5)
    np.testing.assert_allclose(from_points.z_depth(), depth, atol=1e-5)
    with pytest.raises(SceneError, match="depth"):
        view().camera_points()


@pytest.mark.parametrize(
    ("kw", "field"),
    [
        (dict(rgb=np.zeros((4, 5), np.uint8)), "rgb"),
        (dict(depth=np.zeros((3, 5), np.float32)), "depth"),
        (dict(depth=np.zeros((4, 5), np.uint16)), "depth"),
        (dict(points=np.zeros((4, 5, 2), np.float32)), "points"),
        (dict(confidence=np.zeros((4, 4))), "confidence"),
        (dict(instances=np.zeros((4, 5), np.float32)), "instances"),
        (dict(K=np.eye(2)), "K"),
        (dict(cam_to_world=np.eye(3)), "cam_to_world"),
        (dict(cam_to_world=np.full((4, 4), np.nan)), "cam_to_world"),
        (dict(cam_to_world=np.diag([1.0, 1, -1, 1])), "cam_to_world"),
    ],
)
def test_view_validate_names_the_field(kw, field):
    with pytest.raises(SceneError, match=f"v: {field}"):
        view(**kw).validate()


def test_scene_validate_and_select():
    with pytest.raises(SceneError, match="no views"):
        Scene([]).validate()
    with pytest.raises(SceneError, match="unique"):
        Scene([view(), view()]).validate()
    s = Scene([view(name="a"), view(name="b"), view(name="c")], {1: "x"})
    assert [v.name for v in s.select([2, 0])] == ["c", "a"] and len(s) == 3
    assert not s.has_depth and not s.has_points and not s.has_poses and not s.has_instances


def test_matches_shapes_and_errors():
    m = Matches([[1, 2]], [[3, 4]], [0.5])
    assert m.xy_i.dtype == np.float32 and m.xy_i.shape == (1, 2) and len(m) == 1
    with pytest.raises(ValueError, match=r"one M \(got 2, 1, 1\)"):
        Matches([[1, 2], [3, 4]], [[0, 0]], [1.0])
    assert len(Matches(np.zeros((0, 2)), np.zeros((0, 2)), [])) == 0


def test_is_rigid():
    R = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1.0]])
    T = np.eye(4)
    T[:3, :3] = R
    assert is_rigid(T) and not is_rigid(T[:3]) and not is_rigid(np.full((4, 4), np.nan))
