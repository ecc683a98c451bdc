import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from graphseg.backends.lifters.precomputed import PrecomputedLifter
from graphseg.backends.matchers.precomputed import PrecomputedMatcher
from graphseg.backends.precomputed_folders import precomputed_choice
from graphseg.cli import main
from graphseg.config import Config
from graphseg.io import read_scene_folder, write_scene_folder
from graphseg.io.images import write_rgb
from graphseg.io.precomputed import (
    decode_name,
    encode_name,
    pair_file_name,
    read_matches_folder,
    read_point_map,
    resize_nearest,
    save_inputs,
    scale_intrinsics,
    write_matches_folder,
    write_point_map,
)
from graphseg.output import read_output
from graphseg.pipeline import prepare, run
from graphseg.scene import Matches, Scene, SceneError, View
from graphseg.testing.scenes import TWO_BOXES, box_scene


@settings(max_examples=60, deadline=None)
@given(st.text(min_size=1, max_size=12), st.text(min_size=1, max_size=12))
def test_pair_names_split_uniquely_for_any_view_names(a, b):
    stem = pair_file_name(a, b)[:-4]
    assert stem.count("__") == 1 and "/" not in stem
    left, right = stem.split("__")
    assert (decode_name(left), decode_name(right)) == (a, b)
    assert decode_name(encode_name(a)) == a


def test_resize_rule_and_intrinsics_hand_computed():
    src = np.arange(6, dtype=np.float32).reshape(2, 3)
    out = resize_nearest(src, (4, 6))
    assert out.shape == (4, 6) and out[0].tolist() == [0, 0, 1, 1, 2, 2] and out[3].tolist() == [3, 3, 4, 4, 5, 5]
    assert resize_nearest(src, (1, 1)).tolist() == [[4.0]]  # centre pixel: floor(0.5*3/1)=1, floor(0.5*2/1)=1
    K = np.array([[100.0, 0, 49.5], [0, 100, 29.5], [0, 0, 1]])  # principal point at the image centre of 100x60
    K2 = scale_intrinsics(K, (60, 100), (120, 200))
    assert np.allclose(K2, [[200, 0, 99.5], [0, 200, 59.5], [0, 0, 1]])  # still the centre


def test_point_map_validation_names_file_and_field(tmp_path):
    write_point_map(tmp_path, "a", np.zeros((2, 3, 3), np.float32), np.ones((2, 3)))
    pm = read_point_map(tmp_path, "a", (4, 6))
    assert pm.points.shape == (4, 6, 3) and pm.confidence.shape == (4, 6) and pm.source_shape == (2, 3)
    np.savez(tmp_path / "b.npz", points=np.zeros((2, 3, 2)))
    with pytest.raises(SceneError, match=r"b\.npz: points: expected shape \[H, W, 3\] \(got \[2, 3, 2\]\)"):
        read_point_map(tmp_path, "b", (2, 3))
    np.savez(tmp_path / "c.npz", points=np.zeros((2, 3, 3)), confidence=np.zeros((3, 3)))
    with pytest.raises(SceneError, match=r"c\.npz: confidence: expected \[2, 3\]"):
        read_point_map(tmp_path, "c", (2, 3))
    np.savez(tmp_path / "d.npz", points=np.zeros((2, 3, 3)), cam_to_world=np.diag([2.0, 1, 1, 1]))
    with pytest.raises(SceneError, match=r"d\.npz: cam_to_world: not a rigid"):
        read_point_map(tmp_path, "d", (2, 3))
    np.savez(tmp_path / "e.npz", points=np.full((2, 3, 3), np.inf))
    with pytest.raises(SceneError, match=r"e\.npz: points: contains inf"):
        read_point_map(tmp_path, "e", (2, 3))
    np.savez(tmp_path / "f.npz", points=np.array([{"x": 1}], dtype=object))
    with pytest.raises(SceneError, match=r"f\.npz: points: object arrays are not allowed"):
        read_point_map(tmp_path, "f", (2, 3))
    (tmp_path / "g.npz").write_bytes(b"not a zip")
    with pytest.raises(SceneError, match=r"g\.npz: file: not a readable"):
        read_point_map(tmp_path, "g", (2, 3))
    with pytest.raises(SceneError, match=r"zz\.npz: points: no point map"):
        read_point_map(tmp_path, "zz", (2, 3))


def test_huge_arrays_are_refused_from_the_header(tmp_path, monkeypatch):
    import graphseg.io.precomputed as pre

    monkeypatch.setattr(pre, "MAX_ELEMENTS", 10)
    np.savez(tmp_path / "a__b.npz", xy_i=np.zeros((6, 2)), xy_j=np.zeros((6, 2)))
    with pytest.raises(SceneError, match=r"xy_i: too large"):
        pre.read_pair_matches(tmp_path / "a__b.npz")


