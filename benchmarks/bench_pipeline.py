"""The default path's time per step and peak memory, as a user runs it (issue 55).

Scenes: YCB-Video 0001 (``../shared/data/ycbv``, 10 views of 640x480, the
``--num-views 10`` frames; skipped if absent) and a pybullet scene (seed 7, 8
objects, 10 views of 640x480, written as a scene folder first). Each run is
``run_job(SCENE, OUT, Config(), read={"num_views": 10})`` (what ``graphseg run
SCENE -o OUT --num-views 10`` does, without printing) in a fresh process, with
``--jobs`` 1 and 2 (:mod:`graphseg.parallel`).

Rows per run: import (the interpreter and graphseg), resolve (backends), read,
lift, segment, match, graph (``segment()``: background, compose, each edge
stage, each graph operation), evaluate, write (outputs and the report), the
command end to end (wall time of the fresh process) and its peak RSS. Per view
and per pair: segment / views, match / pairs (with the matches per pair).
The labels of the two job counts are compared byte for byte. Then ``graphseg
demo`` and ``graphseg synth --views 8`` end to end (wall time and peak RSS of
the command; targets: demo <= 60 s and <= 2 GB, synth < 10 s).

Run it on an idle machine: the rows are wall times.

Usage: python benchmarks/bench_pipeline.py [--json PATH] [--jobs 1 2]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, os.path.dirname(__file__))
from _common import git_state, print_table, write_json  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
YCBV = ROOT.parent / "shared" / "data" / "ycbv" / "0001"
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])])}

CHILD = r"""
import json, sys, time, hashlib
t0 = time.perf_counter()
from graphseg.config import Config
from graphseg.job import run_job
from graphseg.parallel import jobs
t_import = time.perf_counter() - t0
scene, out, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
with jobs(n):
    job = run_job(scene, out, Config(), read={"num_views": 10})
r = job.result
h = hashlib.sha256()
for lab in r.labels:
    h.update(lab.tobytes())
import resource
print("RESULT " + json.dumps({
    "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    "workers_peak_rss_mb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024,
    "import": t_import, "job": job.timings, "pipeline": r.info["pipeline"]["timings"], "graph": r.info.get("timings", {}),
    "views": len(r.labels), "pairs": len(r.info.get("pairs", [])), "matches": r.info.get("num_matches"), "objects": r.num_objects,
    "labels_sha256": h.hexdigest(),
}, default=float))
"""


def run_child(scene: str, out: str, n: int) -> dict:
    """One fresh process: its timings, wall time and peak RSS (MB; the process's own, its worker processes' apart)."""
    t = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", CHILD, scene, out, str(n)], capture_output=True, text=True, env=ENV, cwd=ROOT)
    wall = time.perf_counter() - t
    if proc.returncode != 0:
        raise SystemExit(f"{scene} (jobs {n}) failed:\n{proc.stdout}\n{proc.stderr}")
    line = next(x for x in proc.stdout.splitlines() if x.startswith("RESULT "))
    got = json.loads(line[len("RESULT ") :])
    got.update(wall=wall)
    return got


def command(cmd: list[str]) -> dict:
    """Wall seconds, peak RSS (MB, of the command's largest process) and exit status of a command run in a fresh process."""
    t = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=ENV, cwd=ROOT)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t
    err = proc.stderr.read().decode(errors="replace") if proc.stderr else ""
    code = os.waitstatus_to_exitcode(status)
    if code != 0:
        print(err)
    return {"command": " ".join(cmd[2:]), "seconds": round(wall, 2), "peak_rss_mb": round(usage.ru_maxrss / 1024, 1), "exit": code}


