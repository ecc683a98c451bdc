"""The command line on a store: graphseg add, and run / eval / export / info / suggest on a store."""

import json
import multiprocessing
import os

import numpy as np
import pytest

from graphseg.cli import main
from graphseg.io import write_scene_folder
from graphseg.scene import Scene
from graphseg.store import SceneGraph
from graphseg.store.layout import StoreLock
from graphseg.testing.scenes import TWO_BOXES, box_scene


@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    d = tmp_path_factory.mktemp("cli_store")
    s = box_scene(TWO_BOXES, views=4, shape=(60, 80))
    write_scene_folder(Scene(s.views[:2], s.objects, "a"), d / "a")
    write_scene_folder(Scene(s.views[2:], s.objects, "b"), d / "b")
    return d


def cli(args, capsys):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_add_then_run_eval_export_info(scenes, tmp_path, capsys):
    store = tmp_path / "store"
    code, out, err = cli(["add", store, scenes / "a", "--quiet"], capsys)
    assert code == 0 and out.startswith("added 2 views (000, 001) to generation 1: ") and err == ""
    code, out, _ = cli(["add", store, scenes / "b", "--quiet"], capsys)
    assert code == 0 and "added 2 views (002, 003) to generation 2" in out
    code, out, _ = cli(["add", store, scenes / "b", "--quiet"], capsys)  # the same views again
    assert code == 0 and out.startswith("nothing added")
    code, out, _ = cli(["info", store], capsys)
    assert code == 0 and "format: graphseg-store version 1; generation 2" in out and "views: 4 (000, 001, 002, 003)" in out
    code, out, _ = cli(["run", store, "-o", tmp_path / "out", "--quiet"], capsys)
    assert code == 0 and "2 objects in 4 views of store generation 2" in out
    run = json.loads((tmp_path / "out" / "run.json").read_text())
    assert run["format"] == "store" and run["store"]["object_ids"] == SceneGraph.open(store, create=False).object_ids
    code, out, _ = cli(["eval", store], capsys)
    assert code == 0 and "2 predicted, 2 true" in out
    code, out, _ = cli(["export", store, "--graphml", tmp_path / "g.graphml"], capsys)
    assert code == 0 and (tmp_path / "g.graphml").is_file() and (tmp_path / "g_stage1.graphml").is_file()
    code, out, _ = cli(["suggest", store, "-n", "2"], capsys)
    lines = out.strip().splitlines()
    assert code == 0 and len(lines) == 4 and out.startswith("rank") and "spread" in lines[0]
    # both boxes are seen in 4 views: every score is 0, and the last line says why
    assert [float(row.split()[2]) for row in lines[1:3]] == [0.0, 0.0]
    assert lines[3].startswith("all scores are 0: every object is seen in two or more views, so nothing is under-seen (the score counts under_seen only;")
    assert lines[3].endswith("the candidates rank by spread, the angle in degrees to the nearest camera, largest first")
    spreads = [float(row.split()[6]) for row in lines[1:3]]
    assert spreads == sorted(spreads, reverse=True)


def test_suggest_gives_real_scores_for_an_object_seen_once(tmp_path, capsys):
    """One view of one box: the box is under-seen, so candidates that see it from elsewhere score > 0, with no note."""
    from graphseg.sim.boxes import Box

    write_scene_folder(box_scene([Box((0.0, 0.0, 0.04), (0.08, 0.06, 0.08))], views=1, shape=(60, 80), arc_deg=0.0), tmp_path / "one")
    assert cli(["add", tmp_path / "store", tmp_path / "one", "--quiet"], capsys)[0] == 0
    code, out, _ = cli(["suggest", tmp_path / "store", "-n", "3"], capsys)
    lines = out.strip().splitlines()
    assert code == 0 and len(lines) == 4 and not any(line.startswith("all scores are 0") for line in lines)
    assert float(lines[1].split()[2]) == 1.0 and float(lines[1].split()[4]) == 1.0  # best candidate: the under_seen term at its top


