"""Per-stage wall time and peak memory of the whole pipeline on a 10-view synthetic scene.

Stages: synthesise (pybullet, 10 views 640x480), lift (rgbd), segment (each
weight-free segmenter), match (reprojection, selected pairs), graph (both
stages), write outputs (labels, overlays, PLY, GraphML, report). Then the
``graphseg demo`` command end to end in a fresh process, and ``graphseg synth
--views 8``, for their wall time and peak RSS (targets: demo <= 60 s and
<= 2 GB; synth of 8 views at 640x480 < 10 s).

Usage: python benchmarks/bench_pipeline.py [--json PATH]
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(__file__))
from _common import peak_rss_mb, print_table, write_json  # noqa: E402

from graphseg.config import Config  # noqa: E402
from graphseg.method.segment import segment  # noqa: E402
from graphseg.output import write_output  # noqa: E402
from graphseg.pipeline import compute_masks, compute_matches, lift  # noqa: E402


def child_run(cmd: list[str]) -> tuple[float, float, int]:
    """Wall seconds and peak RSS (MB) of a command run in a fresh process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    t = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    if proc.returncode != 0:
        print(proc.stdout, proc.stderr)
    return wall, max(after, before) / 1024, proc.returncode


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--json", default="benchmarks/results/pipeline.json")
    ap.add_argument("--seed", type=int, default=7)
    args = ap.parse_args(argv)
    from graphseg.sim.pybullet_scenes import synthesize

    rows = []

    def stage(name, fn):
        t = time.perf_counter()
        out = fn()
        rows.append({"stage": name, "seconds": time.perf_counter() - t, "peak_rss_mb": peak_rss_mb()})
        return out

    cfg = Config.preset("rgbd")
    scene = stage("synthesise 10 views 640x480", lambda: synthesize(seed=args.seed, objects=8, views=10))
    scene = stage("lift (rgbd)", lambda: lift(scene, "rgbd", cfg))
    masks = {}
    for seg in ("geometric", "superpixel"):
        masks[seg] = stage(f"segment ({seg})", lambda seg=seg: compute_masks(scene, seg, cfg))
    matches = stage("match (reprojection)", lambda: compute_matches(scene, None, cfg))
    result = stage("graph: segment() both stages", lambda: segment(scene, masks["geometric"], matches, cfg))
    with tempfile.TemporaryDirectory() as d:
        stage("write outputs + report", lambda: write_output(os.path.join(d, "out"), result, scene))
        total = sum(r["seconds"] for r in rows if "superpixel" not in r["stage"])
        rows.append({"stage": "total (geometric path)", "seconds": total, "peak_rss_mb": peak_rss_mb()})
        print(f"scene: {len(scene)} views, {len(scene.objects)} objects, {len(matches)} pairs, {sum(len(m) for m in matches.values())} matches; "
              f"{result.graph_2d.num_nodes} masks -> {result.num_objects} objects")
        print_table(rows, ["stage", "seconds", "peak_rss_mb"])
        exe = [sys.executable, "-m", "graphseg.cli"]
        # synth first: RUSAGE_CHILDREN reports the largest child so far
        synth_s, synth_mb, rc2 = child_run([*exe, "synth", "-o", os.path.join(d, "synth"), "--seed", "1", "--views", "8"])
        demo_s, demo_mb, rc1 = child_run([*exe, "demo", "-o", os.path.join(d, "demo"), "--quiet"])
    cmd_rows = [
        {"command": "graphseg demo", "seconds": demo_s, "peak_rss_mb": demo_mb, "exit": rc1, "target": "<= 60 s, <= 2048 MB"},
        {"command": "graphseg synth --seed 1 --views 8 (640x480)", "seconds": synth_s, "peak_rss_mb": synth_mb, "exit": rc2, "target": "< 10 s"},
    ]
    print_table(cmd_rows, ["command", "seconds", "peak_rss_mb", "exit", "target"])
    targets = {"demo_le_60s": demo_s <= 60 and rc1 == 0, "demo_le_2GB": demo_mb <= 2048, "synth_8_views_lt_10s": synth_s < 10 and rc2 == 0}
    print("targets:", targets)
    write_json(args.json, {"stages": rows, "commands": cmd_rows, "targets": targets})


if __name__ == "__main__":
    main()