def rows_of(name: str, n: int, r: dict) -> list[dict]:
    """The table rows of one run: one per step, then the totals."""
    job, pipe, graph = r["job"], r["pipeline"], r["graph"]
    steps = [("import", r["import"]), ("resolve backends", job.get("resolve")), ("read", job.get("read")), ("lift", pipe.get("lift"))]
    steps += [("segment", pipe.get("segment")), ("match", pipe.get("match"))]
    steps += [(f"graph: {k}", v) for k, v in graph.items()]
    steps += [("graph: all steps", pipe.get("graph")), ("evaluate", job.get("evaluate")), ("write outputs and report", job.get("write"))]
    steps += [("run_job total", job.get("total")), ("command end to end", r["wall"])]
    out = [{"scene": name, "jobs": n, "step": s, "seconds": None if v is None else round(float(v), 3)} for s, v in steps]
    per_view = pipe.get("segment", 0) / max(r["views"], 1)
    per_pair = (pipe.get("match") or 0) / max(r["pairs"], 1)
    out.append({"scene": name, "jobs": n, "step": f"segment per view ({r['views']} views)", "seconds": round(per_view, 3)})
    out.append({"scene": name, "jobs": n, "step": f"match per pair ({r['pairs']} pairs, {r['matches'] / max(r['pairs'], 1):.0f} matches each)", "seconds": round(per_pair, 3)})
    out.append({"scene": name, "jobs": n, "step": "peak RSS (MB)", "seconds": round(r["peak_rss_mb"], 1)})
    if r.get("workers_peak_rss_mb"):
        out.append({"scene": name, "jobs": n, "step": "peak RSS of one worker process (MB)", "seconds": round(r["workers_peak_rss_mb"], 1)})
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--json", default=str(ROOT / "benchmarks" / "results" / "pipeline.json"))
    ap.add_argument("--jobs", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--seed", type=int, default=7)
    args = ap.parse_args(argv)
    load0 = os.getloadavg()
    rows, runs = [], {}
    with tempfile.TemporaryDirectory(prefix="bench-pipeline-") as tmp:
        scenes = []
        if YCBV.is_dir():
            scenes.append(("YCB-Video 0001", str(YCBV)))
        try:
            from graphseg.io import write_scene_folder
            from graphseg.sim.pybullet_scenes import synthesize

            write_scene_folder(synthesize(seed=args.seed, objects=8, views=10), Path(tmp) / "synth")
            scenes.append((f"pybullet seed {args.seed}", str(Path(tmp) / "synth")))
        except ImportError as err:
            print(f"pybullet scene skipped: {err}")
        for name, path in scenes:
            for n in args.jobs:
                r = run_child(path, str(Path(tmp) / f"out-{len(runs)}"), n)
                runs[f"{name} / jobs {n}"] = r
                rows += rows_of(name, n, r)
                print(f"{name}, jobs {n}: {r['wall']:.2f} s end to end, {r['objects']} objects", flush=True)
        commands = [
            command([sys.executable, "-m", "graphseg.cli", "demo", "-o", str(Path(tmp) / "demo"), "--quiet"]),
            command([sys.executable, "-m", "graphseg.cli", "synth", "-o", str(Path(tmp) / "synth8"), "--seed", "1", "--views", "8", "--quiet"]),
        ]
    same = {name: len({r["labels_sha256"] for k, r in runs.items() if k.startswith(name)}) == 1 for name, _ in scenes}
    table = print_table(rows, ["scene", "jobs", "step", "seconds"])
    print(f"labels identical across job counts: {same}")
    commands_table = print_table(commands, ["command", "seconds", "peak_rss_mb", "exit"])
    payload = {"rows": rows, "runs": runs, "commands": commands, "labels_identical": same, "git": git_state(ROOT), "load_before": load0, "load_after": os.getloadavg(), "cores": len(os.sched_getaffinity(0))}
    write_json(args.json, payload)
    md = Path(args.json).with_suffix(".md")
    md.write_text(
        f"# Pipeline steps (`python benchmarks/bench_pipeline.py`)\n\nLoad average before {load0[0]:.2f}, after {os.getloadavg()[0]:.2f}; "
        f"{payload['cores']} cores. Labels identical across job counts: {same}.\n\n" + table + "\n\n" + commands_table + "\n"
    )
    print(f"wrote {md}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
