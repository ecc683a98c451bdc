import json
import shutil

import numpy as np
import pytest

from graphseg.cli import main
from graphseg.io import read_scene_folder, write_scene_folder
from graphseg.io.images import write_png
from graphseg.testing.scenes import TWO_BOXES, box_scene


@pytest.fixture(scope="module")
def scene_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("cli") / "scene"
    write_scene_folder(box_scene(TWO_BOXES, views=3, shape=(96, 128)), d)
    return d


def fresh(scene_dir, tmp_path):
    d = tmp_path / "scene"
    shutil.copytree(scene_dir, d)
    return d


def run_cli(args, capsys):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_run_eval_export_info(scene_dir, tmp_path, capsys):
    out = tmp_path / "out"
    code, stdout, _ = run_cli(["run", scene_dir, "-o", out, "--quiet"], capsys)
    assert code == 0 and "2 objects" in stdout and "report:" in stdout
    for name in ("labels/000.png", "overlays/000.png", "objects/001.ply", "graphs/stage0.graphml", "graphs/stage1.graphml", "result.npz", ".graphseg-output", "config.yaml", "metrics.json", "report.html", "run.json"):
        assert (out / name).exists(), name
    html = (out / "report.html").read_text()
    assert "http://" not in html and "https://" not in html  # works offline
    metrics = json.loads((out / "metrics.json").read_text())
    assert set(metrics["mean"]) >= {"iou", "f1", "chamfer", "iou_sel", "precision", "pixel_utility"}
    code, stdout, _ = run_cli(["eval", out, "--json", tmp_path / "m.json"], capsys)
    assert code == 0 and "mean" in stdout
    m = json.loads((tmp_path / "m.json").read_text())
    assert m["mean"]["iou"] == pytest.approx(metrics["mean"]["iou"])
    code, stdout, _ = run_cli(["export", out, "--graphml", tmp_path / "g.graphml", "--ply", tmp_path / "ply", "--pyg", tmp_path / "g.pt"], capsys)
    assert code == 0 and (tmp_path / "g.graphml").exists() and (tmp_path / "g_stage1.graphml").exists() and (tmp_path / "g.pt").exists()
    assert len(list((tmp_path / "ply").glob("*.ply"))) == 2
    torch = pytest.importorskip("torch")
    data = torch.load(tmp_path / "g.pt")  # plain torch.load (weights_only) works
    assert data["edge_index"].shape[0] == 2
    code, _, err = run_cli(["export", out, "--graphml", tmp_path / "g.graphml"], capsys)
    assert code == 2 and "--overwrite" in err  # never replaces a file it did not create without --overwrite
    code, _, _ = run_cli(["export", out, "--graphml", tmp_path / "g1.graphml", "--stage", "1"], capsys)
    assert code == 0 and (tmp_path / "g1.graphml").exists() and not (tmp_path / "g1_stage1.graphml").exists()
    code, _, _ = run_cli(["run", scene_dir, "-o", out, "--quiet"], capsys)
    assert code == 0  # an earlier run output is replaced
    code, stdout, _ = run_cli(["info", out], capsys)
    assert code == 0 and "objects: 2" in stdout
    code, stdout, _ = run_cli(["info", scene_dir], capsys)
    assert code == 0 and "views: 3" in stdout and "ground truth: yes" in stdout


def test_run_options(scene_dir, tmp_path, capsys):
    cfg = tmp_path / "c.yaml"
    cfg.write_text("seed: 3\npixel_match:\n  percentile: 70\n")
    code, _, _ = run_cli(["run", scene_dir, "-o", tmp_path / "o", "--config", cfg, "--segmenter", "oracle-parts", "--parts", "1", "--no-3d", "--views", "0,2", "--quiet"], capsys)
    assert code == 0
    info = json.loads((tmp_path / "o" / "run.json").read_text())
    assert info["views"] == ["000", "002"]
    assert "chamfer_3d" not in (tmp_path / "o" / "config.yaml").read_text().split("stages:")[1]
    assert not (tmp_path / "o" / "graphs" / "stage1.graphml").exists()


def test_synth(tmp_path, capsys):
    pytest.importorskip("pybullet")
    code, stdout, _ = run_cli(["synth", "-o", tmp_path / "s", "--seed", "1", "--views", "3", "--objects", "3", "--size", "160x120"], capsys)
    assert code == 0
    s = read_scene_folder(tmp_path / "s")
    assert len(s) == 3 and s.views[0].shape == (120, 160) and s.has_depth and s.has_instances
    code, _, err = run_cli(["synth", "-o", tmp_path / "s2", "--size", "big"], capsys)
    assert code == 2 and "--size" in err


