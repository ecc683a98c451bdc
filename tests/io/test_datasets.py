import json

import numpy as np
import pytest
from scipy.io import savemat
from scipy.spatial import cKDTree

from graphseg.io import detect_format, load_scene, read_bop, read_graspnet, read_ycbv
from graphseg.io.images import write_png
from graphseg.scene import SceneError, is_rigid
from graphseg.sim.boxes import Box, intrinsics, look_at, render_boxes

BOX = [Box((0.0, 0.0, 0.05), (0.1, 0.08, 0.1), 0.3)]


def render(eye, w=64, h=48):
    K = intrinsics(w, h, 60)
    T = look_at(eye, [0, 0, 0])
    return render_boxes(BOX, T, K, (h, w)), K, T


def test_ycbv_two_views_of_one_object_overlap(ycbv_root):
    s = read_ycbv(ycbv_root / "0001", views=[0, 19])
    assert [v.name for v in s.views] == ["000001", "000020"]
    assert s.objects[1] == "002_master_chef_can"
    from graphseg.backends.lifters.rgbd import RGBDLifter

    s = RGBDLifter()(s)
    for obj in (1, 2):
        a = s.views[0].points[s.views[0].instances == obj]
        b = s.views[1].points[s.views[1].instances == obj]
        a, b = a[np.isfinite(a).all(1)], b[np.isfinite(b).all(1)]
        d, _ = cKDTree(b).query(a, k=1)
        assert np.median(d) < 0.005, (obj, np.median(d))
    assert detect_format(ycbv_root / "0001") == "ycbv"
    assert len(load_scene(ycbv_root / "0002", num_views=10)) == 10


def test_ycbv_fixture_and_errors(tmp_path):
    r, K, T = render([0.3, -0.3, 0.3])
    w2c = np.linalg.inv(T)
    for fr in ("000001", "000002"):
        write_png(tmp_path / f"{fr}-color.png", r.rgb)
        write_png(tmp_path / f"{fr}-depth.png", np.rint(r.depth * 10000).astype(np.uint16))
        write_png(tmp_path / f"{fr}-label.png", r.instances.astype(np.uint8))
        savemat(tmp_path / f"{fr}-meta.mat", {"intrinsic_matrix": K, "factor_depth": np.array([[10000]]), "rotation_translation_matrix": w2c[:3]})
    s = read_ycbv(tmp_path)
    np.testing.assert_allclose(s.views[0].cam_to_world, T, atol=1e-9)
    np.testing.assert_allclose(s.views[0].depth, np.rint(r.depth * 10000) / 10000, atol=1e-6)
    savemat(tmp_path / "000002-meta.mat", {"intrinsic_matrix": K})
    with pytest.raises(SceneError, match="000002-meta.mat: factor_depth: missing"):
        read_ycbv(tmp_path)


def build_graspnet(root, n=3):
    cam = root / "scene_0000" / "realsense"
    for d in ("rgb", "depth", "label", "meta"):
        (cam / d).mkdir(parents=True)
    eyes = [[0.3, -0.3, 0.35], [0.35, -0.2, 0.35], [0.25, -0.35, 0.3]][:n]
    poses = []
    T0 = None
    for k, eye in enumerate(eyes):
        r, K, T = render(eye)
        T0 = T if T0 is None else T0
        poses.append(np.linalg.inv(T0) @ T)  # relative to the first camera
        write_png(cam / "rgb" / f"{k:04d}.png", r.rgb)
        write_png(cam / "depth" / f"{k:04d}.png", np.rint(r.depth * 1000).astype(np.uint16))
        write_png(cam / "label" / f"{k:04d}.png", r.instances.astype(np.uint8))
        savemat(cam / "meta" / f"{k:04d}.mat", {"intrinsic_matrix": K, "factor_depth": np.array([[1000.0]])})
    np.save(cam / "camera_poses.npy", np.stack(poses))
    np.save(cam / "camK.npy", K)
    return root / "scene_0000", T0


def test_graspnet_fixture(tmp_path):
    scene_dir, T0 = build_graspnet(tmp_path)
    s = read_graspnet(scene_dir)
    assert detect_format(scene_dir) == "graspnet"
    assert len(s) == 3 and all(is_rigid(v.cam_to_world) for v in s.views)
    np.testing.assert_allclose(s.views[0].cam_to_world, np.eye(4), atol=1e-9)
    # with the table frame given, poses come out in the world (here: the renderer's) frame
    np.save(scene_dir / "realsense" / "cam0_wrt_table.npy", T0)
    s = read_graspnet(scene_dir, num_views=2)
    from graphseg.backends.lifters.rgbd import RGBDLifter

    s = RGBDLifter()(s)
    for v in s.views:
        pts = v.points[v.instances == 1]
        pts = pts[np.isfinite(pts).all(1)]
        c, sn = np.cos(0.3), np.sin(0.3)  # into the box frame (yaw 0.3): every point on the box surface
        local = (pts - [0, 0, 0.05]) @ np.array([[c, -sn, 0], [sn, c, 0], [0, 0, 1]])
        assert (np.abs(local) <= np.array([0.05, 0.04, 0.05]) + 0.004).all(1).mean() > 0.98
    with pytest.raises(SceneError, match="camera_poses"):
        read_graspnet(tmp_path)


def build_bop(root, with_pose=True):
    for d in ("rgb", "depth", "mask_visib"):
        (root / d).mkdir(parents=True)
    cams, gts = {}, {}
    for im, eye in enumerate([[0.3, -0.3, 0.35], [0.35, -0.2, 0.35]]):
        r, K, T = render(eye)
        w2c = np.linalg.inv(T)
        write_png(root / "rgb" / f"{im:06d}.png", r.rgb)
        write_png(root / "depth" / f"{im:06d}.png", np.rint(r.depth * 10000).astype(np.uint16))  # depth_scale 0.1 mm
        write_png(root / "mask_visib" / f"{im:06d}_{0:06d}.png", (r.instances == 1).astype(np.uint8) * 255)
        cam = {"cam_K": K.ravel().tolist(), "depth_scale": 0.1}
        if with_pose:
            cam.update(cam_R_w2c=w2c[:3, :3].ravel().tolist(), cam_t_w2c=(w2c[:3, 3] * 1000).tolist())
        cams[str(im)] = cam
        gts[str(im)] = [{"obj_id": 5, "cam_R_m2c": np.eye(3).ravel().tolist(), "cam_t_m2c": [0, 0, 0]}]
    (root / "scene_camera.json").write_text(json.dumps(cams))
    (root / "scene_gt.json").write_text(json.dumps(gts))
    return T


def test_bop_fixture(tmp_path):
    T = build_bop(tmp_path / "000001")
    s = read_bop(tmp_path / "000001")
    assert detect_format(tmp_path / "000001") == "bop"
    assert s.objects == {1: "obj_000005"}
    np.testing.assert_allclose(s.views[1].cam_to_world, T, atol=1e-6)
    assert s.views[0].instances.max() == 1 and s.views[0].depth.max() < 2.0
    build_bop(tmp_path / "nopose", with_pose=False)
    with pytest.raises(SceneError, match="cam_R_w2c"):
        read_bop(tmp_path / "nopose")
