"""Time and peak memory of the 3D lifters on CPU (random weights: the cost, not the quality).

* ``da3``: Depth Anything 3 small and base (the package's own network code, random
  weights), 5 and 10 views of 640x480 at the default input size 504 (378x504), one
  forward pass over all views plus the conversion to world point maps and the
  nominal metric scale. Model construction is timed separately.
* ``dust3r-align``: graphseg's global alignment (spanning tree + 10 refinement rounds)
  of the 90 ordered pairwise point maps of 10 views at DUSt3R's 384x512, made from
  ground-truth depth with 1% noise and a random scale per pair; the pose error
  against the truth is reported too. (The DUSt3R network itself is not timed: its
  weights are the user's.)

Each case runs in a fresh process, so the peak RSS is that case's alone.

Usage: python benchmarks/bench_lifters.py [--json PATH] [--quick]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))  # this checkout's graphseg
from _common import print_table, write_json  # noqa: E402


def _rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def case_da3(model: str, views: int, size: int) -> dict:
    import numpy as np

    from graphseg.backends.lifters.da3 import DA3Lifter, model_size_14
    from graphseg.scene import Scene, View

    t = time.perf_counter()
    lifter = DA3Lifter(model=model, random_weights=True, size=size)
    build = time.perf_counter() - t
    rss_model = _rss_mb()
    gen = np.random.default_rng(0)
    scene = Scene([View(f"{k:03d}", gen.integers(0, 255, (480, 640, 3), dtype=np.uint8)) for k in range(views)])
    load = os.getloadavg()[0]
    t = time.perf_counter()
    out = lifter(scene)
    run = time.perf_counter() - t
    assert all(np.isfinite(v.points).any() for v in out.views)
    h, w = model_size_14((480, 640), size)
    return {"case": f"da3 {model}", "views": views, "input": f"{w}x{h}", "build_s": build, "run_s": run, "per_view_s": run / views, "rss_model_mb": rss_model, "peak_rss_mb": _rss_mb(), "load_avg": load}


def case_align(views: int) -> dict:
    import numpy as np

    sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests", "backends"))
    from test_align import rotation_error_deg, synthetic_pairs

    from graphseg.backends.lifters.align import global_align, similarity_to_known_poses
    from graphseg.testing.scenes import box_scene, random_boxes

    scene = box_scene(random_boxes(1, 6), views=views, shape=(384, 512), arc_deg=300, rng=1)
    pairs = synthetic_pairs(scene, noise=0.01, rng=2)
    rss_in = _rss_mb()
    load = os.getloadavg()[0]
    t = time.perf_counter()
    al = global_align(pairs, views, iterations=10, rng=0)
    run = time.perf_counter() - t
    gt = np.stack([v.cam_to_world for v in scene.views])
    s, R, tr, _ = similarity_to_known_poses(al.cam_to_world, gt)
    pts = np.concatenate([v.points[np.isfinite(v.points).all(-1)] for v in scene.views])
    size = float(np.linalg.norm(np.ptp(pts, axis=0)))
    rot = max(rotation_error_deg(R @ a[:3, :3], b) for a, b in zip(al.cam_to_world, gt))
    trans = max(float(np.linalg.norm(s * R @ a[:3, 3] + tr - b[:3, 3])) for a, b in zip(al.cam_to_world, gt)) / size
    return {"case": "dust3r-align", "views": views, "input": "512x384", "pairs": len(pairs), "run_s": run, "per_view_s": run / views, "rss_inputs_mb": rss_in, "peak_rss_mb": _rss_mb(), "rot_err_deg": rot, "trans_err_pct": 100 * trans, "load_avg": load}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--json", default=os.path.join(os.path.dirname(__file__), "results", "lifters.json"))
    ap.add_argument("--quick", action="store_true", help="da3-small at 5 views only")
    ap.add_argument("--one", nargs="+", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.one:
        kind = args.one[0]
        row = case_da3(args.one[1], int(args.one[2]), int(args.one[3])) if kind == "da3" else case_align(int(args.one[1]))
        print("ROW " + json.dumps(row))
        return
    cases = [["da3", "da3-small", "5", "504"], ["da3", "da3-small", "10", "504"], ["da3", "da3-base", "5", "504"], ["da3", "da3-base", "10", "504"], ["align", "10"]]
    if args.quick:
        cases = cases[:1] + cases[-1:]
    rows = []
    for c in cases:
        proc = subprocess.run([sys.executable, __file__, "--one", *c], capture_output=True, text=True)
        line = [x for x in proc.stdout.splitlines() if x.startswith("ROW ")]
        if proc.returncode != 0 or not line:
            print(proc.stdout[-2000:], proc.stderr[-2000:])
            rows.append({"case": " ".join(c), "error": proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else "failed"})
            continue
        rows.append(json.loads(line[0][4:]))
        print(rows[-1], flush=True)
    import torch

    table = print_table(rows, ["case", "views", "input", "build_s", "run_s", "per_view_s", "peak_rss_mb", "rot_err_deg", "trans_err_pct", "load_avg"])
    write_json(args.json, {"rows": rows, "torch_threads": torch.get_num_threads(), "table": table})


if __name__ == "__main__":
    main()
