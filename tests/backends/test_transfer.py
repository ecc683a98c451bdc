import numpy as np
import pytest

from graphseg.backends.lifters.transfer import transfer_points
from graphseg.scene import backproject

K = np.array([[40.0, 0, 15.5], [0, 40, 11.5], [0, 0, 1]])
H, W = 24, 32


def _cam(x: float) -> np.ndarray:
    T = np.eye(4)
    T[0, 3] = x
    return T


def _wall(T: np.ndarray, z: float = 1.0) -> np.ndarray:
    return backproject(np.full((H, W), z, np.float32), K, T)


def _grey(v: int = 128) -> np.ndarray:
    return np.full((H, W, 3), v, np.uint8)


def _run(pts, conf=None, rgb=None, poses=None, **kw):
    n = len(pts)
    conf = conf or [np.ones((H, W), np.float32)] * n
    rgb = rgb or [_grey()] * n
    poses = poses or [_cam(0.05 * i) for i in range(n)]
    opts = dict(min_confidence=0.5, max_color_distance=30.0, color_blur=0.0, confidence_out=0.5)
    opts.update(kw)
    return transfer_points(pts, conf, rgb, [K] * n, poses, **opts)


def test_shapes_dtypes_and_inputs_untouched():
    T0, T1 = _cam(0.0), _cam(0.05)
    p0, p1 = _wall(T0), _wall(T1)
    p1[:, :16] = np.nan
    before = p1.copy()
    out, conf, added = _run([p0, p1])
    assert [o.shape for o in out] == [(H, W, 3)] * 2 and out[1].dtype == np.float32
    assert [c.shape for c in conf] == [(H, W)] * 2 and conf[1].dtype == np.float32
    assert len(added) == 2 and added[0] == 0.0  # view 0 had no empty pixel
    np.testing.assert_array_equal(np.isnan(p1), np.isnan(before))  # not mutated


def test_transferred_points_are_the_measured_ones():
    # view 1 is 5 cm (2 px at 1 m) right of view 0 and misses its left half; every
    # pixel view 0 sees with a normal (2 px border lost) lands exactly on view 1's grid
    T0, T1 = _cam(0.0), _cam(0.05)
    p1 = _wall(T1)
    p1[:, :16] = np.nan
    out, conf, added = _run([_wall(T0), p1])
    np.testing.assert_allclose(out[1][2:-2, :16], _wall(T1)[2:-2, :16], atol=1e-6)
    assert added[1] == pytest.approx(20 * 16 / (H * W))
    assert (conf[1][2:-2, :16] == 0.5).all() and (conf[1][:, 16:] == 1.0).all()


def test_nearest_point_wins_and_colour_refuses_a_hidden_one():
    # view 0 sees a near wall (0.5 m) on its left and a far one (1 m) behind; both project into the
    # empty view 1: the near one must win where both land
    T0, T1 = _cam(0.0), _cam(0.0)
    near, far = _wall(T0, 0.5), _wall(T0, 1.0)
    src = np.where(np.arange(W)[None, :, None] < 16, near, far).astype(np.float32)
    empty = np.full((H, W, 3), np.nan, np.float32)
    out, _, _ = _run([src, empty], poses=[T0, T1])
    z = out[1][..., 2]
    assert np.nanmax(z[3:-3, 3:13]) == pytest.approx(0.5) and np.nanmin(z[3:-3, 19:29]) == pytest.approx(1.0)
    # a target pixel whose colour differs from the source's refuses the point
    rgb1 = _grey(128).copy()
    rgb1[:, 16:] = 20
    out, _, added = _run([src, empty], rgb=[_grey(128), rgb1], poses=[T0, T1])
    assert np.isnan(out[1][:, 16:]).all() and np.isfinite(out[1][3:-3, 3:13]).all()
    out, _, _ = _run([src, empty], rgb=[_grey(128), rgb1], poses=[T0, T1], max_color_distance=None)
    assert np.isfinite(out[1][3:-3, 19:29]).all()


def test_back_facing_points_are_not_transferred():
    # a camera behind the wall, looking at it from the other side, must not take its points
    T0 = _cam(0.0)
    back = np.eye(4)
    back[:3, :3] = np.diag([-1.0, 1.0, -1.0])  # turned around
    back[2, 3] = 2.0
    out, _, added = _run([_wall(T0), np.full((H, W, 3), np.nan, np.float32)], poses=[T0, back])
    assert added[1] == 0.0 and np.isnan(out[1]).all()


def test_low_confidence_and_no_other_view():
    T0, T1 = _cam(0.0), _cam(0.05)
    empty = np.full((H, W, 3), np.nan, np.float32)
    out, _, added = _run([_wall(T0), empty], conf=[np.full((H, W), 0.25, np.float32), np.zeros((H, W), np.float32)])
    assert added == [0.0, 0.0] and np.isnan(out[1]).all()
    out, _, added = _run([empty])
    assert added == [0.0]
    with pytest.raises(ValueError, match="one confidence, image, K and pose"):
        transfer_points([empty, empty], [np.zeros((H, W))], [_grey()] * 2, [K] * 2, [T0, T1], min_confidence=0.5, max_color_distance=None, color_blur=0.0, confidence_out=0.5)
