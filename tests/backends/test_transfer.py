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


def test_inputs_are_not_mutated_and_any_memory_order_works():
    T0, T1 = _cam(0.0), _cam(0.05)
    p1 = _wall(T1)
    p1[:, :16] = np.nan
    conf = [np.ones((H, W), np.float32), np.ones((H, W), np.float32)]
    out_p, _, _ = _run([_wall(T0), p1], conf=conf)
    assert (conf[1] == 1.0).all() and np.isnan(p1[:, :16]).all()
    fortran = [np.asfortranarray(_wall(T0)), np.asfortranarray(p1)]
    out_f, conf_f, added_f = _run(fortran, conf=[np.asfortranarray(c) for c in conf])
    np.testing.assert_array_equal(out_f[1], out_p[1])
    assert added_f[1] > 0 and (conf_f[1][2:-2, :16] == 0.5).all()


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
    # view 0 sees a near wall (0.5 m), view 1 a far one (1 m), both over the whole image; the empty
    # view 2 (at view 0's place) receives both on the same pixels: the near one must win
    T = _cam(0.0)
    near, far = _wall(T, 0.5), _wall(T, 1.0)
    empty = np.full((H, W, 3), np.nan, np.float32)
    for order in ((near, far), (far, near)):
        out, _, _ = _run([*order, empty], poses=[T, T, T])
        z = out[2][..., 2]
        assert np.isfinite(z[2:-2, 2:-2]).all() and np.nanmax(z) == pytest.approx(0.5)
    # a target pixel whose colour differs from the near source's refuses it, and the far
    # point behind it is not tried: the pixel stays empty
    rgb = [_grey(128), _grey(128), _grey(128).copy()]
    rgb[1][:] = 20
    rgb[2][:, 16:] = 20
    out, _, _ = _run([near, far, empty], rgb=rgb, poses=[T, T, T])
    assert np.isnan(out[2][:, 16:]).all() and np.isfinite(out[2][2:-2, 2:16]).all()
    out, _, _ = _run([near, far, empty], rgb=rgb, poses=[T, T, T], max_color_distance=None)
    assert np.isfinite(out[2][2:-2, 2:-2]).all()


def test_back_facing_points_are_not_transferred():
    # a camera behind the wall, looking at it from the other side, must not take its points
    T0 = _cam(0.0)
    back = np.eye(4)
    back[:3, :3] = np.diag([-1.0, 1.0, -1.0])  # turned around
    back[2, 3] = 2.0
    out, _, added = _run([_wall(T0), np.full((H, W, 3), np.nan, np.float32)], poses=[T0, back])
    assert added[1] == 0.0 and np.isnan(out[1]).all()
    # a back-facing surface nearer than a front-facing one hides it: the pixel stays empty.
    # A turned camera at z = 1 measures a plate at z = 0.5 from behind (as seen from the origin),
    # as densely as the origin sees it; view 0 measures a wall at z = 1; the empty view 2 sits at
    # the origin: the plate is nearer
    near_back = back.copy()
    near_back[2, 3] = 1.0
    plate = _wall(near_back, 0.5)
    empty = np.full((H, W, 3), np.nan, np.float32)
    out, _, added = _run([_wall(T0, 1.0), empty.copy(), empty], poses=[T0, near_back, T0])
    assert added[2] > 0.5  # the wall alone is taken
    out, _, added = _run([_wall(T0, 1.0), plate, empty], poses=[T0, near_back, T0])
    assert np.isnan(out[2][2:-2, 3:-3]).all()  # where the plate lands


def test_low_confidence_and_no_other_view():
    T0, T1 = _cam(0.0), _cam(0.05)
    empty = np.full((H, W, 3), np.nan, np.float32)
    out, _, added = _run([_wall(T0), empty], conf=[np.full((H, W), 0.25, np.float32), np.zeros((H, W), np.float32)])
    assert added == [0.0, 0.0] and np.isnan(out[1]).all()
    out, _, added = _run([empty])
    assert added == [0.0]
    with pytest.raises(ValueError, match=r"view 1: expected points \[H, W, 3\] with confidence \[H, W\] and an image"):
        _run([_wall(T0), empty], rgb=[_grey(), np.zeros((H, W + 1, 3), np.uint8)])
    with pytest.raises(ValueError, match="one confidence, image, K and pose"):
        transfer_points([empty, empty], [np.zeros((H, W))], [_grey()] * 2, [K] * 2, [T0, T1], min_confidence=0.5, max_color_distance=None, color_blur=0.0, confidence_out=0.5)
