"""Batch throughput: scenes per minute on 8 synthetic scenes, local workers vs Ray.

Runs the same batch (8 box scenes, 6 views each at 240x320, method graphseg,
all views) three ways into fresh folders: 1 local worker, 2 local workers, and
Ray on 2 CPUs (one CPU per task). Ray's start-up is timed separately and
excluded from its throughput (a cluster is started once and reused); the
overhead is Ray's wall time over the 2-worker local wall time, minus 1
(target <= 15%). The per-scene metrics of the three runs must be identical.

Usage: python benchmarks/bench_batch.py [--scenes 8] [--json PATH]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(__file__))
from _common import print_table, write_json  # noqa: E402

from graphseg.batch import LocalExecutor, RayExecutor, run_batch  # noqa: E402
from graphseg.io import write_scene_folder  # noqa: E402
from graphseg.sim.boxes import Box  # noqa: E402
from graphseg.testing.scenes import box_scene  # noqa: E402


def make_scenes(root: str, n: int) -> list[str]:
    import numpy as np

    paths = []
    for k in range(n):
        rng = np.random.default_rng(k)
        boxes = [
            Box((float(x), float(y), 0.05), (0.1, 0.08, 0.1), float(rng.uniform(0, 3)))
            for x, y in [(-0.12, -0.05), (0.12, 0.06), (0.0, 0.15)][: 2 + k % 2]
        ]
        p = os.path.join(root, "scenes", f"s{k:02d}")
        write_scene_folder(box_scene(boxes, views=6, shape=(240, 320), rng=k, jitter=0.02), p)
        paths.append(p)
    return paths


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--scenes", type=int, default=8)
    ap.add_argument("--json", default=os.path.join(os.path.dirname(__file__), "results", "batch.json"))
    args = ap.parse_args()
    root = tempfile.mkdtemp(prefix="bench-batch-")
    scenes = make_scenes(root, args.scenes)
    rows, metrics = [], {}
    for name, make in (("local, 1 worker", lambda: LocalExecutor(1)), ("local, 2 workers", lambda: LocalExecutor(2)), ("ray, 2 CPUs", lambda: RayExecutor())):
        start = 0.0
        if name.startswith("ray"):
            import ray

            t = time.perf_counter()
            ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
            start = time.perf_counter() - t
        t = time.perf_counter()
        s = run_batch(scenes, os.path.join(root, name.split(",")[0] + name[-9:].replace(" ", "")), executor=make())
        wall = time.perf_counter() - t
        if name.startswith("ray"):
            ray.shutdown()
        assert s.failed == 0, [r["error"] for r in s.records if r["status"] != "ok"]
        metrics[name] = {r["scene_label"]: r["metrics"] for r in s.records}
        rows.append({"executor": name, "scenes": s.ok, "wall_s": wall, "scenes_per_min": 60 * s.ok / wall, "startup_s": start})
    base = next(r for r in rows if r["executor"] == "local, 2 workers")
    for r in rows:
        r["vs_local2"] = r["wall_s"] / base["wall_s"] - 1
    identical = all(m == metrics["local, 1 worker"] for m in metrics.values())
    table = print_table(rows, ["executor", "scenes", "wall_s", "scenes_per_min", "startup_s", "vs_local2"])
    print(f"identical per-scene metrics across executors: {identical}")
    write_json(args.json, {"rows": rows, "identical_metrics": identical, "table": table})


if __name__ == "__main__":
    main()
