import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from graphseg.backends.lifters.align import (
    NOMINAL_WORKING_DISTANCE,
    PairPointMaps,
    apply_similarity,
    estimate_focal,
    global_align,
    metric_scale,
    similarity_to_known_poses,
    umeyama,
)
from graphseg.scene import Scene
from graphseg.testing.scenes import box_scene, random_boxes


def synthetic_pairs(scene, *, noise=0.01, rng=0, symmetric=True):
    """DUSt3R-like predictions from ground truth: both views in i's camera frame, a random scale per pair."""
    gen = np.random.default_rng(rng)
    cams = [v.camera_points().astype(np.float64) for v in scene.views]
    T = [np.asarray(v.cam_to_world) for v in scene.views]
    out = []
    n = scene.num_views
    for i in range(n):
        for j in range(n):
            if i == j or (not symmetric and j < i):
                continue
            rel = np.linalg.inv(T[i]) @ T[j]
            pj = cams[j] @ rel[:3, :3].T + rel[:3, 3]
            s = gen.uniform(0.3, 3.0)
            maps = []
            for p in (cams[i], pj):
                d = np.linalg.norm(p, axis=-1, keepdims=True)
                q = p + gen.normal(0, 1, p.shape) * noise * d  # 1% of the distance to the camera
                maps.append((s * q).astype(np.float32))
            conf = [np.where(np.isfinite(m).all(-1), gen.uniform(1, 3, m.shape[:2]), 0).astype(np.float32) for m in maps]
            out.append(PairPointMaps(i, j, np.nan_to_num(maps[0], nan=0.0) * (conf[0] > 0)[..., None], np.nan_to_num(maps[1], nan=0.0) * (conf[1] > 0)[..., None], conf[0], conf[1]))
    return out


def rotation_error_deg(A, B):
    return float(np.degrees(Rotation.from_matrix(A[:3, :3].T @ B[:3, :3]).magnitude()))


def test_umeyama_shapes_exact_and_rigid():
    gen = np.random.default_rng(1)
    src = gen.normal(size=(50, 3))
    R0 = Rotation.random(random_state=2).as_matrix()
    s, R, t = umeyama(src, 1.7 * src @ R0.T + [0.1, -2, 3])
    assert R.shape == (3, 3) and t.shape == (3,) and abs(s - 1.7) < 1e-9 and np.allclose(R, R0) and np.allclose(t, [0.1, -2, 3])
    s1, R1, _ = umeyama(src, src @ R0.T, with_scale=False)
    assert s1 == 1.0 and np.allclose(R1, R0)
    mirror = src * [1, 1, -1]  # a reflection is never returned
    assert np.linalg.det(umeyama(src, mirror)[1]) > 0
    with pytest.raises(ValueError, match=r"expected at least 3 point pairs \(got 2\)"):
        umeyama(src[:2], src[:2])
    with pytest.raises(ValueError, match=r"expected src and dst of shape \[N, 3\]"):
        umeyama(src[:, :2], src[:, :2])


def test_global_alignment_recovers_ground_truth_poses():
    """Acceptance: 1% point noise and a random scale per pair -> < 1 deg rotation, < 1% translation error."""
    scene = box_scene(random_boxes(3, 5), views=5, shape=(48, 64), arc_deg=120, rng=3)
    pairs = synthetic_pairs(scene, noise=0.01, rng=4)
    al = global_align(pairs, scene.num_views, iterations=5, rng=0)
    assert len(al.points) == 5 and al.points[0].shape == (48, 64, 3) and al.cam_to_world.shape == (5, 4, 4) and al.K.shape == (5, 3, 3)
    gt = np.stack([v.cam_to_world for v in scene.views])
    s, R, t, how = similarity_to_known_poses(al.cam_to_world, gt)
    assert how == "umeyama"
    mapped = apply_similarity(Scene([v.replace(points=p, cam_to_world=T) for v, p, T in zip(scene.views, al.points, al.cam_to_world)]), s, R, t)
    size = np.linalg.norm(np.ptp(np.concatenate([v.points[np.isfinite(v.points).all(-1)] for v in scene.views]), axis=0))
    rot_err = max(rotation_error_deg(a.cam_to_world, b) for a, b in zip(mapped.views, gt))
    trans_err = max(np.linalg.norm(a.cam_to_world[:3, 3] - b[:3, 3]) for a, b in zip(mapped.views, gt)) / size
    print(f"rotation error {rot_err:.4f} deg, translation error {100 * trans_err:.4f} % of the scene size")
    assert rot_err < 1.0, rot_err
    assert trans_err < 0.01, trans_err
    # the world point maps land on the ground truth too (median error well under the noise)
    err = np.concatenate([np.linalg.norm(a.points - b.points, axis=-1)[np.isfinite(b.points).all(-1)] for a, b in zip(mapped.views, scene.views)])
    assert np.median(err) < 0.01 * size
    # focal lengths from the point maps
    assert np.allclose(al.K[:, 0, 0], scene.views[0].K[0, 0], rtol=0.02)
    assert al.info["residuals"][-1] <= al.info["residuals"][0] + 1e-9


