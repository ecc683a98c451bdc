import json

import numpy as np
import pytest

from graphseg.io import load_scene, read_scene_folder, write_scene_folder
from graphseg.io.images import write_png
from graphseg.scene import Scene, SceneError, View
from graphseg.sim.boxes import look_at


def make_scene(n=3, h=12, w=16):
    rng = np.random.default_rng(0)
    views = []
    for i in range(n):
        depth = rng.uniform(0.4, 1.2, (h, w)).astype(np.float32)
        depth[0, 0] = 0
        inst = rng.integers(0, 3, (h, w)).astype(np.int32)
        K = np.array([[20.0, 0, 7.5], [0, 20, 5.5], [0, 0, 1]])
        views.append(View(f"{i:03d}", rng.integers(0, 255, (h, w, 3), dtype=np.uint8), depth=depth, K=K, cam_to_world=look_at([i, -1, 1], [0, 0, 0]), instances=inst))
    return Scene(views, {1: "mug", 2: "box"}, name="s")


def test_roundtrip_every_field(tmp_path):
    s = make_scene()
    write_scene_folder(s, tmp_path / "s")
    b = read_scene_folder(tmp_path / "s")
    assert b.objects == s.objects and len(b) == 3
    for x, y in zip(s.views, b.views):
        assert x.name == y.name
        assert np.array_equal(x.rgb, y.rgb)
        np.testing.assert_allclose(y.depth, np.round(x.depth * 1000) / 1000, atol=1e-6)
        assert y.depth[0, 0] == 0
        assert np.array_equal(x.instances, y.instances)
        np.testing.assert_allclose(x.K, y.K)
        np.testing.assert_allclose(x.cam_to_world, y.cam_to_world)
    with pytest.raises(FileExistsError):
        write_scene_folder(s, tmp_path / "s")
    write_scene_folder(s, tmp_path / "s", overwrite=True)
    assert [p.name for p in tmp_path.iterdir()] == ["s"]  # no temporary leftovers


def test_optional_fields_and_selection(tmp_path):
    s = make_scene(5)
    s.views = [v.replace(depth=None, instances=None, K=None, cam_to_world=None) for v in s.views]
    s.objects = {}
    write_scene_folder(s, tmp_path / "s")
    doc = json.loads((tmp_path / "s" / "scene.json").read_text())
    assert "depth" not in doc["views"][0] and doc["objects"] == []
    b = read_scene_folder(tmp_path / "s", num_views=3)
    assert [v.name for v in b.views] == ["000", "002", "004"]
    assert b.views[0].depth is None and b.views[0].K is None
    assert [v.name for v in load_scene(tmp_path / "s", views=["001", 3]).views] == ["001", "003"]
    assert [v.name for v in load_scene(tmp_path / "s", step=2).views] == ["000", "002", "004"]


def test_plain_image_folder(tmp_path):
    from graphseg.io.images import write_rgb

    for i in range(3):
        write_rgb(tmp_path / f"img{i}.jpg", np.full((8, 9, 3), 10 * i, np.uint8))
    (tmp_path / "notes.txt").write_text("x")
    s = read_scene_folder(tmp_path)
    assert [v.name for v in s.views] == ["img0", "img1", "img2"] and s.views[0].depth is None
    write_rgb(tmp_path / "img3.png", np.zeros((6, 9, 3), np.uint8))
    with pytest.raises(SceneError, match="img0 is 9x8 but img3 is 9x6; resize img3 to 9x8 or remove it"):
        read_scene_folder(tmp_path)


# --------------------------------------------------------------- validation: every field
@pytest.fixture
def scene_dir(tmp_path):
    write_scene_folder(make_scene(2), tmp_path / "s")
    return tmp_path / "s"


def edit(scene_dir, fn):
    p = scene_dir / "scene.json"
    doc = json.loads(p.read_text())
    fn(doc)
    p.write_text(json.dumps(doc))


