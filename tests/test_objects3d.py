"""graphseg.objects3d: objects.json, fused meshes (open3d), boxes; the run output's objects.json."""

import json

import numpy as np
import pytest

from graphseg import Config
from graphseg.method.segment import segment
from graphseg.objects3d import (
    OBJECTS_FILE,
    canonical_mesh,
    fuse_mesh,
    load_open3d,
    object_geometry,
    principal_box,
    upright_box,
    write_mesh_ply,
    write_objects,
)
from graphseg.registry import MissingDependencyError
from graphseg.sim.boxes import Box
from graphseg.testing.scenes import box_scene, exact_matches, two_boxes_scene


def _open3d():
    try:
        return load_open3d()
    except MissingDependencyError as err:
        pytest.skip(f"open3d does not import here: {err}")


def gt_boxes(scene):
    """Ground truth: the axis-aligned box of every object's true points over all views."""
    out = {}
    ids = sorted(set(np.unique(np.concatenate([np.unique(v.instances) for v in scene.views])).tolist()) - {0})
    for k in ids:
        P = np.concatenate([np.asarray(v.points)[v.instances == k] for v in scene.views])
        P = P[np.isfinite(P).all(1)]
        out[k] = (P.min(0), P.max(0))
    return out


def box_error(vertices, box):
    """Largest distance (m) between the corners of the mesh's axis-aligned box and ``box``."""
    V = np.asarray(vertices)
    return float(max(np.abs(V.min(0) - box[0]).max(), np.abs(V.max(0) - box[1]).max()))


def matched_gt(scene, result, k):
    """The ground-truth id most pixels of predicted object ``k`` carry."""
    g = np.concatenate([v.instances[lab == k] for v, lab in zip(scene.views, result.labels)])
    return int(np.bincount(g).argmax())


@pytest.fixture(scope="module")
def boxes():
    scene, masks, matches = two_boxes_scene()
    return scene, segment(scene, masks, matches)


# Three boxes and four views all around at 240x320: exact depth and instances
THREE = (
    Box((-0.10, 0.02, 0.04), (0.07, 0.05, 0.08), yaw=0.4, color=(200, 60, 60)),
    Box((0.08, 0.06, 0.03), (0.10, 0.06, 0.06), yaw=-0.3, color=(60, 90, 200)),
    Box((0.02, -0.10, 0.05), (0.05, 0.05, 0.10), yaw=1.0, color=(60, 180, 60)),
)


@pytest.fixture(scope="module")
def three():
    scene = box_scene(THREE, views=4, shape=(240, 320), arc_deg=270.0, name="three")
    masks = [v.instances.astype(np.int32) for v in scene.views]  # oracle masks: the objects are exact
    return scene, segment(scene, masks, exact_matches(scene), Config.preset("rgbd"))


# ----------------------------------------------------------------------------- boxes (hand-computed)
def test_upright_box_of_a_rotated_box_gives_its_sides_and_axes():
    yaw = 0.5
    c, s = np.cos(yaw), np.sin(yaw)
    Rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    corners = np.array([[x, y, z] for x in (-0.05, 0.05) for y in (-0.02, 0.02) for z in (0.0, 0.03)]) @ Rz.T + [1.0, 2.0, 0.5]
    centre, R, ext = upright_box(corners, np.array([0.0, 0, 1]))
    assert np.allclose(ext, [0.1, 0.04, 0.03]) and np.allclose(centre, [1.0, 2.0, 0.515])
    assert np.isclose(abs(R[:, 0] @ Rz[:, 0]), 1.0) and np.allclose(R[:, 2], [0, 0, 1]) and np.isclose(np.linalg.det(R), 1.0)
    local = (corners - centre) @ R  # every corner lies on the box
    assert np.allclose(np.abs(local), ext / 2)


def test_principal_box_shapes_and_degenerate_input():
    rng = np.random.default_rng(0)
    P = rng.normal(size=(200, 3)) * [3.0, 1.0, 0.1]
    c, R, e = principal_box(P)
    assert c.shape == (3,) and R.shape == (3, 3) and e.shape == (3,) and np.isclose(np.linalg.det(R), 1.0)
    assert e[0] > e[1] > e[2] and np.all(np.abs((P - c) @ R) <= e / 2 + 1e-9)
    c1, _, e1 = principal_box(np.array([[1.0, 2, 3]]))  # one point: a box of size 0
    assert c1.tolist() == [1.0, 2.0, 3.0] and e1.tolist() == [0.0, 0.0, 0.0]
    with pytest.raises(ValueError, match="at least one point"):
        principal_box(np.zeros((0, 3)))
    with pytest.raises(ValueError, match="at least one point"):
        upright_box(np.zeros((0, 3)), np.array([0.0, 0, 1]))


def test_upright_box_of_collinear_points():
    c, R, e = upright_box(np.array([[0.0, 0, 0], [1, 1, 0], [2, 2, 0]]), np.array([0.0, 0, 1]))
    assert np.allclose(e, [np.sqrt(8), 0, 0]) and np.allclose(c, [1, 1, 0])


