import numpy as np
import pytest

from graphseg.sim.boxes import Box, intrinsics, look_at, render_boxes
from graphseg.sim.pybullet_scenes import CameraRig, linearize_depth, projection_K

pb = pytest.importorskip("pybullet")


def test_linearize_depth_hand_computed():
    near, far = 0.1, 10.0
    # z = near -> buffer 0, z = far -> buffer ~1 ; pick z = 1: d = (far - far*near/z) / (far - near)
    d = (far - far * near / 1.0) / (far - near)
    assert linearize_depth(np.array([d]), near, far)[0] == pytest.approx(1.0, rel=1e-6)
    assert linearize_depth(np.array([1.0]), near, far)[0] == 0.0


def test_principal_point_and_depth_match_ray_casting():
    """Back-project rendered depth through our K and pose; a ray cast through the same pixel must agree."""
    import pybullet_data

    from graphseg.sim.pybullet_scenes import render_view

    cid = pb.connect(pb.DIRECT)
    try:
        pb.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=cid)
        pb.loadURDF("plane.urdf", physicsClientId=cid)
        pb.loadURDF("cube_small.urdf", [0.03, -0.02, 0.025], physicsClientId=cid)
        pb.loadURDF("cube.urdf", [-0.8, 0, 0.5], useFixedBase=True, physicsClientId=cid)  # a wall at x = -0.3
        # one view where depth varies along image rows (floor), one along columns (wall)
        for eye, target, shift in (([0.35, -0.25, 0.3], [0.0, 0.0, 0.0], (0.0, 0.5)), ([0.0, -0.4, 0.5], [-0.3, 0.1, 0.5], (0.5, 0.0))):
            eye, target = np.array(eye), np.array(target)
            w, h = 160, 120
            rgb, depth, body, K, T = render_view(pb, cid, eye, target, (w, h), 50.0)
            np.testing.assert_allclose(K, projection_K(w, h, 50.0))

            def ray_depth_error(K):
                ys, xs = np.mgrid[4 : h - 4 : 5, 4 : w - 4 : 5]
                ys, xs = ys.ravel(), xs.ravel()
                rays = np.stack([(xs - K[0, 2]) / K[0, 0], (ys - K[1, 2]) / K[1, 1], np.ones_like(xs, float)], 1) @ T[:3, :3].T
                hits = pb.rayTestBatch([eye.tolist()] * len(xs), (eye + 5.0 * rays).tolist(), physicsClientId=cid)
                frac = np.array([hh[2] for hh in hits])
                ok = (frac < 1) & (depth[ys, xs] > 0)
                return np.median(np.abs(frac[ok] * 5.0 - depth[ys, xs][ok]))  # rays have unit z: t = z-depth

            assert ray_depth_error(K) < 1e-4
            K2 = K.copy()  # half a pixel off along the axis where depth varies is measurably worse
            K2[0, 2] += shift[0]
            K2[1, 2] += shift[1]
            assert ray_depth_error(K2) > 10 * max(ray_depth_error(K), 1e-6)
        assert body.max() >= 1
    finally:
        pb.disconnect(physicsClientId=cid)


def test_synthesize_is_deterministic_with_valid_ground_truth():
    from graphseg.sim.pybullet_scenes import synthesize

    a = synthesize(seed=3, objects=4, views=3, size=(160, 120))
    b = synthesize(seed=3, objects=4, views=3, size=(160, 120))
    assert len(a) == 3 and a.objects == b.objects and len(a.objects) >= 1
    for x, y in zip(a.views, b.views):
        assert np.array_equal(x.rgb, y.rgb) and np.array_equal(x.instances, y.instances)
        np.testing.assert_allclose(x.cam_to_world, y.cam_to_world)
    a.validate()
    v = a.views[0]
    assert v.depth.dtype == np.float32 and set(np.unique(v.instances)) <= {0, *a.objects}
    # objects rest on the table: their lowest back-projected points sit near the table top
    from graphseg.backends.lifters.rgbd import RGBDLifter
    from graphseg.sim.pybullet_scenes import TABLE_TOP

    pts = RGBDLifter()(a).views[0].points
    table = pts[(v.instances == 0) & (np.abs(pts[..., 2] - TABLE_TOP) < 0.01)]
    assert len(table) > 100


