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
    for name in ("labels/000.png", "overlays/000.png", "objects/001.ply", "graph_2d.graphml", "graph_3d.graphml", "result.npz", "config.yaml", "metrics.json", "report.html", "run.json"):
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
    assert code == 0 and (tmp_path / "g.graphml").exists() and (tmp_path / "g_3d.graphml").exists() and (tmp_path / "g.pt").exists()
    assert len(list((tmp_path / "ply").glob("*.ply"))) == 2
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
    assert not (tmp_path / "o" / "graph_3d.graphml").exists()


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
    assert code == 2 and "pixel_match.percentile" in err and str(bad_cfg) in err
    code, _, err = run_cli(["eval", tmp_path / "nothing"], capsys)
    assert code == 2 and "not a graphseg output folder" in err


def test_internal_error_exit_1(monkeypatch, scene_dir, tmp_path, capsys):
    import graphseg.pipeline as pl

    def boom(*a, **k):
        raise RuntimeError("bug")

    monkeypatch.setattr(pl, "run", boom)
    code, _, err = run_cli(["run", scene_dir, "-o", tmp_path / "o", "--quiet"], capsys)
    assert code == 1 and "internal error" in err and not (tmp_path / "o").exists()


def test_demo_small(tmp_path, capsys, monkeypatch):
    code, stdout, _ = run_cli(["demo", "-o", tmp_path / "demo", "--views", "3", "--objects", "3", "--quiet"], capsys)
    assert code == 0 and "report:" in stdout and "mean" in stdout
    assert (tmp_path / "demo" / "output" / "report.html").exists()
    assert (tmp_path / "demo" / "scene" / "scene.json").exists()


def test_run_with_precomputed_masks(scene_dir, tmp_path, capsys):
    from graphseg.backends.segmenters import save_precomputed

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


def test_eval_audit_and_method(scene_dir, tmp_path, capsys):
    out = tmp_path / "out"
    code, _, _ = run_cli(["run", scene_dir, "-o", out, "--quiet", "--method", "sam3d"], capsys)
    assert code == 0
    assert "bidirectional_overlap" in (out / "config.yaml").read_text() or "sam3d" in (out / "config.yaml").read_text()
    code, stdout, _ = run_cli(["eval", out, "--audit", "--json", tmp_path / "m.json"], capsys)
    assert code == 0 and "audit:" in stdout and "stage 0:" in stdout
    m = json.loads((tmp_path / "m.json").read_text())
    assert set(m["audit"]) >= {"summary", "stages", "impure_masks", "merge_errors"}
    with pytest.raises(SystemExit):
        main(["run", str(scene_dir), "-o", str(tmp_path / "x"), "--method", "nope"])