def test_canonical_mesh_ignores_the_order_of_vertices_and_triangles():
    class M:
        def __init__(self, V, F):
            self.vertices, self.triangles, self.vertex_colors = V, F, []

    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    F = np.array([[0, 1, 2], [0, 3, 1]])
    perm = np.array([2, 0, 3, 1])  # vertex i of the first mesh is vertex inv[i] of the second
    inv = np.argsort(perm)
    a = canonical_mesh(M(V, F))
    b = canonical_mesh(M(V[perm], inv[F][::-1][:, [1, 2, 0]]))  # renumbered, triangles reversed and rotated
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    # orientation is kept: the normal of every triangle is the same
    n = lambda V, F: np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])  # noqa: E731
    assert np.allclose(sorted(map(tuple, n(*a[:2]))), sorted(map(tuple, n(V, F))))


def test_write_mesh_ply_refuses_bad_indices(tmp_path):
    with pytest.raises(ValueError, match=r"triangles: expected vertex indices in \[0, 3\) \(got 0..3\)"):
        write_mesh_ply(tmp_path / "m.ply", np.eye(3), np.array([[0, 1, 3]]))


# ----------------------------------------------------------------------------- objects.json
def test_object_geometry_fields(boxes):
    scene, result = boxes
    objs = object_geometry(scene, result)
    assert [o["id"] for o in objs] == [1, 2]
    for o in objs:
        assert o["views"] == 3 and o["view_names"] == ["000", "001", "002"] and o["num_points"] > 100
        assert len(o["centroid"]) == 3 and np.array_equal(np.subtract(o["aabb"]["max"], o["aabb"]["min"]), o["extent"])
        R = np.array(o["obb"]["rotation"])
        assert R.shape == (3, 3) and np.isclose(np.linalg.det(R), 1.0) and o["obb"]["upright"]
        # the oriented box holds every point of the object
        P = np.concatenate([np.asarray(v.points)[lab == o["id"]] for v, lab in zip(scene.views, result.labels)])
        P = P[np.isfinite(P).all(1)]
        assert len(P) == o["num_points"] and np.allclose(P.mean(0), o["centroid"])
        assert np.all(np.abs((P - o["obb"]["center"]) @ R) <= np.array(o["obb"]["extent"]) / 2 + 1e-6)


def test_write_objects_without_open3d_states_why(boxes, tmp_path, monkeypatch):
    import graphseg.objects3d as o3

    def missing():
        raise MissingDependencyError("this feature needs 'open3d': pip install \"graphseg[open3d]\"")

    monkeypatch.setattr(o3, "load_open3d", missing)
    scene, result = boxes
    doc = write_objects(tmp_path, scene, result)
    back = json.loads((tmp_path / OBJECTS_FILE).read_text())
    assert back == json.loads(json.dumps(doc))
    assert [o["mesh"] for o in back["objects"]] == [None, None] and back["method"] is None
    assert back["mesh_note"] == "no mesh: this feature needs 'open3d': pip install \"graphseg[open3d]\""
    assert not list(tmp_path.glob("objects/*_mesh.ply"))
    with pytest.raises(MissingDependencyError, match="graphseg\\[open3d\\]"):
        write_objects(tmp_path, scene, result, meshes=True)


def test_write_objects_without_poses_states_why(boxes, tmp_path):
    scene, result = boxes
    from graphseg.scene import Scene

    bare = Scene([v.replace(cam_to_world=None) for v in scene.views], scene.objects, scene.name)
    doc = write_objects(tmp_path, bare, result)
    assert doc["mesh_note"] == "no mesh: view 000 has no pose, intrinsics or point map" and all(o["mesh"] is None for o in doc["objects"])
    assert [o["id"] for o in doc["objects"]] == [1, 2]  # the boxes are still there
    with pytest.raises(ValueError, match="view 000 has no pose"):
        write_objects(tmp_path, bare, result, meshes=True)


def test_write_objects_with_no_object(tmp_path):
    scene, masks, matches = two_boxes_scene()
    result = segment(scene, [np.zeros(v.shape, np.int32) for v in scene.views], matches)  # no masks: 0 objects
    doc = write_objects(tmp_path, scene, result)
    assert result.num_objects == 0 and doc["objects"] == [] and json.loads((tmp_path / OBJECTS_FILE).read_text())["objects"] == []


def test_bad_arguments(boxes, tmp_path):
    scene, result = boxes
    with pytest.raises(ValueError, match="unknown mesh method 'marching'; choose one of tsdf, poisson"):
        write_objects(tmp_path, scene, result, method="marching")
    with pytest.raises(IndexError, match=r"object 3 out of range \[1, 2\]"):
        fuse_mesh(scene, result, 3)
    with pytest.raises(ValueError, match=r"expected the scene of the result \(3 views\) \(got 2 views\)"):
        object_geometry(scene.select([0, 1]), result)