# ------------------------------------------------------------------ bad input: exit 2, one line
def mutate_json(d, fn):
    p = d / "scene.json"
    doc = json.loads(p.read_text())
    fn(doc)
    p.write_text(json.dumps(doc))


def case_missing_field(d):
    mutate_json(d, lambda doc: doc["views"][0].pop("rgb"))
    return "views[0].rgb"


def case_size_mismatch(d):
    write_png(d / "depth" / "001.png", np.zeros((10, 10), np.uint16))
    return "views[1].depth"


def case_bad_K(d):
    mutate_json(d, lambda doc: doc["views"][2].update(K=[[1, 0], [0, 1]]))
    return "views[2].K"


def case_non_rigid(d):
    mutate_json(d, lambda doc: doc["views"][0].update(cam_to_world=np.diag([1.0, 2, 1, 1]).tolist()))
    return "views[0].cam_to_world"


def case_nan_pose(d):
    def f(doc):
        doc["views"][1]["cam_to_world"][0][3] = float("nan")

    mutate_json(d, f)
    return "views[1].cam_to_world"


def case_corrupt_png(d):
    (d / "rgb" / "000.png").write_bytes(b"\x89PNG garbage")
    return "views[0].rgb"


def case_depth_dtype(d):
    write_png(d / "depth" / "002.png", np.zeros((96, 128), np.uint8))
    return "views[2].depth"


def case_wrong_format(d):
    mutate_json(d, lambda doc: doc.update(format="colmap"))
    return "format"


def case_invalid_json(d):
    (d / "scene.json").write_text("{")
    return "scene.json"


BAD = [case_missing_field, case_size_mismatch, case_bad_K, case_non_rigid, case_nan_pose, case_corrupt_png, case_depth_dtype, case_wrong_format, case_invalid_json]


@pytest.mark.parametrize("case", BAD, ids=[c.__name__ for c in BAD])
def test_bad_scene_exit_2_one_line_no_output(case, scene_dir, tmp_path, capsys):
    d = fresh(scene_dir, tmp_path)
    field = case(d)
    out = tmp_path / "out"
    code, _, err = run_cli(["run", d, "-o", out, "--quiet"], capsys)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert field in lines[0] and str(d) in lines[0]
    assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out")]