def test_box_renderer_geometry():
    K = intrinsics(80, 60, 60)
    T = look_at([0.0, -0.5, 0.5], [0, 0, 0])
    r = render_boxes([Box((0, 0, 0.05), (0.1, 0.1, 0.1))], T, K, (60, 80))
    pts = r.points[r.instances == 1]
    assert (np.abs(pts[:, :2]) <= 0.0501).all() and (pts[:, 2] <= 0.1001).all()
    table = r.points[r.instances == 0]
    table = table[np.isfinite(table).all(1)]
    assert np.abs(table[:, 2]).max() < 1e-5


def test_stress_layouts_put_objects_together():
    from graphseg.sim.pybullet_scenes import synthesize

    def gaps(scene):
        cents = []
        v = scene.views[0]
        pts = v.camera_points()
        for k in np.unique(v.instances[v.instances > 0]):
            cents.append(np.nanmean(pts[v.instances == k], axis=0))
        c = np.array(cents)
        d = np.linalg.norm(c[:, None] - c[None], axis=-1) + np.eye(len(c)) * 9
        return float(np.median(d.min(axis=1)))

    spread = synthesize(seed=5, objects=5, views=1, size=(160, 120))
    touching = synthesize(seed=5, objects=5, views=1, size=(160, 120), layout="touching")
    assert touching.meta["layout"] == "touching"
    assert gaps(touching) < gaps(spread)
    stacked = synthesize(seed=5, objects=3, views=1, size=(160, 120), layout="stacked")
    assert stacked.meta["layout"] == "stacked" and stacked.views[0].instances.max() >= 1


def test_unknown_layout():
    from graphseg.sim.pybullet_scenes import synthesize

    with pytest.raises(ValueError, match="unknown layout"):
        synthesize(layout="pile")


@pytest.mark.slow
@pytest.mark.parametrize("layout", ["spread", "touching", "stacked"])
def test_every_requested_object_stays_on_the_table(layout):
    """Issue 19: seeds 0..20 with 6 objects and seeds 0..4 with 16 keep every object (none fell off).

    (Checked once for seeds 0..99 with 3, 6, 10 and 16 objects in every layout.)
    """
    from graphseg.sim.pybullet_scenes import synthesize

    for objects, seeds in ((6, range(21)), (16, range(5))):
        for seed in seeds:
            s = synthesize(seed=seed, objects=objects, views=1, size=(16, 16), layout=layout)
            assert s.meta["fell_off"] == [], (layout, objects, seed, s.meta["fell_off"])
            assert len(s.objects) == objects == s.meta["objects_requested"], (layout, objects, seed)


def test_objects_rest_on_the_measured_table_top():
    """The table's top is measured from pybullet (not guessed), and every kept object is seen standing on it."""
    import pybullet_data

    from graphseg.sim.pybullet_scenes import TABLE_TOP, synthesize

    cid = pb.connect(pb.DIRECT)
    try:
        pb.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=cid)
        table = pb.loadURDF("table/table.urdf", [0, 0, 0], useFixedBase=True, physicsClientId=cid)
        lo, hi = pb.getAABB(table, physicsClientId=cid)
    finally:
        pb.disconnect(physicsClientId=cid)
    assert hi[2] == pytest.approx(TABLE_TOP, abs=1e-3)
    assert hi[0] == pytest.approx(0.751, abs=1e-3) and hi[1] == pytest.approx(0.501, abs=1e-3)
    s = synthesize(seed=0, objects=6, views=4, size=(160, 120))
    seen = set()
    for v in s.views:
        pts = v.camera_points() @ v.cam_to_world[:3, :3].T + v.cam_to_world[:3, 3]
        for k in np.unique(v.instances[v.instances > 0]):
            p = pts[v.instances == k]
            p = p[np.isfinite(p).all(1)]
            # inside the top's extent and no point below it
            assert (np.abs(p[:, 0]) < hi[0]).all() and (np.abs(p[:, 1]) < hi[1]).all()
            assert p[:, 2].min() > TABLE_TOP - 0.005
            seen.add(int(k))
    assert seen == set(s.objects) and len(seen) == 6