# ----------------------------------------------------------------------------- meshes (open3d)
def test_meshes_load_in_open3d_and_trimesh(boxes, tmp_path):
    o3d = _open3d()
    trimesh = pytest.importorskip("trimesh")
    scene, result = boxes
    doc = write_objects(tmp_path, scene, result)
    assert doc["method"] == "tsdf" and doc["open3d"] == o3d.__version__ and doc["mesh_note"] is None
    for o in doc["objects"]:
        path = tmp_path / o["mesh"]
        assert o["mesh"] == f"objects/{o['id']:03d}_mesh.ply" and path.is_file()
        m = o3d.io.read_triangle_mesh(str(path))
        t = trimesh.load(path, process=False, force="mesh")
        assert len(m.vertices) == len(t.vertices) == o["mesh_vertices"] > 0
        assert len(m.triangles) == len(t.faces) == o["mesh_triangles"] > 0
        assert np.allclose(np.asarray(m.vertices), t.vertices) and np.array_equal(np.asarray(m.triangles), t.faces)
        assert m.has_vertex_colors() and t.visual.vertex_colors.shape == (len(t.vertices), 4)
        # the mesh lies on the object: inside its axis-aligned box grown by 1 cm
        lo, hi = np.array(o["aabb"]["min"]), np.array(o["aabb"]["max"])
        assert np.all(t.vertices >= lo - 0.01) and np.all(t.vertices <= hi + 0.01)


def test_tsdf_meshes_are_within_1cm_of_the_true_boxes(three):
    _open3d()
    scene, result = three
    truth = gt_boxes(scene)
    assert result.num_objects == 3
    errs = [box_error(fuse_mesh(scene, result, k).vertices, truth[matched_gt(scene, result, k)]) for k in (1, 2, 3)]
    assert max(errs) <= 0.01, errs


def test_poisson_mesh_is_within_1cm_of_the_true_box(three):
    _open3d()
    scene, result = three
    truth = gt_boxes(scene)
    mesh = fuse_mesh(scene, result, 1, method="poisson")
    assert len(mesh.triangles) > 0 and box_error(mesh.vertices, truth[matched_gt(scene, result, 1)]) <= 0.01


def test_meshes_of_a_pybullet_scene_segmented_by_the_pipeline_are_within_1cm():
    """The whole path: a pybullet scene (true depth), the rgbd preset's own masks, TSDF meshes."""
    _open3d()
    pytest.importorskip("pybullet")
    from graphseg.pipeline import lift, run
    from graphseg.sim.pybullet_scenes import CameraRig, synthesize

    cfg = Config.preset("rgbd")
    scene = lift(synthesize(seed=3, objects=4, views=5, size=(320, 240), cameras=CameraRig(arc_deg=360)), None, cfg)
    result = run(scene, cfg)
    truth = gt_boxes(scene)
    assert result.num_objects == len(truth) == 4
    errs = [box_error(fuse_mesh(scene, result, k).vertices, truth[matched_gt(scene, result, k)]) for k in range(1, 5)]
    assert max(errs) <= 0.01, errs


def test_fusion_is_deterministic(boxes, tmp_path):
    _open3d()
    scene, result = boxes
    for d in ("a", "b"):
        (tmp_path / d).mkdir()
        write_objects(tmp_path / d, scene, result)
    for name in ("objects.json", "objects/001_mesh.ply", "objects/002_mesh.ply"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes(), name


def test_run_output_holds_objects_json_and_meshes(boxes, tmp_path):
    from graphseg.output import read_marker, write_output

    scene, result = boxes
    out = write_output(tmp_path / "out", result, scene)
    doc = json.loads((out / OBJECTS_FILE).read_text())
    assert [o["id"] for o in doc["objects"]] == [1, 2]
    try:
        load_open3d()
    except MissingDependencyError:
        assert all(o["mesh"] is None for o in doc["objects"]) and doc["mesh_note"].startswith("no mesh: ")
    else:
        assert [o["mesh"] for o in doc["objects"]] == ["objects/001_mesh.ply", "objects/002_mesh.ply"]
        assert all((out / o["mesh"]).is_file() for o in doc["objects"])
    files = read_marker(out)["files"]
    assert OBJECTS_FILE in files and all(o["mesh"] in files for o in doc["objects"] if o["mesh"])


DEFERRED_CHECK = r"""
import sys
from graphseg.objects3d import load_open3d
o3d = load_open3d()
skipped = sorted(m for m in ("sklearn", "pandas", "dash", "open3d.ml") if m in sys.modules)  # the Plotly viewer's module is there, not loaded
volume = o3d.pipelines.integration.ScalableTSDFVolume  # what graphseg uses is there
ml = o3d.ml  # a user's open3d.ml still imports, on first use
import open3d.ml.datasets
import open3d.visualization.draw_plotly  # an explicit import leaves the function in place, as plain open3d does
from open3d.visualization.draw_plotly import get_plotly_fig
print(skipped, type(ml).__name__, ml.__name__, "sklearn" in sys.modules, callable(o3d.visualization.draw_plotly) and callable(get_plotly_fig))
"""


def test_load_open3d_defers_unused_modules_and_keeps_them_importable():
    import subprocess
    import sys

    pytest.importorskip("open3d")
    proc = subprocess.run([sys.executable, "-c", DEFERRED_CHECK], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip().splitlines()[-1] == "[] module open3d.ml True True"