def test_empty_folder_unknown_view_missing_path_unwritable_output(scene_dir, tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    code, _, err = run_cli(["run", tmp_path / "empty", "-o", tmp_path / "o1"], capsys)
    assert code == 2 and "empty" in err and "views" in err and not (tmp_path / "o1").exists()
    code, _, err = run_cli(["run", scene_dir, "-o", tmp_path / "o2", "--views", "0,7"], capsys)
    assert code == 2 and "unknown view 7" in err and "views" in err and not (tmp_path / "o2").exists()
    code, _, err = run_cli(["run", tmp_path / "nope", "-o", tmp_path / "o3"], capsys)
    assert code == 2 and "nope" in err and "path" in err
    blocker = tmp_path / "file"
    blocker.write_text("x")
    code, _, err = run_cli(["run", scene_dir, "-o", blocker / "out", "--quiet"], capsys)
    assert code == 2 and "output" in err and len(err.strip().splitlines()) == 1
    code, _, err = run_cli(["run", scene_dir, "-o", tmp_path / "o4", "--segmenter", "sam9"], capsys)
    assert code == 2 and "unknown segmenter 'sam9'; installed choices:" in err
    bad_cfg = tmp_path / "bad.yaml"
    bad_cfg.write_text("pixel_match:\n  percentile: 900\n")
    code, _, err = run_cli(["run", scene_dir, "-o", tmp_path / "o5", "--config", bad_cfg], capsys)
    assert code == 2 and "pixel_match: option 'percentile'" in err and str(bad_cfg) in err
    code, _, err = run_cli(["eval", tmp_path / "nothing"], capsys)
    assert code == 2 and "not a graphseg output folder" in err


def test_internal_error_exit_1(monkeypatch, scene_dir, tmp_path, capsys):
    import graphseg.pipeline as pl

    def boom(*a, **k):
        raise RuntimeError("bug")

    monkeypatch.setattr(pl, "execute", boom)  # the run after planning
    code, _, err = run_cli(["run", scene_dir, "-o", tmp_path / "o", "--quiet"], capsys)
    assert code == 1 and "internal error" in err and "--debug" in err and len(err.strip().splitlines()) == 1 and not (tmp_path / "o").exists()
    code, _, err = run_cli(["run", scene_dir, "-o", tmp_path / "o", "--quiet", "--debug"], capsys)
    assert code == 1 and "Traceback" in err


def test_demo_small(tmp_path, capsys, monkeypatch):
    code, stdout, _ = run_cli(["demo", "-o", tmp_path / "demo", "--views", "3", "--objects", "3", "--quiet"], capsys)
    assert code == 0 and "report:" in stdout and "mean" in stdout
    assert (tmp_path / "demo" / "output" / "report.html").exists()
    assert (tmp_path / "demo" / "scene" / "scene.json").exists()


def test_run_with_precomputed_masks(scene_dir, tmp_path, capsys):
    from graphseg.backends.segmenters.precomputed import save_precomputed

    s = read_scene_folder(scene_dir)
    for v in s.views:
        save_precomputed(tmp_path / "masks", v.name, v.instances.astype(np.int32))
    code, stdout, _ = run_cli(["run", scene_dir, "-o", tmp_path / "o", "--masks", tmp_path / "masks", "--quiet"], capsys)
    assert code == 0 and "2 objects" in stdout
    info = json.loads((tmp_path / "o" / "run.json").read_text())
    assert info["pipeline"]["segmenter"] == "precomputed" and info["pipeline"]["lifter"] == "rgbd"
    code, _, err = run_cli(["run", scene_dir, "-o", tmp_path / "o2", "--masks", tmp_path / "nope"], capsys)
    assert code == 2 and "masks" in err
    (tmp_path / "masks" / "001.png").unlink()
    code, _, err = run_cli(["run", scene_dir, "-o", tmp_path / "o3", "--masks", tmp_path / "masks", "--quiet"], capsys)
    assert code == 2 and "no masks for view '001'" in err and not (tmp_path / "o3").exists()


# ------------------------------------------------------------------ degenerate input: a result, not a crash
@pytest.fixture(scope="module")
def small_scene(tmp_path_factory):
    d = tmp_path_factory.mktemp("small") / "scene"
    write_scene_folder(box_scene(TWO_BOXES, views=3, shape=(48, 64)), d)
    return d


def degenerate_empty_table(d, tmp):
    for f in (d / "depth").glob("*.png"):
        write_png(f, np.zeros((48, 64), np.uint16))
    return []


def degenerate_zero_masks(d, tmp):
    m = tmp / "m"
    m.mkdir()
    for n in ("000", "001", "002"):
        write_png(m / f"{n}.png", np.zeros((48, 64), np.uint16))
    return ["--masks", m]


def degenerate_huge_min_area(d, tmp):
    (tmp / "c.yaml").write_text("masks:\n  min_area: 1000000\n")
    return ["--config", tmp / "c.yaml"]


@pytest.mark.parametrize("case", [degenerate_empty_table, degenerate_zero_masks, degenerate_huge_min_area], ids=lambda c: c.__name__)
def test_degenerate_input_gives_an_empty_result(case, small_scene, tmp_path, capsys):
    d = fresh(small_scene, tmp_path)
    extra = case(d, tmp_path)
    code, stdout, err = run_cli(["run", d, "-o", tmp_path / "o", "--quiet", *extra], capsys)
    assert code == 0 and "0 objects" in stdout, err
    lines = err.strip().splitlines()  # one line naming the step that lost every object (tests/test_photos_only.py)
    assert len(lines) == 1 and lines[0].startswith("graphseg: warning: 0 objects: lost at the "), err
    assert (tmp_path / "o" / "report.html").exists() and not list((tmp_path / "o" / "objects").glob("*.ply"))
    code, stdout, _ = run_cli(["info", tmp_path / "o"], capsys)
    assert code == 0 and "objects: 0" in stdout
    code, _, _ = run_cli(["export", tmp_path / "o", "--graphml", tmp_path / "g.graphml", "--ply", tmp_path / "ply"], capsys)
    assert code == 0


def test_one_view_warns(small_scene, tmp_path, capsys):
    code, stdout, err = run_cli(["run", small_scene, "-o", tmp_path / "o", "--views", "1", "--quiet"], capsys)
    assert code == 0 and "2 objects in 1 views" in stdout
    assert err.strip().splitlines() == ["graphseg: warning: only one view: no cross-view evidence, every mask is its own object"]


# ------------------------------------------------------------------ least surprise
def test_views_match_names_before_indices(small_scene, tmp_path, capsys):
    d = fresh(small_scene, tmp_path)
    doc = json.loads((d / "scene.json").read_text())
    for v, name in zip(doc["views"], ["2", "0", "1"]):
        v["name"] = name
    (d / "scene.json").write_text(json.dumps(doc))
    code, _, err = run_cli(["run", d, "-o", tmp_path / "o", "--views", "0,1", "--quiet"], capsys)
    assert code == 0, err
    assert json.loads((tmp_path / "o" / "run.json").read_text())["views"] == ["0", "1"]  # names, not indices 0 and 1


def test_partial_config_overrides_the_preset_in_use(small_scene, tmp_path, capsys):
    from graphseg.config import Config

    (tmp_path / "c.yaml").write_text("seed: 5\n")
    code, _, _ = run_cli(["run", small_scene, "-o", tmp_path / "o", "--config", tmp_path / "c.yaml", "--quiet"], capsys)
    assert code == 0
    used = Config.load(tmp_path / "o" / "config.yaml")
    assert used == Config.preset("rgbd", seed=5)


def test_backend_option_flag(small_scene, tmp_path, capsys):
    from graphseg.cli import parse_backend_option

    assert parse_backend_option("oracle-parts.parts=3") == ("oracle-parts", "parts", 3)
    assert parse_backend_option("x.flag=true") == ("x", "flag", True)
    assert parse_backend_option("x.list=[1, 2]") == ("x", "list", [1, 2])
    code, _, err = run_cli(["run", small_scene, "-o", tmp_path / "o", "--segmenter", "oracle-parts", "--backend-option", "oracle-parts.parts=1", "--quiet"], capsys)
    assert code == 0, err
    import yaml

    cfg = yaml.safe_load((tmp_path / "o" / "config.yaml").read_text())
    assert cfg["backends"]["options"]["oracle-parts"]["parts"] == 1


def test_eval_against_a_scene_checks_view_names(small_scene, tmp_path, capsys):
    code, _, _ = run_cli(["run", small_scene, "-o", tmp_path / "o", "--views", "0,1", "--quiet"], capsys)
    assert code == 0
    code, stdout, _ = run_cli(["eval", tmp_path / "o", "--scene", small_scene], capsys)
    assert code == 0 and "mean" in stdout  # the matching views are picked by name


# ------------------------------------------------------------------ interruption
SLOW_RUN = """
import sys, time
import graphseg.output as o
real = o.fill_output
def slow(*a, **k):
    real(*a, **k)
    print("ready", flush=True)
    time.sleep(60)
o.fill_output = slow
from graphseg.cli import main
sys.exit(main(sys.argv[1:]))
"""


@pytest.mark.parametrize("sig,code", [("SIGTERM", 143), ("SIGINT", 130)])
def test_signal_leaves_nothing_behind(sig, code, small_scene, tmp_path):
    import os
    import signal
    import subprocess
    import sys
    from pathlib import Path

    repo = Path(__file__).resolve().parents[1]
    env = {**os.environ, "PYTHONPATH": str(repo)}
    p = subprocess.Popen([sys.executable, "-c", SLOW_RUN, "run", str(small_scene), "-o", str(tmp_path / "out"), "--quiet"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=tmp_path)
    assert p.stdout.readline().strip() == "ready"
    assert [q.name for q in tmp_path.iterdir() if ".graphseg-tmp-" in q.name]  # mid-write
    p.send_signal(getattr(signal, sig))
    _, err = p.communicate(timeout=60)
    assert p.returncode == code
    assert err.strip().splitlines() == ["graphseg: interrupted; nothing written"]
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------ run never modifies its inputs
def _tree(root):
    import hashlib
    import os
    from pathlib import Path

    out = {}
    for dirpath, _, files in os.walk(root):
        for f in files:
            p = Path(dirpath) / f
            out[str(p.relative_to(root))] = (hashlib.sha256(p.read_bytes()).hexdigest(), p.stat().st_mode)
    return out


def test_run_never_modifies_its_inputs(small_scene, tmp_path_factory):
    import contextlib
    import io

    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st

    from graphseg.backends.segmenters.precomputed import save_precomputed
    from graphseg.cli import main as cli_main

    template = tmp_path_factory.mktemp("prop-template")
    shutil.copytree(small_scene, template / "scene")
    for v in read_scene_folder(small_scene).views:
        save_precomputed(template / "masks", v.name, v.instances.astype(np.int32))
    (template / "c.yaml").write_text("seed: 1\n")
    targets = st.sampled_from(["scene", "scene/x", "scene/rgb", "masks", "masks/y", ".", "c.yaml", "new", "new/deeper"])

    @settings(max_examples=12, deadline=None, suppress_health_check=list(HealthCheck))
    @given(target=targets, overwrite=st.booleans(), use_masks=st.booleans(), use_config=st.booleans(), views=st.sampled_from([None, "0,2", "001"]))
    def prop(target, overwrite, use_masks, use_config, views):
        base = tmp_path_factory.mktemp("prop")
        shutil.rmtree(base)
        shutil.copytree(template, base)
        argv = ["run", str(base / "scene"), "-o", str(base / target), "--quiet"]
        argv += ["--overwrite"] * overwrite + ["--masks", str(base / "masks")] * use_masks + ["--config", str(base / "c.yaml")] * use_config
        argv += ["--views", views] if views else []
        inputs = ["scene"] + ["masks"] * use_masks + ["c.yaml"] * use_config
        before = {k: v for k, v in _tree(base).items() if k.split("/")[0] in inputs}
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            code = cli_main(argv)
        assert code in (0, 2)
        after = {k: v for k, v in _tree(base).items() if k.split("/")[0] in inputs}
        assert after == before  # no file under an input of the command changed, appeared or vanished
        shutil.rmtree(base)

    prop()


def test_eval_audit_and_method(scene_dir, tmp_path, capsys):
    out = tmp_path / "out"
    code, _, _ = run_cli(["run", scene_dir, "-o", out, "--quiet", "--method", "sam3d"], capsys)
    assert code == 0
    # issue 53: --method runs that method's stages, and the written config reloads to them
    from graphseg.config import Config
    from graphseg.result import Result

    assert Result.load(out / "result.npz").config.stage_names() == [["bidirectional_overlap"]]
    assert Config.load(out / "config.yaml").stage_names() == [["bidirectional_overlap"]]
    code, stdout, _ = run_cli(["eval", out, "--audit", "--json", tmp_path / "m.json"], capsys)
    assert code == 0 and "audit:" in stdout and "stage 0:" in stdout
    m = json.loads((tmp_path / "m.json").read_text())
    assert set(m["audit"]) >= {"summary", "stages", "impure_masks", "merge_errors"}
    code, _, err = run_cli(["run", scene_dir, "-o", tmp_path / "x", "--method", "nope"], capsys)
    assert code == 2 and err.startswith("graphseg: error: --method: invalid choice 'nope'") and len(err.splitlines()) == 1


def test_preset_names_match_the_presets(small_scene, tmp_path, capsys):
    from graphseg.cli import PRESET_NAMES
    from graphseg.config import PRESETS, Config

    assert sorted(PRESET_NAMES) == sorted(PRESETS)
    code, _, err = run_cli(["run", small_scene, "-o", tmp_path / "o", "--preset", "robust", "--quiet"], capsys)
    assert code == 0, err
    used = Config.load(tmp_path / "o" / "config.yaml")
    assert used == Config.preset("robust")
    assert used.stage_names() == [["pixel_match", "depth_repulsion"], ["chamfer_3d", "depth_repulsion", "smooth_adjacency"]]
    assert json.loads((tmp_path / "o" / "metrics.json").read_text())["mean"]["iou"] > 0.5


# ------------------------------------------------------------------ a closed standard output (issue 19)
ENTRY = "import sys\nfrom graphseg.cli import main\nsys.exit(main(sys.argv[1:]))"


def _env():
    import os
    from pathlib import Path

    return {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}


def _closed_reader(args, cwd):
    """Run graphseg with a stdout pipe whose read end is closed before it prints; (status, stderr)."""
    import subprocess
    import sys

    p = subprocess.Popen([sys.executable, "-c", ENTRY, *map(str, args)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=_env(), cwd=cwd)
    p.stdout.close()  # like `| head -1` once head has gone
    with p.stderr:
        err = p.stderr.read().decode()
    return p.wait(timeout=120), err


def test_closed_stdout_is_not_an_error(small_scene, tmp_path):
    from graphseg.cli import EXIT_BROKEN_PIPE
    from graphseg.result import Result

    out = tmp_path / "out"
    code, err = _closed_reader(["run", small_scene, "-o", out, "--quiet"], tmp_path)
    assert (code, err) == (EXIT_BROKEN_PIPE, "")
    assert Result.load(out / "result.npz").num_objects >= 1  # written completely before printing
    assert (out / "report.html").is_file() and (out / "metrics.json").is_file() and (out / ".graphseg-output").is_file()
    for args in (["info", out], ["eval", out], ["eval", out, "--audit"], ["info", small_scene]):
        assert _closed_reader(args, tmp_path) == (EXIT_BROKEN_PIPE, ""), args
    assert _closed_reader(["eval", out, "--json", tmp_path / "m.json"], tmp_path) == (EXIT_BROKEN_PIPE, "")
    assert "mean" in json.loads((tmp_path / "m.json").read_text())  # files first, then printing
    code, err = _closed_reader(["run", "--help"], tmp_path)  # argparse itself ignores the failed write
    assert code in (0, EXIT_BROKEN_PIPE) and err == ""


def test_closed_stdout_in_a_shell_pipeline(small_scene, tmp_path, capsys):
    import shutil
    import subprocess
    import sys

    bash = shutil.which("bash")
    if bash is None:
        pytest.skip("needs bash")
    assert run_cli(["run", small_scene, "-o", tmp_path / "out", "--quiet"], capsys)[0] == 0
    script = 'set -o pipefail; "$0" -c "$1" info "$2" | true; echo "status $?"'
    r = subprocess.run([bash, "-c", script, sys.executable, ENTRY, str(tmp_path / "out")], capture_output=True, text=True, env=_env(), timeout=120)
    assert r.stdout.strip() == "status 141" and r.stderr == ""


def test_run_into_head_leaves_stderr_empty(small_scene, tmp_path):
    """`graphseg run ... | head -1` (no --quiet): no progress bars when stderr is no terminal, no error."""
    import shutil
    import subprocess
    import sys

    bash = shutil.which("bash")
    if bash is None:
        pytest.skip("needs bash")
    script = 'set -o pipefail; "$0" -c "$1" run "$2" -o "$3" | head -1; echo "status $?"'
    r = subprocess.run([bash, "-c", script, sys.executable, ENTRY, str(small_scene), str(tmp_path / "out")], capture_output=True, text=True, env=_env(), timeout=300)
    first, status = r.stdout.strip().splitlines()
    assert "objects in" in first and status in ("status 0", "status 141") and r.stderr == ""
    assert (tmp_path / "out" / "result.npz").is_file()


def test_broken_pipe_while_printing(monkeypatch, scene_dir, tmp_path, capsys):
    """A write that fails mid-command (the reader left) ends the command quietly with 141."""
    import io
    import sys

    from graphseg import cli

    run_cli(["run", scene_dir, "-o", tmp_path / "out", "--quiet"], capsys)

    class Gone(io.StringIO):
        def write(self, text):
            raise BrokenPipeError(32, "Broken pipe")

    monkeypatch.setattr(sys, "stdout", Gone())
    code = cli.main(["info", str(tmp_path / "out")])
    monkeypatch.undo()
    assert code == cli.EXIT_BROKEN_PIPE and capsys.readouterr().err == ""


def test_other_broken_pipes_are_internal_errors(monkeypatch, tmp_path, capsys):
    """A broken pipe that is not standard output's is reported (exit 1), never blamed on a path."""
    from graphseg import cli

    def boom(args):
        raise BrokenPipeError(32, "Broken pipe")

    monkeypatch.setitem(cli.COMMANDS, "info", boom)
    monkeypatch.setattr(cli, "_stdout_closed", lambda: False)
    code, _, err = run_cli(["info", tmp_path], capsys)
    assert code == 1 and err.startswith("graphseg: internal error: BrokenPipeError") and "path" not in err


# ------------------------------------------------------------------ argument errors: one line, exit 2
@pytest.mark.parametrize(
    "argv,line",
    [
        (["run", "S", "-o", "O", "--preset", "robsut"], "graphseg: error: --preset: invalid choice 'robsut'; did you mean 'robust'? (choose from rgbd, paper, robust, multicut)"),
        (["run", "S", "-o", "O", "--method", "graphseg-mins"], "graphseg: error: --method: invalid choice 'graphseg-mins'; did you mean 'graphseg-minus'? (choose from graphseg, graphseg-minus, maskclustering, sam3d)"),
        (["synth", "-o", "O", "--layout", "stackd"], "graphseg: error: --layout: invalid choice 'stackd'; did you mean 'stacked'? (choose from spread, touching, stacked)"),
        (["demo", "--preset", "zzz"], "graphseg: error: --preset: invalid choice 'zzz' (choose from rgbd, paper, robust, multicut)"),
        (["rn", "S"], "graphseg: error: unknown command 'rn'; did you mean 'run'? (commands: run, eval, synth, demo, export, info, batch, add, suggest)"),
        (["frobnicate"], "graphseg: error: unknown command 'frobnicate' (commands: run, eval, synth, demo, export, info, batch, add, suggest)"),
        (["run", "S"], "graphseg: error: -o/--out: required by graphseg run (see graphseg run --help)"),
        (["eval"], "graphseg: error: out: required by graphseg eval (see graphseg eval --help)"),
        (["run", "S", "-o", "O", "--seed", "abc"], "graphseg: error: --seed: expected an integer (got 'abc')"),
        (["synth", "-o", "O", "--arc", "wide"], "graphseg: error: --arc: expected a number (got 'wide')"),
        (["run", "S", "-o", "O", "--presett", "rgbd"], "graphseg: error: --presett: unknown option; did you mean '--preset'?"),
        (["run", "S", "-o", "O", "--num_views=3"], "graphseg: error: --num_views: unknown option; did you mean '--num-views'?"),
        (["--bogus"], "graphseg: error: --bogus: unknown option; see graphseg --help"),
        (["info", "A", "B"], "graphseg: error: info: unexpected argument 'B' (see graphseg info --help)"),
        (["run", "S", "-o", "O", "--views", "1", "--step", "2"], "graphseg: error: --step: not allowed with --views"),
        (["run", "S", "-o", "O", "--seed"], "graphseg: error: --seed: expected one argument"),
    ],
)
def test_argument_errors_are_one_line(argv, line, capsys):
    code, stdout, err = run_cli(argv, capsys)
    assert code == 2 and stdout == ""
    assert err.splitlines() == [line]


def test_help_still_works(capsys):
    code, stdout, err = run_cli(["run", "--help"], capsys)
    assert code == 0 and stdout.startswith("usage: graphseg run") and err == ""


# ------------------------------------------------------------------ config errors say what to do
@pytest.mark.parametrize(
    "name,text,line",
    [
        ("c.yaml", "background:\n  plane: true\n - x\n", "config: line 3, column 2: expected <block end>, but found '<block sequence start>'"),
        ("c.yaml", "seed: [1, 2\n", "config: line 2, column 1: expected ',' or ']', but got '<stream end>'"),
        ("c.json", '{"seed": 1,\n "stages": }', "config: line 2, column 12: Expecting value"),
        ("c.yaml", "background:\n  plane_tolerence: 0.02\n", "background.plane_tolerence: unknown key 'plane_tolerence'; did you mean 'plane_tolerance'? valid keys: enabled, plane, plane_tolerance,"),
        ("c.yaml", "masks:\n  min_aera: 5\n", "masks.min_aera: unknown key 'min_aera'; did you mean 'min_area'? valid keys: min_area"),
        ("c.yaml", "pairs:\n  mod: all\n", "pairs.mod: unknown key 'mod'; did you mean 'mode'? valid keys: mode, auto_max_views,"),
        ("c.yaml", "output:\n  voxelsize: 0.01\n", "output.voxelsize: unknown key 'voxelsize'; did you mean 'voxel_size'? valid keys: voxel_size, stride"),
        ("c.yaml", "backends:\n  segmentr: geometric\n", "backends.segmentr: unknown key 'segmentr'; did you mean 'segmenter'? valid keys: segmenter, matcher, lifter,"),
        ("c.yaml", "sed: 3\n", "sed: unknown key 'sed'; did you mean 'seed'? valid keys: background, masks,"),
        ("c.yaml", "colour: red\n", "colour: unknown key 'colour'; valid keys: background, masks,"),
        ("c.yaml", "background:\n  max_distance: .inf\n", "background.max_distance: Input should be a finite number (got inf)"),
    ],
)
def test_config_errors_say_where_and_what_to_do(name, text, line, small_scene, tmp_path, capsys):
    cfg = tmp_path / name
    cfg.write_text(text)
    code, _, err = run_cli(["run", small_scene, "-o", tmp_path / "o", "--config", cfg, "--quiet"], capsys)
    assert code == 2 and len(err.splitlines()) == 1, err
    assert err.startswith(f"graphseg: error: {cfg}: {line}"), err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    "text,line",
    [
        ("background:\n  plane: true\n - x\n", "config: line 3, column 2: expected <block end>"),
        ("masks:\n  min_aera: 5\n", "masks.min_aera: unknown key 'min_aera'; did you mean 'min_area'? valid keys: min_area"),
    ],
)
def test_batch_config_errors_match_run(text, line, small_scene, tmp_path, capsys):
    cfg = tmp_path / "c.yaml"
    cfg.write_text(text)
    code, _, err = run_cli(["batch", small_scene, "-o", tmp_path / "b", "--config", cfg, "--quiet"], capsys)
    assert code == 2 and len(err.splitlines()) == 1 and err.startswith(f"graphseg: error: {cfg}: {line}"), err
    assert not (tmp_path / "b").exists()


def test_misspelt_stage_option_names_the_closest(small_scene, tmp_path, capsys):
    cfg = tmp_path / "c.yaml"
    cfg.write_text("stages:\n  - [{pixel_match: {tua: 0.3}}]\n")
    code, _, err = run_cli(["run", small_scene, "-o", tmp_path / "o", "--config", cfg, "--quiet"], capsys)
    assert code == 2 and len(err.splitlines()) == 1
    assert err.startswith(f"graphseg: error: {cfg}: stages.0.0: pixel_match: unknown option 'tua'; valid options: ")
    assert err.rstrip().endswith("; did you mean 'tau'?")


def test_validation_errors_outside_config_files_use_the_same_message(monkeypatch, tmp_path, capsys):
    from pydantic import ValidationError

    from graphseg import cli
    from graphseg.config import Config

    def bad(args):
        try:
            Config.model_validate({"pairs": {"max_rotaton": 1.0}})
        except ValidationError:
            raise
        raise AssertionError("not reached")

    monkeypatch.setitem(cli.COMMANDS, "info", bad)
    code, _, err = run_cli(["info", tmp_path], capsys)
    assert code == 2 and err.splitlines() == [
        "graphseg: error: config: pairs.max_rotaton: unknown key 'max_rotaton'; did you mean 'max_rotation'? valid keys: mode, auto_max_views, max_rotation, max_translation, translation_scale"
    ]


# ------------------------------------------------------------------ small message gaps
def test_num_views_above_the_scene_warns(small_scene, tmp_path, capsys):
    code, stdout, err = run_cli(["run", small_scene, "-o", tmp_path / "o", "--num-views", "25", "--quiet"], capsys)
    assert code == 0 and " in 3 views" in stdout
    assert "graphseg: warning: --num-views 25: the scene has 3 views; using all 3" in err.splitlines()
    code, _, err = run_cli(["run", small_scene, "-o", tmp_path / "o2", "--num-views", "3", "--quiet"], capsys)
    assert code == 0 and "--num-views" not in err


def test_unknown_view_lists_the_valid_ones(small_scene, tmp_path, capsys):
    code, _, err = run_cli(["run", small_scene, "-o", tmp_path / "o", "--views", "000,099", "--quiet"], capsys)
    assert code == 2 and err.splitlines() == [f"graphseg: error: {small_scene / 'scene.json'}: views: unknown view 99; valid: 000, 001, 002 (3 views) or indices 0..2"]


def test_interrupted_message_starts_a_new_line_on_a_terminal():
    import io

    from graphseg.cli import _interrupted

    class Tty(io.StringIO):
        def isatty(self):
            return True

    tty, pipe = Tty(), io.StringIO()
    tty.write(" 40%|####      | 2/5 [00:01<00:01]")  # tqdm leaves the cursor here
    _interrupted(stream=tty)
    _interrupted(stream=pipe)
    assert tty.getvalue().splitlines()[-1] == "graphseg: interrupted; nothing written"
    assert pipe.getvalue() == "graphseg: interrupted; nothing written\n"  # a log file gets no blank line


def test_metrics_table_shows_counts_and_panoptic_quality():
    from graphseg.cli import _metrics_table

    obj = {"id": 1, "name": "box", "iou": 0.9, "f1": 0.95, "chamfer": 1e-4, "iou_sel": 0.9, "precision": 0.97}
    mean = {k: v for k, v in obj.items() if k not in ("id", "name")} | {"pixel_utility": 0.99}
    new = {"objects": [obj], "mean": {**mean, "pq": 0.9123, "sq": 0.931, "rq": 0.98}, "num_gt": 4, "num_pred": 4}
    assert _metrics_table(new).splitlines()[-1] == "objects: 4 predicted, 4 true; PQ 0.91 (SQ 0.93 x RQ 0.98)"
    old = {"objects": [obj], "mean": mean, "num_gt": 4, "num_pred": 5}  # metrics.json written before PQ existed
    assert _metrics_table(old).splitlines()[-1] == "objects: 5 predicted, 4 true"
    older = {"objects": [obj], "mean": mean}
    assert _metrics_table(older).splitlines()[-1].startswith("pixel utility:")


def test_eval_and_run_print_the_object_counts(scene_dir, tmp_path, capsys):
    code, stdout, _ = run_cli(["run", scene_dir, "-o", tmp_path / "o", "--quiet"], capsys)
    assert code == 0 and "objects: 2 predicted, 2 true" in stdout
    code, stdout, _ = run_cli(["eval", tmp_path / "o"], capsys)
    assert code == 0 and "objects: 2 predicted, 2 true" in stdout

