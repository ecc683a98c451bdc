"""Segmentation quality on synthetic scenes and real YCB-Video frames.

Scenes
    * 10 synthetic pybullet scenes (seeds 100..109) with 3, 5 or 10 views and
      5-10 objects, 640x480 (``graphseg.sim.pybullet_scenes``);
    * YCB-Video videos 0001 and 0002 from ``../shared/data/ycbv`` (10 views,
      evenly spaced over the 20 frames), skipped if absent.

Methods
    GraphSeg and GraphSeg-minus (no 3D stage), for each configuration preset
    (``rgbd``, measured for metric RGB-D, and ``paper``), with each segmenter:
    ``geometric``, ``superpixel`` and ``oracle-parts`` with k = 1..4 (ground
    truth cut into k random parts per object and view: measures the graph stage
    alone). Matcher ``reprojection``, lifter ``rgbd``; one global config per
    preset, no per-scene tuning. Targets are checked on the first preset.

Metrics (``graphseg.metrics.evaluate``): mean IoU, F1, IoU_sel, Chamfer (m^2),
precision, pixel utility, panoptic quality (PQ: extra and missed objects count,
which IoU cannot see) and the numbers of predicted and true objects, averaged
over scenes.

Targets (issue 4): synthetic mean IoU >= 0.80, F1 >= 0.88, pixel utility >=
0.95; YCB-Video mean IoU >= 0.75; oracle-parts k = 1..4 IoU >= 0.95.

Usage: python benchmarks/bench_quality.py [--quick] [--json PATH] [--config FILE [--base PRESET]]
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
from graphseg.io import load_scene  # noqa: E402
from graphseg.method.segment import segment  # noqa: E402
from graphseg.metrics import evaluate  # noqa: E402
from graphseg.pipeline import compute_masks, compute_matches, lift  # noqa: E402

YCBV = Path(__file__).resolve().parents[2] / "shared" / "data" / "ycbv"
KEYS = ("iou", "f1", "iou_sel", "chamfer", "precision", "pixel_utility", "pq", "num_pred", "num_gt")


def synthetic_scenes(quick: bool):
    from graphseg.sim.pybullet_scenes import synthesize

    seeds = range(100, 103 if quick else 110)
    views = [3, 5, 10]
    for k, seed in enumerate(seeds):
        n_obj = 5 + (seed * 7) % 6
        yield f"synth-{seed}", synthesize(seed=seed, objects=n_obj, views=views[k % 3], size=(640, 480))


def ycb_scenes():
    for vid in ("0001", "0002"):
        if (YCBV / vid).is_dir():
            yield f"ycbv-{vid}", load_scene(YCBV / vid, num_views=10)


def graph_check(result):
    """Pixels where the objects graph, painted, differs from the labels beyond the pixel refiners' count; the refiners' share."""
    from graphseg.graphs.lineage import paint_objects

    painted = paint_objects(result.objects_graph)
    moved = sum(int(np.count_nonzero(a != b)) for a, b in zip(painted, result.labels))
    return moved - int(result.info["refiners"]["pixels"]), float(result.info["refiners"]["fraction"])


def methods():
    out = [("geometric", {}), ("superpixel", {})]
    out += [(f"oracle-parts k={k}", {"oracle-parts": {"parts": k}}) for k in (1, 2, 3, 4)]
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="3 synthetic scenes only")
    ap.add_argument("--config", help="config file (replaces the presets)")
    ap.add_argument("--base", help="preset that --config is loaded over (default: Config(), the rgbd method)")
    ap.add_argument("--presets", nargs="+", default=["rgbd", "paper"], help="Config.preset names to compare")
    ap.add_argument("--json", default="benchmarks/results/quality.json")
    ap.add_argument("--matchers", nargs="*", default=["flow", "sift"], help="other matchers to compare with the default segmenter and the first preset")
    args = ap.parse_args(argv)
    if args.base and not args.config:
        ap.error("--base needs --config")
    bases = {"config": Config.load(args.config, base=Config.preset(args.base) if args.base else None)} if args.config else {p: Config.preset(p) for p in args.presets}
    variants = {}
    for pname, cfg in bases.items():
        variants[f"GraphSeg [{pname}]"] = cfg
        variants[f"GraphSeg-minus [{pname}]"] = cfg.without_3d()
    base = next(iter(bases.values()))
    rows = []
    per_scene = []
    t0 = time.perf_counter()
    groups = [("synthetic", list(synthetic_scenes(args.quick))), ("ycbv", list(ycb_scenes()))]
    default_masks: dict = {}
    for group, scenes in groups:
        for method, options in methods():
            seg = method.split()[0]
            acc = {v: [] for v in variants}
            for name, scene in scenes:
                cfg = base.model_copy(update={"backends": base.backends.model_copy(update={"options": {**base.backends.options, **options}})})
                scene = lift(scene, None, cfg)
                masks = compute_masks(scene, seg, cfg)
                matches = compute_matches(scene, None, cfg)
                if seg == base.backends.segmenter:
                    default_masks[name] = (scene, masks)
                gt = [v.instances for v in scene.views]
                pts = [v.points for v in scene.views]
                for vname, vcfg in variants.items():
                    r = segment(scene, masks, matches, vcfg)
                    m = evaluate(r.labels, gt, pts, names=scene.objects)
                    acc[vname].append({**m["mean"], "num_pred": m["num_pred"], "num_gt": m["num_gt"]})
                    unexplained, refined = graph_check(r)
                    per_scene.append(
                        {"group": group, "scene": name, "method": method, "variant": vname, "objects_gt": m["num_gt"], "objects_pred": m["num_pred"], **m["mean"], "unexplained": unexplained, "refined": refined}
                    )
            for vname in variants:
                if not acc[vname]:
                    continue
                row = {"scenes": group, "segmenter": method, "variant": vname, "n": len(acc[vname])}
                for k in KEYS:
                    vals = [a[k] for a in acc[vname] if a.get(k) is not None]
                    row[k] = float(np.mean(vals)) if vals else None
                rows.append(row)
                print(f"  {group:9s} {method:18s} {vname:26s} iou {row['iou']:.3f} f1 {row['f1']:.3f} util {row['pixel_utility']:.3f} pq {row['pq']:.3f} objects {row['num_pred']:.1f}/{row['num_gt']:.1f}", flush=True)
    first_cfg = next(iter(bases.values()))
    for matcher in args.matchers:  # matchers other than reprojection, default segmenter, first preset
        for group, scenes in groups:
            acc = []
            for name, _ in scenes:
                scene, masks = default_masks[name]
                matches = compute_matches(scene, matcher, first_cfg)
                r = segment(scene, masks, matches, first_cfg)
                m = evaluate(r.labels, [v.instances for v in scene.views], [v.points for v in scene.views])
                acc.append({**m["mean"], "num_pred": m["num_pred"], "num_gt": m["num_gt"]})
            if acc:
                row = {"scenes": group, "segmenter": f"{base.backends.segmenter} + {matcher}", "variant": f"GraphSeg [{next(iter(bases))}]", "n": len(acc)}
                for k in KEYS:
                    vals = [a[k] for a in acc if a.get(k) is not None]
                    row[k] = float(np.mean(vals)) if vals else None
                rows.append(row)
                print(f"  {group:9s} {row['segmenter']:18s} {row['variant']:26s} iou {row['iou']:.3f} f1 {row['f1']:.3f}", flush=True)
    print()
    print_table(rows, ["scenes", "segmenter", "variant", "n", *KEYS])
    print("\nper scene:")
    print_table(per_scene, ["group", "scene", "method", "variant", "objects_gt", "objects_pred", "iou", "f1", "pixel_utility", "pq"])
    first = next(iter(bases))
    default = [r for r in rows if r["variant"] == f"GraphSeg [{first}]"]

    def get(group, method):
        return next((r for r in default if r["scenes"] == group and r["segmenter"] == method), None)

    seg_default = base.backends.segmenter
    syn = get("synthetic", seg_default)
    ycb = get("ycbv", seg_default)
    targets = {
        "synthetic_iou_ge_0.80": syn is not None and syn["iou"] >= 0.80,
        "synthetic_f1_ge_0.88": syn is not None and syn["f1"] >= 0.88,
        "synthetic_pixel_utility_ge_0.95": syn is not None and syn["pixel_utility"] >= 0.95,
        "ycbv_iou_ge_0.75": ycb is not None and ycb["iou"] >= 0.75,
    }
    for k in (1, 2, 3, 4):
        for group in ("synthetic", "ycbv"):
            r = get(group, f"oracle-parts k={k}")
            if r is not None:
                targets[f"oracle_k{k}_{group}_iou_ge_0.95"] = r["iou"] >= 0.95
    print(f"\ntargets checked on GraphSeg [{first}] with the default segmenter ({seg_default})")
    print("targets:", targets)
    print(f"total {time.perf_counter() - t0:.0f} s")
    graph = {"runs": len(per_scene), "unexplained_runs": sum(1 for r in per_scene if r["unexplained"]), "max_refined": max((r["refined"] for r in per_scene), default=0.0)}
    print(f"objects graph: {graph['runs'] - graph['unexplained_runs']} of {graph['runs']} runs painted back to their labels (pixel refiners: at most {100 * graph['max_refined']:.2f}% of the pixels)")
    write_json(args.json, {"rows": rows, "per_scene": per_scene, "targets": targets, "objects_graph": graph, "configs": {k: v.to_dict() for k, v in bases.items()}})


if __name__ == "__main__":
    main()
