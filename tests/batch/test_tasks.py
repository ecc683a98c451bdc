import os

import pytest

from graphseg.batch.tasks import (
    GRASPNET_SPLITS,
    config_digest,
    configurations,
    expand_scenes,
    graspnet_split,
    make_tasks,
    scene_digest,
)
from graphseg.scene import SceneError
from tests.io.test_datasets import build_graspnet


def test_graspnet_split_boundaries():
    assert [graspnet_split(k) for k in (0, 99, 100, 129, 130, 159, 160, 189, 190)] == [
        "train", "train", "test_seen", "test_seen", "test_similar", "test_similar", "test_novel", "test_novel", "other"
    ]
    assert len(GRASPNET_SPLITS["test"]) == 90


def test_expand_paths_globs_and_dedup(synth_dir):
    specs = expand_scenes([str(synth_dir / "*"), str(synth_dir / "a")])
    assert [os.path.basename(s.path) for s in specs] == ["a", "b"]
    assert {s.split for s in specs} == {"synth"}
    with pytest.raises(SceneError, match="no scene folder matches"):
        expand_scenes([str(synth_dir / "nope*")])


def test_expand_graspnet_root_by_split(tmp_path):
    root = tmp_path / "graspnet"
    build_graspnet(root / "scenes", n=2)  # scene_0000 (train)
    (root / "scenes" / "scene_0000").rename(root / "scenes" / "scene_0101")
    specs = expand_scenes([str(root)], split="test_seen")
    assert [(os.path.basename(s.path), s.split) for s in specs] == [("scene_0101", "test_seen")]
    with pytest.raises(SceneError, match="no scene_XXXX folders of split test_novel"):
        expand_scenes([str(root)], split="test_novel")
    with pytest.raises(SceneError, match="unknown split"):
        expand_scenes([str(root)], split="val")
    # a GraspNet scene given as a path gets its split from its id
    assert expand_scenes([str(root / "scenes" / "scene_0101")])[0].split == "test_seen"


def test_expand_ycbv_root_by_video(tmp_path):
    (tmp_path / "data" / "0048").mkdir(parents=True)
    specs = expand_scenes([str(tmp_path)], videos=["0048"])
    assert specs[0].split == "ycbv" and specs[0].path.endswith("0048")
    with pytest.raises(SceneError, match="no video folder 0049"):
        expand_scenes([str(tmp_path)], videos=["0049"])


def test_scene_digest_changes_with_any_file(synth_dir, tmp_path):
    import shutil

    d = tmp_path / "s"
    shutil.copytree(synth_dir / "a", d)
    a = scene_digest(d)
    assert a == scene_digest(d) and len(a) == 16
    (d / "extra.txt").write_text("x")
    assert scene_digest(d) != a


def test_configurations_and_keys(synth_dir, tmp_path):
    cfgs = configurations(["graphseg", "graphseg-minus"])
    assert [c.label for c in cfgs] == ["graphseg", "graphseg-minus"]
    assert config_digest(cfgs[0].config) != config_digest(cfgs[1].config)
    with pytest.raises(SceneError, match="unknown method"):
        configurations(["nope"])
    f = tmp_path / "mine.yaml"
    f.write_text("seed: 3\n")
    assert [c.label for c in configurations(None, [str(f)])] == ["mine"]
    specs = expand_scenes([str(synth_dir / "*")])
    tasks = make_tasks(specs, cfgs, [2, None], tmp_path / "out")
    assert len(tasks) == 2 * 2 * 2 and len({t.key for t in tasks}) == 8
    assert tasks[0].out.endswith(os.path.join("runs", "a", "graphseg", "views-2"))
    assert tasks[1].out.endswith("views-all")
    # keys are stable across calls
    assert [t.key for t in make_tasks(specs, cfgs, [2, None], tmp_path / "out")] == [t.key for t in tasks]
