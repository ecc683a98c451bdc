"""Time the background step (table plane by RANSAC, below-plane and far points) on real-size views.

Inputs: YCB-Video videos 0001 and 0002 from ``../shared/data/ycbv`` (10 views
of 640x480 each), lifted with the ``rgbd`` lifter; without the data, a
synthetic 10-view 640x480 scene. Configuration: the ``rgbd`` preset's
``background`` section. Best of ``--repeat`` runs; the plane and the background
fraction are printed so runs of two versions can be compared.

Usage: python benchmarks/bench_background.py [--json PATH] [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from _common import print_table, write_json  # noqa: E402

from graphseg.config import Config  # noqa: E402
from graphseg.method.background import background_masks  # noqa: E402
from graphseg.pipeline import lift  # noqa: E402

YCBV = Path(__file__).resolve().parents[2] / "shared" / "data" / "ycbv"


def scenes():
    from graphseg.io import load_scene

    found = False
    for vid in ("0001", "0002"):
        if (YCBV / vid).is_dir():
            found = True
            yield f"ycbv-{vid}", load_scene(YCBV / vid, num_views=10)
    if not found:
        from graphseg.sim.pybullet_scenes import synthesize

        yield "synth-100", synthesize(seed=100, objects=8, views=10, size=(640, 480))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--json", default="benchmarks/results/background.json")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    cfg = Config.preset("rgbd")
    rows = []
    for name, scene in scenes():
        scene = lift(scene, None, cfg)
        pts = [v.points for v in scene.views]
        centers = [v.camera_center for v in scene.views]
        best = np.inf
        for _ in range(args.repeat):
            t = time.perf_counter()
            bg, info = background_masks(pts, centers, cfg.background, rng=0)
            best = min(best, time.perf_counter() - t)
        rows.append({"scene": name, "views": len(pts), "seconds": best, "plane": [round(x, 5) for x in info.plane or ()],
                     "max_distance": info.max_distance, "background_fraction": float(np.mean(info.fraction))})
    print_table(rows, ["scene", "views", "seconds", "plane", "max_distance", "background_fraction"])
    write_json(args.json, {"repeat": args.repeat, "rows": rows})


if __name__ == "__main__":
    main()