def test_zero_score_note_when_no_candidate_sees_the_under_seen_object():
    from graphseg.method.segment import segment
    from graphseg.sim.boxes import Box
    from graphseg.store.commands import zero_score_note

    scene = box_scene([Box((0.0, 0.0, 0.04), (0.08, 0.06, 0.08))], views=1, shape=(60, 80), arc_deg=0.0)
    result = segment(scene, [v.instances.astype(np.int32) for v in scene.views], {})
    note = zero_score_note(scene, result)
    assert note.startswith("all scores are 0: no candidate sees the objects seen in fewer than two views (the score counts under_seen only;")
    assert zero_score_note(scene, result, {"under_seen": 0.0}).startswith("all scores are 0: every term weighs 0 (the score counts nothing)")


@pytest.fixture(scope="module")
def made(scenes, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("refused")
    SceneGraph.open(tmp / "store").add(str(scenes / "a"))
    (tmp / "mine").mkdir()
    (tmp / "c.json").write_text("[[1, 2]]")
    return tmp, tmp / "store"


@pytest.mark.parametrize(
    "args, words",
    [
        (["add", "{store}", "{tmp}/missing"], "{tmp}/missing: input: no such file or folder"),
        (["add", "{tmp}/mine", "{scenes}/a"], "{tmp}/mine: store: exists and is not a graphseg store (choose a new folder)"),
        (["add", "{store}", "{scenes}/a", "--preset", "paper"], "{store}: --preset: a store keeps the configuration it was created with"),
        (["run", "{store}", "-o", "{tmp}/o", "--seed", "3"], "{store}: --seed: a store keeps its own configuration and views"),
        (["add", "{store}", "{scenes}/a", "--views", "000,nope"], "views: unknown view 'nope'"),
        (["suggest", "{store}", "--candidates", "{tmp}/c.json"], "{tmp}/c.json: candidates: expected finite cam_to_world poses [C, 4, 4]"),
        (["eval", "{store}", "--scene", "{tmp}/missing"], "{tmp}/missing"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(scenes, made, capsys, args, words):
    tmp_path, store = made
    fill = {"store": store, "tmp": tmp_path, "scenes": scenes}
    code, out, err = cli([a.format(**fill) for a in args], capsys)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("graphseg: error: ") and words.format(**fill) in err
    assert SceneGraph.open(store, create=False).generation == 1  # unchanged
    assert sorted(p.name for p in (tmp_path / "mine").iterdir()) == []


def test_a_failed_first_add_leaves_no_empty_store(scenes, tmp_path, capsys):
    from graphseg.io.images import write_png

    write_png(tmp_path / "photo.png", np.zeros((32, 48, 3), np.uint8))  # no depth: the rgbd lifter cannot lift it
    code, out, err = cli(["add", tmp_path / "new", tmp_path / "photo.png", "--lifter", "rgbd"], capsys)
    assert code == 2 and err.startswith("graphseg: error: ") and err.count("\n") == 1
    assert not (tmp_path / "new").exists()
    store = tmp_path / "store"
    assert cli(["add", store, scenes / "a", "--quiet"], capsys)[0] == 0
    assert cli(["add", store, tmp_path / "photo.png", "--lifter", "rgbd"], capsys)[0] == 2
    assert SceneGraph.open(store, create=False).generation == 1  # an existing store is kept as it was


def _hold(path, ready, done):
    with StoreLock(path):
        ready.set()
        done.wait(20)
    os._exit(0)


def test_a_second_writer_gets_one_line(scenes, tmp_path, capsys):
    store = tmp_path / "store"
    assert cli(["add", store, scenes / "a", "--quiet"], capsys)[0] == 0
    ctx = multiprocessing.get_context("fork")
    ready, done = ctx.Event(), ctx.Event()
    p = ctx.Process(target=_hold, args=(store, ready, done))
    p.start()
    try:
        assert ready.wait(20)
        code, out, err = cli(["add", store, scenes / "b", "--quiet"], capsys)
    finally:
        done.set()
        p.join(20)
    assert code == 2 and err == f"graphseg: error: {store}: lock: another graphseg process (pid {p.pid}) is writing this store; try again when it has finished\n"
    assert cli(["add", store, scenes / "b", "--quiet"], capsys)[0] == 0
