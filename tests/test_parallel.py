"""Views and pairs on several processes (issue 55): the count, the order, and the same bytes on one core and two."""

import os

import numpy as np
import pytest

from graphseg import parallel
from graphseg.parallel import ENV, job_count, jobs, parallel_map


def test_job_count_takes_jobs_then_the_environment_then_the_cores(monkeypatch):
    monkeypatch.delenv(ENV, raising=False)
    assert job_count() == len(os.sched_getaffinity(0))
    monkeypatch.setenv(ENV, "3")
    assert job_count() == 3
    with jobs(1):
        assert job_count() == 1
        with jobs(None):  # the default again, inside
            assert job_count() == 3
    assert job_count() == 3
    for bad in ("0", "two", "-1"):
        monkeypatch.setenv(ENV, bad)
        with pytest.raises(ValueError, match=f"GRAPHSEG_JOBS: expected an integer >= 1 \\(got '{bad}'\\)"):
            job_count()
    with pytest.raises(ValueError, match="jobs: expected an integer >= 1"):
        with jobs(0):
            pass


def test_parallel_map_keeps_the_order_and_uses_other_processes():
    items = list(range(7))
    with jobs(2):
        got = parallel_map(lambda i: (i * i, os.getpid()), items)  # a lambda: workers are forked, nothing is pickled but results
    assert [g for g, _ in got] == [i * i for i in items]
    assert os.getpid() not in {pid for _, pid in got}
    with jobs(1):
        assert {pid for _, pid in parallel_map(lambda i: (i, os.getpid()), items)} == {os.getpid()}
    assert parallel_map(abs, []) == [] and parallel.parallel_map(abs, [-1]) == [1]
    seen = []
    with jobs(2):
        assert parallel_map(abs, [-1, -2, -3], wrap=lambda it: (seen.append(x) or x for x in it)) == [1, 2, 3]
    assert seen == [1, 2, 3]  # the wrapper (a progress bar) sees every result, in order


def test_a_backend_without_parallel_stays_in_this_process():
    from graphseg.pipeline import compute_masks
    from graphseg.testing.scenes import TWO_BOXES, box_scene

    scene = box_scene(TWO_BOXES, views=3, shape=(48, 64))
    pids = []

    def seg(view):  # a plain function: no `parallel = True` declared
        pids.append(os.getpid())
        return view.instances

    with jobs(2):
        masks = compute_masks(scene, seg)
    assert pids == [os.getpid()] * 3 and all(np.array_equal(m, v.instances) for m, v in zip(masks, scene.views))


def _files(root):
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def test_one_core_and_two_write_the_same_bytes(tmp_path):
    """Labels, result.npz, graphs and every other file but those with timings (run.json, the report, the marker) are byte-identical."""
    from graphseg.job import run_job
    from graphseg.testing.scenes import TWO_BOXES, box_scene

    scene = box_scene(TWO_BOXES, views=4, shape=(96, 128))
    outs = {}
    for n in (1, 2):
        with jobs(n):
            run_job(scene, tmp_path / f"out{n}")
        outs[n] = _files(tmp_path / f"out{n}")
    assert outs[1].keys() == outs[2].keys()
    timed = {"run.json", "report.html", ".graphseg-output"}  # timings, and the marker that lists the files' digests
    differ = sorted(k for k in outs[1] if outs[1][k] != outs[2][k] and k not in timed)
    assert not differ, differ
    assert {"result.npz", "graphs/objects.graphml"} <= outs[1].keys() and any(k.startswith("labels/") for k in outs[1])


def test_cli_jobs_and_a_bad_environment_variable_are_one_line_each(tmp_path, capsys, monkeypatch):
    from graphseg.cli import main
    from graphseg.io import write_scene_folder
    from graphseg.testing.scenes import TWO_BOXES, box_scene

    write_scene_folder(box_scene(TWO_BOXES, views=3, shape=(48, 64)), tmp_path / "s")
    capsys.readouterr()
    assert main(["run", str(tmp_path / "s"), "-o", str(tmp_path / "o"), "--jobs", "0", "--quiet"]) == 2
    assert capsys.readouterr().err.strip().splitlines() == ["graphseg: error: --jobs: expected an integer >= 1 (got 0)"]
    monkeypatch.setenv(ENV, "many")
    assert main(["run", str(tmp_path / "s"), "-o", str(tmp_path / "o"), "--quiet"]) == 2
    assert capsys.readouterr().err.strip().splitlines() == ["graphseg: error: environment variable GRAPHSEG_JOBS: expected an integer >= 1 (got 'many')"]
    assert main(["run", str(tmp_path / "s"), "-o", str(tmp_path / "o"), "--jobs", "2", "--quiet"]) == 0  # --jobs wins over the variable
    assert not (tmp_path / "o").exists() or (tmp_path / "o" / "result.npz").is_file()


def test_a_worker_error_reaches_the_caller_and_a_second_thread_runs_in_its_own():
    import threading

    def boom(i):
        if i == 2:
            raise ValueError("view 2: bad")
        return i

    with jobs(2), pytest.raises(ValueError, match="view 2: bad"):
        parallel_map(boom, [0, 1, 2, 3])
    got = {}
    parallel._BUSY.acquire()  # as if another thread's map were running
    try:
        t = threading.Thread(target=lambda: got.setdefault("pids", parallel_map(lambda i: os.getpid(), [0, 1, 2])))
        with jobs(2):
            t.start()
            t.join()
    finally:
        parallel._BUSY.release()
    assert set(got["pids"]) == {os.getpid()}
