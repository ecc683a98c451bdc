"""``graphseg synth --arc/--no-depth`` and the automatic sfm lifter for scenes without depth."""

import json

import numpy as np
import pytest

from graphseg.cli import main


def test_synth_arc_no_depth(tmp_path, capsys):
    pytest.importorskip("pybullet")
    out = tmp_path / "s"
    assert main(["synth", "-o", str(out), "--views", "3", "--objects", "2", "--size", "160x120", "--arc", "40", "--no-depth"]) == 0
    doc = json.loads((out / "scene.json").read_text())
    v = doc["views"][0]
    assert "depth" not in v and "cam_to_world" not in v and "K" in v and "instances" in v
    assert not (out / "depth").exists()
    assert main(["synth", "-o", str(tmp_path / "t"), "--views", "2", "--objects", "1", "--size", "160x120", "--no-depth", "--no-intrinsics"]) == 0
    assert "K" not in json.loads((tmp_path / "t" / "scene.json").read_text())["views"][0]


@pytest.mark.parametrize("args, msg", [(["--arc", "0"], "--arc"), (["--arc", "400"], "--arc"), (["--no-intrinsics"], "--no-intrinsics")])
def test_synth_bad_flags_exit_2(args, msg, tmp_path, capsys):
    assert main(["synth", "-o", str(tmp_path / "s"), *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and msg in err[0]


def test_lift_picks_sfm_without_depth():
    pytest.importorskip("pycolmap")
    from graphseg.pipeline import lift
    from graphseg.scene import Scene, SceneError, View

    flat = Scene([View(str(i), np.full((40, 50, 3), 100, np.uint8)) for i in range(2)])
    with pytest.raises(SceneError, match="structure from motion registered 0 of 2 views"):
        lift(flat)