def test_tree_initialisation_alone_is_close_and_inputs_are_checked():
    scene = box_scene(random_boxes(5, 4), views=3, shape=(32, 40), rng=5)
    pairs = synthetic_pairs(scene, noise=0.0, rng=6)
    al = global_align(pairs, 3, iterations=0, rng=0)
    gt = np.stack([v.cam_to_world for v in scene.views])
    s, R, t, _ = similarity_to_known_poses(al.cam_to_world, gt)
    for a, b in zip(al.cam_to_world, gt):
        assert np.allclose(s * R @ a[:3, 3] + t, b[:3, 3], atol=1e-4)
    with pytest.raises(ValueError, match="every view must come first"):
        global_align([p for p in pairs if p.i != 2], 3)
    with pytest.raises(ValueError, match="not connected"):
        a, b = pairs[0].of(0)
        global_align([PairPointMaps(i, j, a, a, b, b) for i, j in ((0, 1), (1, 0), (2, 3), (3, 2))], 4)
    with pytest.raises(ValueError, match="distinct views"):
        global_align([PairPointMaps(0, 0, *pairs[0].of(0), *pairs[0].of(0))], 1)


def test_focal_hand_computed():
    pts = np.zeros((2, 2, 3))
    pts[..., 2] = 1.0
    pts[..., 0] = np.array([[-1, 1], [-1, 1]]) * 0.5 / 10  # u - cx = -0.5, 0.5 with f = 10
    pts[..., 1] = np.array([[-1, -1], [1, 1]]) * 0.5 / 10
    assert abs(estimate_focal(pts) - 10.0) < 1e-9
    assert estimate_focal(np.full((2, 3, 3), np.nan)) == 3.0  # nothing valid: the image size


def test_metric_scale_known_poses_and_nominal():
    scene = box_scene(random_boxes(7, 3), views=4, shape=(24, 32), rng=7)
    R0 = Rotation.from_euler("xyz", [10, -20, 30], degrees=True).as_matrix()
    shrunk = apply_similarity(scene, 0.2, R0, np.array([1.0, 2, 3]))
    known = [v.cam_to_world for v in scene.views]
    back = metric_scale(shrunk, known)
    assert back.meta["scale"]["metric"] and back.meta["scale"]["method"] == "known-poses-umeyama"
    assert abs(back.meta["scale"]["factor"] - 5.0) < 1e-6
    for a, b in zip(back.views, scene.views):
        assert np.allclose(a.cam_to_world, b.cam_to_world, atol=1e-6)
        assert np.allclose(a.points, b.points, atol=1e-5, equal_nan=True)
    two = metric_scale(shrunk.select([0, 1]), known[:2])  # two views: orientation + baseline
    assert two.meta["scale"]["method"] == "known-poses-baseline"
    assert np.allclose(two.views[1].cam_to_world, known[1], atol=1e-6)
    nominal = metric_scale(shrunk)
    assert not nominal.meta["scale"]["metric"] and nominal.meta["scale"]["method"] == "nominal-distance"
    v = nominal.views[0]
    d = np.linalg.norm(v.points[::1].reshape(-1, 3)[::7] - v.cam_to_world[:3, 3], axis=1)
    assert abs(np.nanmedian(d) - NOMINAL_WORKING_DISTANCE) < 0.05


@pytest.mark.parametrize("known", [True, False])
def test_aligned_and_scaled_point_maps_segment_like_ground_truth(known):
    """Synthetic DUSt3R-like pairs (1% noise, random scales) -> alignment -> metric scale -> GraphSeg finds both boxes."""
    from graphseg.backends.lifters.align import lift_from_alignment
    from graphseg.config import Config
    from graphseg.method.segment import segment
    from graphseg.metrics import evaluate
    from graphseg.scene import View
    from graphseg.testing.scenes import two_boxes_scene

    scene, masks, matches = two_boxes_scene(views=3)
    al = global_align(synthetic_pairs(scene, noise=0.01, rng=1), 3, iterations=5, rng=0)
    base = Scene([View(v.name, v.rgb, cam_to_world=v.cam_to_world if known else None) for v in scene.views])
    lifted = lift_from_alignment(base, al, scene.views[0].shape)
    assert lifted.meta["scale"]["metric"] is known
    result = segment(lifted, masks, matches, Config.preset("rgbd"))
    m = evaluate(result.labels, [v.instances for v in scene.views], [v.points for v in scene.views])
    assert result.num_objects == 2 and m["mean"]["iou"] > 0.98