def test_fell_off_warning_wording():
    from graphseg.scene import fell_off_warning
    from graphseg.sim.pybullet_scenes import synthesize

    s = synthesize(seed=1, objects=3, views=1, size=(16, 16))
    assert s.meta["fell_off"] == [] and fell_off_warning(s) is None
    s.meta["fell_off"] = ["sphere"]  # the rare leftover case, as the CLI and the job report it
    assert fell_off_warning(s) == "1 of 3 objects did not stay on the table and are not in the scene: sphere"


# --------------------------------------------------------------- issue 20: generator options


def _digest(scene):
    import hashlib

    m = hashlib.sha256()
    for v in scene.views:
        for a in (v.rgb, v.depth, v.instances, v.K, v.cam_to_world):
            m.update(np.ascontiguousarray(a).tobytes())
    m.update(repr(sorted(scene.objects.items())).encode())
    return m.hexdigest()


@pytest.mark.parametrize(
    "kwargs, expected",
    [
        # computed with the generator as it was before the options (object_set, table_texture, lighting) existed
        (dict(seed=0, objects=3, views=2, size=(96, 72)), "728ee55ec4bc17e595348d2033500c20e08717cf354a1b1ab6d8e5cd466728e5"),
        (dict(seed=7, objects=5, views=3, size=(160, 120), cameras=CameraRig(arc_deg=50.0), layout="touching"), "878e1dff9a9008387fc7480a9b15ab2680713574538366cb1029fd065aa7d98e"),
    ],
)
def test_default_output_is_unchanged_by_the_options(kwargs, expected):
    from graphseg.sim.pybullet_scenes import synthesize

    s = synthesize(**kwargs)
    assert _digest(s) == expected
    assert {"object_set", "table_texture", "lighting"}.isdisjoint(s.meta)
    # the defaults spelt out give the same scene
    assert _digest(synthesize(**kwargs, object_set="bundled", table_texture=None, lighting=None)) == expected


_OPTIONS = dict(seed=11, objects=4, views=2, size=(64, 48), object_set="mixed", table_texture="noise", lighting="vary", cameras=CameraRig(arc_deg=40.0))


def test_options_render_byte_identically_across_processes():
    import json
    import subprocess
    import sys

    from graphseg.sim.pybullet_scenes import synthesize

    code = (
        "import json, sys\n"
        "from tests.test_sim import _digest\n"
        "from graphseg.sim.pybullet_scenes import CameraRig, synthesize\n"
        "kw = json.loads(sys.argv[1]); kw['size'] = tuple(kw['size']); kw['cameras'] = CameraRig(**kw['cameras'])\n"
        "print(_digest(synthesize(**kw)))\n"
    )
    here = _digest(synthesize(**_OPTIONS))
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    out = subprocess.run([sys.executable, "-c", code, json.dumps({**_OPTIONS, "cameras": vars(_OPTIONS["cameras"])})], capture_output=True, text=True, cwd=root, check=True)
    assert out.stdout.split()[-1] == here
    for oset in ("procedural", "bundled"):  # and again in this process, for the other sets
        kw = {**_OPTIONS, "object_set": oset, "table_texture": "photo"}
        assert _digest(synthesize(**kw)) == _digest(synthesize(**kw))


def test_procedural_objects_record_their_options():
    from graphseg.sim.pybullet_scenes import OBJECT_TEXTURES, synthesize

    s = synthesize(seed=4, objects=5, views=1, size=(64, 48), object_set="procedural", table_texture="cloth", lighting="vary")
    s.validate()
    assert s.meta["object_set"] == "procedural" and s.meta["table_texture"] == "cloth"
    assert set(s.meta["lighting"]) >= {"lightDirection", "lightColor", "shadow"}
    assert len(s.objects) == 5 and s.meta["fell_off"] == []
    for name in s.objects.values():
        texture, kind = name.split()
        assert texture in OBJECT_TEXTURES and kind in ("box", "cylinder", "sphere")


def test_table_texture_and_lighting_do_not_move_the_objects():
    from graphseg.sim.pybullet_scenes import synthesize

    kw = dict(seed=2, objects=4, views=2, size=(96, 72))
    base = synthesize(**kw)
    for extra in (dict(table_texture="checker"), dict(lighting="vary"), dict(lighting={"lightDirection": [1, 0, 2], "shadow": True})):
        s = synthesize(**kw, **extra)
        assert s.objects == base.objects
        for a, b in zip(s.views, base.views):
            assert np.array_equal(a.instances, b.instances) and np.array_equal(a.depth, b.depth)
            assert not np.array_equal(a.rgb, b.rgb)  # but they are seen differently


