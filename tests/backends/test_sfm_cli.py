"""The photos-only path end to end through the CLI (split from test_sfm.py so that the suite's two
workers share the structure-from-motion runs): a run and its failure message, partial
registration, byte-identical outputs across processes, and a four-object scene."""

import numpy as np
import pytest

pytest.importorskip("pycolmap")
pytest.importorskip("pybullet")

from graphseg.scene import Scene, View  # noqa: E402
from graphseg.sim.strip import rgb_only  # noqa: E402


@pytest.fixture(scope="module")
def photos_run(arc_scene, tmp_path_factory):
    """The arc scene's photos as a plain folder (no scene.json) and one `graphseg run` of it, shared
    by the run test and the byte-identity test (one structure-from-motion run fewer)."""
    from graphseg.cli import main
    from graphseg.io.images import write_rgb

    root = tmp_path_factory.mktemp("photos_run")
    folder = root / "photos"
    folder.mkdir()
    for v in arc_scene.views:
        write_rgb(folder / f"{v.name}.png", v.rgb)
    assert main(["run", str(folder), "-o", str(root / "out"), "--quiet"]) == 0
    return folder, root / "out"


def test_cli_rgb_only_run_and_failure(arc_scene, photos_run, tmp_path, capsys):
    from graphseg.cli import main
    from graphseg.io import write_scene_folder
    from graphseg.metrics import evaluate
    from graphseg.output import read_output

    result, _ = read_output(photos_run[1])
    gt_points = [v.camera_points() @ v.cam_to_world[:3, :3].T + v.cam_to_world[:3, 3] for v in arc_scene.views]
    m = evaluate(result.labels, [v.instances for v in arc_scene.views], gt_points)
    # IoU pools pixels over views for one predicted id per object, so ids must agree across views;
    # every pixel with true depth counts. Measured 0.61 on this 320x240 scene with COLMAP's
    # unguided matching and 0.40 with guided matching (better cameras: rotation error 0.59 -> 0.28
    # degrees, depth error 0.7% -> 0.3%, but two objects merge); guided matching raised the tuning
    # half of bench_rgb_only.py from 0.499 to 0.582 (docs/results.md). A broken path scores ~0.
    assert m["mean"]["iou"] >= 0.35
    assert m["num_pred"] == result.num_objects
    # a scene SfM cannot register: exit 2, one line
    flat = rgb_only(Scene([View(f"{i}", np.full((60, 80, 3), 90, np.uint8)) for i in range(3)]))
    write_scene_folder(flat, tmp_path / "flat")
    capsys.readouterr()
    assert main(["run", str(tmp_path / "flat"), "-o", str(tmp_path / "out2"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "registered 0 of 3 views" in err[0]
    assert not (tmp_path / "out2").exists()


def test_partial_registration_segments_the_registered_views(arc_scene, tmp_path, capsys, monkeypatch):
    """Issue 20: a view structure from motion cannot register (a blank wall) is left out with one
    warning line naming it, and run.json says so; before, the whole run failed with exit 2."""
    import json

    from graphseg.cli import main
    from graphseg.io import write_scene_folder

    h, w = arc_scene.views[0].shape
    blank = View("blank", np.full((h, w, 3), 128, np.uint8), instances=np.zeros((h, w), np.int32))
    scene = rgb_only(Scene([*arc_scene.views, blank], arc_scene.objects, "partial"), keep_intrinsics=False)
    write_scene_folder(scene, tmp_path / "s")
    capsys.readouterr()
    assert main(["run", str(tmp_path / "s"), "-o", str(tmp_path / "out"), "--quiet"]) == 0
    cap = capsys.readouterr()
    warn = [line for line in cap.err.splitlines() if "registered" in line]
    assert warn == [f"graphseg: warning: structure from motion registered {len(arc_scene)} of {len(arc_scene) + 1} views; segmenting those {len(arc_scene)}, without: blank"]
    run = json.loads((tmp_path / "out" / "run.json").read_text())
    assert run["dropped_views"] == ["blank"] and run["views"] == [v.name for v in arc_scene.views]
    # issue 54: run.json keeps structure from motion's record: the variants tried (pooled SIFT left the
    # blank view out, so plain SIFT ran too; more than half registered, so no third try) and the views each registered
    tried = run["sfm"]["registration"]["tried"]
    assert [t["variant"] for t in tried] == ["dsp", "sift"] and max(t["views"] for t in tried) == len(arc_scene)
    assert run["sfm"]["registered"] == len(arc_scene)
    assert f"in {len(arc_scene)} views" in cap.out
    assert main(["eval", str(tmp_path / "out"), "--quiet"]) == 0  # the evaluation follows the registered views
    # issue 54: eval reads the points the run estimated (points/) and never lifts again, so it gives the
    # run's own metrics exactly (before, it ran structure from motion again, and other views could pass)
    from graphseg.backends.lifters import sfm

    assert sorted(p.stem for p in (tmp_path / "out" / "points").glob("*.npz")) == sorted(v.name for v in arc_scene.views)

    def no_lift(*a, **k):
        raise AssertionError("eval ran the lifter")

    monkeypatch.setattr(sfm.SfmLifter, "__call__", no_lift)
    assert main(["eval", str(tmp_path / "out"), "--quiet", "--json", str(tmp_path / "m.json")]) == 0
    again = json.loads((tmp_path / "m.json").read_text())
    assert again["mean"] == json.loads((tmp_path / "out" / "metrics.json").read_text())["mean"]
    (tmp_path / "out" / "points").rename(tmp_path / "points_gone")  # an output written before points/ existed
    capsys.readouterr()
    assert main(["eval", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "stores no estimated points" in err[0]
    from graphseg.result import Result

    recorded = Result.load(tmp_path / "out" / "result.npz").config
    assert recorded.backends.options["reprojection"]["max_color_distance"] == 30.0  # the colour test of estimated points ran


def test_same_photos_give_byte_identical_outputs(arc_scene, photos_run, tmp_path):
    """Issue 20: two runs (separate processes) on the same photos write the same labels, result.npz
    and graphs, byte for byte (seeded COLMAP, matching and mapping on one thread; entries of result.npz without
    timestamps or timings). Before, the cameras and the objects changed from run to run. The first
    run is the module's in-process run, the second a fresh process."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    folder, first = photos_run
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    code = "import sys\nfrom graphseg.cli import main\nsys.exit(main(sys.argv[1:]))"
    subprocess.run([sys.executable, "-c", code, "run", str(folder), "-o", str(tmp_path / "out2"), "--quiet"], check=True, env=env, timeout=300)
    files = sorted(p.relative_to(first) for p in first.rglob("*") if p.suffix in (".png", ".npz", ".graphml", ".ply"))
    assert any(f.name == "result.npz" for f in files) and any(f.suffix == ".graphml" for f in files)
    assert len([f for f in files if f.parent.name == "labels"]) == len(arc_scene)
    for f in files:
        assert (first / f).read_bytes() == (tmp_path / "out2" / f).read_bytes(), f


def test_photos_of_a_four_object_scene_give_four_objects(tmp_path, capsys):
    """Issue 19: `graphseg run PHOTOS` on 8 photos (640x480, the synth default ring) of a 4-object
    scene reported 13-37 objects: stray table and floor fragments. Now 4 +- 1, and PQ counts extras."""
    from graphseg.cli import main
    from graphseg.io.images import write_rgb
    from graphseg.metrics import evaluate
    from graphseg.output import read_output
    from graphseg.sim.pybullet_scenes import synthesize

    scene = synthesize(seed=5, objects=4, views=8, size=(640, 480))
    folder = tmp_path / "photos"
    folder.mkdir()
    for v in scene.views:
        write_rgb(folder / f"{v.name}.png", v.rgb)
    assert main(["run", str(folder), "-o", str(tmp_path / "out"), "--quiet"]) == 0
    result, _ = read_output(tmp_path / "out")
    assert len(scene.objects) == 4 and abs(result.num_objects - 4) <= 1, result.num_objects
    gt_points = [v.camera_points() @ v.cam_to_world[:3, :3].T + v.cam_to_world[:3, 3] for v in scene.views]
    m = evaluate(result.labels, [v.instances for v in scene.views], gt_points)
    assert m["num_pred"] == result.num_objects and m["mean"]["pq"] > 0.5
    assert "fragments below the minimum support" in capsys.readouterr().out