def test_matches_folder_roundtrip_swap_and_resize(tmp_path):
    views = [View(n, np.zeros((4, 6, 3), np.uint8)) for n in ("x__1", "b", "c")]
    scene = Scene(views)
    m = Matches([[0, 0], [5, 3]], [[1, 1], [2, 2]], [0.5, 1.0])
    write_matches_folder(tmp_path / "m", scene, {(0, 1): m})
    # a user's file: reversed pair, no certainty, coordinates for an image of half the size
    np.savez(tmp_path / "m" / "c__b.npz", xy_i=np.array([[0.0, 0.0]]), xy_j=np.array([[2.5, 1.5]]), image_size_i=np.array([2, 3]), image_size_j=np.array([2, 3]))
    got = read_matches_folder(tmp_path / "m", scene)
    assert sorted(got) == [(0, 1), (1, 2)]
    assert np.array_equal(got[(0, 1)].xy_i, m.xy_i) and np.array_equal(got[(0, 1)].certainty, m.certainty)
    # (x + 0.5) * 2 - 0.5 ; the pair was stored as (c, b) so xy_i of (b, c) is the file's xy_j
    assert got[(1, 2)].xy_i.tolist() == [[5.5, 3.5]] and got[(1, 2)].xy_j.tolist() == [[0.5, 0.5]]
    assert got[(1, 2)].certainty.tolist() == [1.0]
    sub = read_matches_folder(tmp_path / "m", scene.select([1, 2]))  # files of unselected views are skipped
    assert sorted(sub) == [(0, 1)]
    matcher = PrecomputedMatcher(folder=tmp_path / "m")
    assert np.array_equal(matcher(views[1], views[0]).xy_j, m.xy_i)  # embedded names, either order
    assert len(matcher(views[0], views[2])) == 0
    with pytest.raises(SceneError, match="no matches for the pair"):
        PrecomputedMatcher(folder=tmp_path / "m", missing="error")(views[0], views[2])
    np.savez(tmp_path / "m" / "b__c.npz", xy_i=np.zeros((1, 2)), xy_j=np.zeros((2, 2)))
    with pytest.raises(SceneError, match=r"b__c\.npz: xy_j: expected \[1, 2\] like xy_i"):
        read_matches_folder(tmp_path / "m", scene)
    np.savez(tmp_path / "m" / "b__c.npz", xy_i=np.zeros((1, 2)), xy_j=np.zeros((1, 2)))
    with pytest.raises(SceneError, match="a second file for the pair"):
        read_matches_folder(tmp_path / "m", scene)


def test_missing_folders_and_conflicting_flags(tmp_path):
    with pytest.raises(SceneError, match=r"nope: points: no such folder"):
        PrecomputedLifter(folder=tmp_path / "nope")
    with pytest.raises(SceneError, match=r"--points needs the precomputed-points lifter \(got --lifter rgbd\)"):
        precomputed_choice("points", tmp_path, "rgbd")
    with pytest.raises(SceneError, match="precomputed-matches.folder"):
        PrecomputedMatcher()


def test_scene_folder_v2_carries_point_maps_and_v1_still_reads(tmp_path):
    s = box_scene(TWO_BOXES, views=2, shape=(24, 32))
    lifted = Scene([v.replace(depth=None, confidence=np.full(v.shape, 2.0, np.float32)) for v in s.views], s.objects)
    write_scene_folder(lifted, tmp_path / "v2")
    assert '"version": 2' in (tmp_path / "v2" / "scene.json").read_text()
    back = read_scene_folder(tmp_path / "v2")
    for a, b in zip(lifted.views, back.views):
        assert np.array_equal(a.points, b.points, equal_nan=True) and np.array_equal(a.confidence, b.confidence)
        assert b.depth is None
    write_scene_folder(s, tmp_path / "v1")  # depth present: v1, points recomputed by the rgbd lifter
    assert '"version": 1' in (tmp_path / "v1" / "scene.json").read_text()
    assert read_scene_folder(tmp_path / "v1").views[0].points is None


def test_round_trip_from_saved_masks_matches_and_point_maps_is_exact(tmp_path, capsys):
    scene = box_scene(TWO_BOXES, views=3, shape=(72, 96))
    cfg = Config.preset("rgbd")
    lifted, masks, matches, _ = prepare(scene, cfg)
    first = run(scene, cfg)
    save_inputs(tmp_path / "inputs", lifted, masks, matches)
    # the same views as plain RGB images: no depth, no poses, no point maps
    rgb_only = Scene([View(v.name, v.rgb) for v in scene.views], name="rgb")
    again = run(rgb_only, cfg, masks=tmp_path / "inputs" / "masks", matches=tmp_path / "inputs" / "matches", points=tmp_path / "inputs" / "points")
    assert again.num_objects == first.num_objects == 2
    assert all(np.array_equal(a, b) for a, b in zip(first.labels, again.labels))
    assert np.array_equal(first.mask_object, again.mask_object)
    assert again.info["pipeline"]["lifter"] == "precomputed"
    # the same through the CLI on a folder of plain images
    img = tmp_path / "images"
    img.mkdir()
    for v in scene.views:
        write_rgb(img / f"{v.name}.png", v.rgb)
    cfg.save(tmp_path / "cfg.yaml")
    code = main([str(a) for a in ["run", img, "-o", tmp_path / "out", "--config", tmp_path / "cfg.yaml", "--quiet", "--masks", tmp_path / "inputs/masks", "--matches", tmp_path / "inputs/matches", "--points", tmp_path / "inputs/points"]])
    assert code == 0, capsys.readouterr().err
    res, info = read_output(tmp_path / "out")
    assert res.num_objects == 2 and all(np.array_equal(a, b) for a, b in zip(first.labels, res.labels))
    assert info["pipeline"]["lifter"] == "precomputed-points" and info["pipeline"]["matcher"] == "precomputed-matches"