def _edge_energy(rgb, mask):
    """Mean absolute horizontal + vertical colour difference (summed over R, G, B) inside ``mask`` (eroded by 2 pixels)."""
    from scipy.ndimage import binary_erosion

    g = rgb.astype(np.float64)
    inner = binary_erosion(mask, iterations=2)
    dx = np.abs(np.diff(g, axis=1)).sum(-1)[inner[:, 1:] & inner[:, :-1]]
    dy = np.abs(np.diff(g, axis=0)).sum(-1)[inner[1:] & inner[:-1]]
    return float(np.concatenate([dx, dy]).mean())


@pytest.mark.parametrize("kind", ["box", "cylinder", "sphere"])
def test_tinyrenderer_maps_textures_on_procedural_shapes(kind, tmp_path):
    """A striped (or noise / photo-like) shape shows its texture: strong pixel-to-pixel change where a plain one has almost none."""
    import pybullet_data

    from graphseg.sim.pybullet_scenes import (
        Shape,
        _create_shape,
        _load_texture,
        object_texture,
        render_view,
    )

    size = {"box": (0.08, 0.08, 0.08), "cylinder": (0.04, 0.08), "sphere": (0.045,)}[kind]
    energy = {}
    for texture in ("plain", "stripes", "noise", "photo"):
        cid = pb.connect(pb.DIRECT)
        try:
            pb.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=cid)
            img = object_texture(texture, np.random.default_rng(5))
            shape = Shape(kind, size, texture, (0.7, 0.3, 0.2, 1.0) if img is None else (1.0, 1.0, 1.0, 1.0), img)
            tid = None if img is None else _load_texture(pb, cid, img, str(tmp_path), texture)
            b = _create_shape(pb, cid, shape, [0, 0, 0], pb.getQuaternionFromEuler([0.3, 0.2, 0.4]), tid)
            rgb, _, body, _, _ = render_view(pb, cid, np.array([0.0, -0.25, 0.12]), np.zeros(3), (160, 120), 50.0)
        finally:
            pb.disconnect(physicsClientId=cid)
        assert (body == b).sum() > 500
        energy[texture] = _edge_energy(rgb, body == b)
    assert energy["plain"] < 4.0, energy
    for texture in ("stripes", "noise", "photo"):
        assert energy[texture] > 2.5 * max(energy["plain"], 1.0), energy


def test_table_textures_appear():
    from graphseg.sim.pybullet_scenes import TABLE_TEXTURES, synthesize

    energy = {}
    for tex in (None, *TABLE_TEXTURES):
        s = synthesize(seed=1, objects=1, views=1, size=(160, 120), table_texture=tex)
        v = s.views[0]
        pts = v.camera_points() @ v.cam_to_world[:3, :3].T + v.cam_to_world[:3, 3]
        top = (v.instances == 0) & (np.abs(pts[..., 2] - 0.626) < 0.003)  # the table top, no object
        assert top.sum() > 2000
        energy[tex] = _edge_energy(v.rgb, top)
    assert energy["plain"] < 1.0, energy
    for tex in ("checker", "noise", "cloth", "photo"):
        assert energy[tex] > 3 * energy["plain"] + 2.0, energy
    assert energy["wood"] > 2 * energy["plain"], energy


def test_bad_options_are_refused():
    from graphseg.sim.pybullet_scenes import synthesize

    with pytest.raises(ValueError, match="unknown object set 'lego'"):
        synthesize(object_set="lego")
    with pytest.raises(ValueError, match="unknown table texture 'marble'"):
        synthesize(table_texture="marble")
    with pytest.raises(ValueError, match="unknown keys lightPower"):
        synthesize(lighting={"lightPower": 2})
    with pytest.raises(ValueError, match="expected None, 'vary' or a dict"):
        synthesize(lighting="bright")
    with pytest.raises(ValueError, match="3 finite numbers"):
        synthesize(lighting={"lightDirection": [1, 2]})