@pytest.mark.parametrize(
    ("mutate", "field"),
    [
        (lambda d: d.pop("format"), "format"),
        (lambda d: d.update(format="other"), "format"),
        (lambda d: d.update(version=3), "version"),
        (lambda d: d.update(depth_scale=-1), "depth_scale"),
        (lambda d: d.update(depth_scale="x"), "depth_scale"),
        (lambda d: d.update(views=[]), "views"),
        (lambda d: d.update(views="x"), "views"),
        (lambda d: d["views"][0].pop("name"), r"views\[0\].name"),
        (lambda d: d["views"][1].pop("rgb"), r"views\[1\].rgb"),
        (lambda d: d["views"][1].update(name="000"), "views"),
        (lambda d: d["views"][0].update(K=[[1, 0], [0, 1]]), r"views\[0\].K"),
        (lambda d: d["views"][0].update(K=[[0, 0, 1], [0, 1, 1], [0, 0, 1]]), r"views\[0\].K"),
        (lambda d: d["views"][0].update(K=[[1, 0, "a"], [0, 1, 1], [0, 0, 1]]), r"views\[0\].K"),
        (lambda d: d["views"][0].update(cam_to_world=np.diag([2.0, 1, 1, 1]).tolist()), r"views\[0\].cam_to_world"),
        (lambda d: d["views"][0].update(cam_to_world=[[float("nan")] * 4] * 4), r"views\[0\].cam_to_world"),
        (lambda d: d["views"][0].update(cam_to_world=[[1, 0, 0], [0, 1, 0], [0, 0, 1]]), r"views\[0\].cam_to_world"),
        (lambda d: d["views"][0].update(rgb="rgb/missing.png"), r"views\[0\].rgb"),
        (lambda d: d.update(objects=[{"name": "x"}]), r"objects\[0\]"),
        (lambda d: d["views"].__setitem__(0, 5), r"views\[0\]"),
    ],
)
def test_every_field_is_validated(scene_dir, mutate, field):
    edit(scene_dir, mutate)
    with pytest.raises(SceneError, match=field) as info:
        read_scene_folder(scene_dir)
    assert "scene.json" in str(info.value) or "missing.png" in str(info.value)


def test_invalid_json_corrupt_png_sizes_and_dtypes(scene_dir):
    (scene_dir / "rgb" / "000.png").write_bytes(b"not a png")
    with pytest.raises(SceneError, match=r"000.png: views\[0\].rgb: cannot decode"):
        read_scene_folder(scene_dir)
    write_png(scene_dir / "rgb" / "000.png", np.zeros((12, 16, 3), np.uint8))
    write_png(scene_dir / "depth" / "000.png", np.zeros((5, 5), np.uint16))
    with pytest.raises(SceneError, match=r"views\[0\].depth: the depth image is 5x5 but the rgb image is 16x12; resize it to 16x12"):
        read_scene_folder(scene_dir)
    write_png(scene_dir / "depth" / "000.png", np.zeros((12, 16), np.uint8))
    with pytest.raises(SceneError, match="expected a 16-bit PNG"):
        read_scene_folder(scene_dir)
    write_png(scene_dir / "depth" / "000.png", np.zeros((12, 16), np.uint16))
    write_png(scene_dir / "instances" / "001.png", np.zeros((3, 3), np.uint16))
    with pytest.raises(SceneError, match=r"views\[1\].instances"):
        read_scene_folder(scene_dir)
    (scene_dir / "scene.json").write_text("{nope")
    with pytest.raises(SceneError, match="invalid JSON"):
        read_scene_folder(scene_dir)


def test_missing_paths_and_empty_folder(tmp_path):
    with pytest.raises(SceneError, match="path: no such file"):
        read_scene_folder(tmp_path / "nope")
    (tmp_path / "empty").mkdir()
    with pytest.raises(SceneError, match="empty scene"):
        read_scene_folder(tmp_path / "empty")
    (tmp_path / "f").write_text("x")
    with pytest.raises(SceneError, match="expected a scene folder"):
        read_scene_folder(tmp_path / "f")


def test_view_selection_errors(scene_dir):
    with pytest.raises(SceneError, match="unknown view 'zzz'"):
        read_scene_folder(scene_dir, views=["zzz"])
    with pytest.raises(SceneError, match="unknown view 9"):
        read_scene_folder(scene_dir, views=[9])
    with pytest.raises(SceneError, match="step must be"):
        read_scene_folder(scene_dir, step=0)
