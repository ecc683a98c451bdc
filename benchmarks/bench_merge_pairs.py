"""The evidence behind ``split.merge_ncut``: what joining each touching pair of objects would cost.

For every scene, the ``rgbd`` preset runs with its split but without the merge
(``split.merge_ncut`` None). Then every pair of its objects is handed alone to
:func:`graphseg.method.split.merge_objects` with ``min_ncut`` 0, which joins
any pair that touches and reports the pair's cost (the cheapest normalized cut
found in the union). Each pair is labelled by the ground truth: *same* when
both objects hold most of the pixels of one true object, *different*
otherwise. A good threshold lies above every *different* cost and below every
*same* cost.

Sets: the YCB-Video dev videos 0001 and 0002 at 3, 5 and 10 views, with
geometric, gt-cut and hed masks (the inputs of ``bench_ycb_views.py``), split
into the tune and check halves of frames, and the synthetic and stress scenes
of ``bench_ablation.py`` (``synthetic``, ``stress-touching``, ``stress-stacked``,
``synthetic oracle k=4``). Only the tune half, synthetic and stress were used to
choose the threshold; the check half is reported next to them.

Prints the pairs sorted by cost and, per set, the largest *different* and the
smallest *same* cost; writes them as JSON.

Usage: PYTHONPATH=.test-models python benchmarks/bench_merge_pairs.py [--ycb-cache DIR] [--cache DIR] [--json PATH]
"""

from __future__ import annotations

import argparse
import os
import sys
from itertools import combinations
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
import bench_ablation  # noqa: E402
import bench_ycb_views  # noqa: E402
from _common import write_json  # noqa: E402

from graphseg.config import Config  # noqa: E402
from graphseg.method.baselines import run_method  # noqa: E402
from graphseg.method.split import merge_objects  # noqa: E402


def majority_truth(labels: list, scene, num_objects: int) -> np.ndarray:
    """The true instance holding most of each object's pixels (index = object id)."""
    top = max(int(np.asarray(v.instances).max()) for v in scene.views) + 1
    hist = np.zeros((num_objects + 1, top), np.int64)
    for lab, view in zip(labels, scene.views):
        np.add.at(hist, (np.asarray(lab).ravel(), np.asarray(view.instances).ravel().astype(np.int64)), 1)
    return hist.argmax(1)


def pair_costs(scene, masks, matches) -> list[dict]:
    """Every touching pair of the ``rgbd`` objects (split on, merge off): its cost and whether it is one true object."""
    cfg = Config.preset("rgbd", split={"enabled": True, "merge_ncut": None})
    res = run_method(scene, masks, matches, cfg)
    sp = cfg.split
    truth = majority_truth(res.labels, scene, res.num_objects)
    points = [v.points for v in scene.views]
    cameras = [(v.K, v.cam_to_world) for v in scene.views]
    out = []
    for a, b in combinations(range(1, res.num_objects + 1), 2):
        alone = [np.where((lab == a) | (lab == b), lab, 0) for lab in res.labels]
        _, info = merge_objects(alone, points, cameras, sp.model_copy(update={"merge_ncut": 0.0}), rng=cfg.seed)  # join anyway, to read the cost
        if info["merges"]:  # they touch, and both are large enough to be measured
            cost = info["merges"][0]["ncut"]
            out.append({"ids": [a, b], "cost": cost, "same": bool(truth[a] == truth[b] and truth[a] > 0)})  # cost None: too small to cut
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ycb-cache", help="bench_ycb_views.py's --cache folder (inputs reused)")
    ap.add_argument("--cache", help="bench_ablation.py's --cache folder (inputs reused)")
    ap.add_argument("--json", default="benchmarks/results/merge_pairs.json")
    args = ap.parse_args(argv)
    rows = []
    if bench_ycb_views.YCBV.is_dir():
        cache = Path(args.ycb_cache) if args.ycb_cache else None
        for half in ("tune", "check"):
            for masks_kind in ("geometric", "gt-cut", "hed"):
                for video in ("0001", "0002"):
                    for n in (3, 5, 10):
                        scene, masks, matches = bench_ycb_views.inputs(video, half, n, masks_kind, cache)
                        for p in pair_costs(scene, masks, matches):
                            rows.append({"set": f"ycbv {half}", "scene": f"{video}-{n}-{masks_kind}", **p})
    cache = Path(args.cache) if args.cache else None
    for group, name, loader, seg, options in bench_ablation.scene_specs(False):
        if group not in ("synthetic", "stress-touching", "stress-stacked", "synthetic oracle k=4"):
            continue
        scene, masks, matches = bench_ablation.inputs(name, loader, seg, options, cache)
        for p in pair_costs(scene, masks, matches):
            rows.append({"set": group, "scene": name, **p})
    cost = {id(r): np.inf if r["cost"] is None else r["cost"] for r in rows}
    for r in sorted(rows, key=lambda r: cost[id(r)]):
        if cost[id(r)] >= 0.01:  # the cheaper ones are far below any threshold in question
            print(f"  {cost[id(r)]:.4f}  {'same' if r['same'] else 'different':9s}  {r['set']:22s} {r['scene']:22s} objects {r['ids']}")
    summary = []
    for s in dict.fromkeys(r["set"] for r in rows):
        diff = [cost[id(r)] for r in rows if r["set"] == s and not r["same"]]
        same = [cost[id(r)] for r in rows if r["set"] == s and r["same"]]
        summary.append({"set": s, "pairs": len(diff) + len(same), "max_different": max(diff, default=None), "min_same": min(same, default=None) if not same or np.isfinite(min(same)) else None})
        print(f"{s:22s} pairs {len(diff) + len(same):3d}  largest different {max(diff, default=float('nan')):.4f}  smallest same {min(same, default=float('nan')):.4f}")
    write_json(args.json, {"rows": rows, "summary": summary, "merge_ncut": Config.preset("rgbd").split.merge_ncut})


if __name__ == "__main__":
    main()
