"""Real RGB-D frames: does seeing more views help? (issue 21)

Scenes: YCB-Video dev videos 0001 and 0002 (``../shared/data/ycbv``), split
once by frame into two halves of 10 frames each:

* **tune**: frames 0, 2, ..., 18 (the frames ``--num-views 10`` reads);
* **check**: frames 1, 3, ..., 19.

Settings are chosen on the tune half only; both halves are reported. In each
half a scene is 3, 5 or 10 views spread evenly over its 10 frames.

Masks (one configuration for all scenes, no per-scene tuning):

* ``geometric``: the default weight-free segmenter;
* ``gt-cut``: every geometric mask cut along the ground-truth labels (pure
  masks), so the graph stage is measured apart from the segmenter;
* ``hed`` (only when the ``hed`` extra is installed): geometric masks cut at
  HED edges (``GeometricSegmenter(edges="hed")``).

Per variant (a config) and scene: mean IoU, precision, the number of predicted
objects, and the audit's majority-grouping ceiling (every mask to its majority
object: what a perfect graph would reach with these masks). Timings are of
``segment()`` alone (graph stage, background and refinement) on cached inputs.

``iou_objects`` is the IoU with the pixels that the ground truth calls table
not counted (a label there is neither right nor wrong). With ``gt-cut`` masks
the ceiling is exact on those pixels: cutting along the ground truth also cuts
off, as masks of their own, the rim pixels that YCB-Video's labels call table
although their depth is the object's, and the ceiling paints them as table.
No segmenter without the labels can do that, so ``of_ceiling_objects`` (the
lowest ``iou_objects / ceiling``) is printed beside ``of_ceiling`` (the lowest
``iou / ceiling``).

The 3- and 5-view frames are among the half's 10, so each 3- and 5-view scene
also gets ``iou_10``: the 10-view run's IoU on that scene's frames. A 10-view
score below the 5-view one can mean that the added frames are harder, or that
the added evidence hurt the frames both runs see; ``iou_10`` against ``iou``
tells the two apart (``same@3``, ``same@5`` in the table).

Usage: python benchmarks/bench_ycb_views.py [--half tune|check|all] [--masks geometric gt-cut hed]
       [--variants NAME ...] [--cache DIR] [--json PATH]
"""

from __future__ import annotations

import argparse
import os
import pickle
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from _common import print_table, write_json  # noqa: E402

from graphseg.audit import audit  # noqa: E402
from graphseg.config import Config  # noqa: E402
from graphseg.io import load_scene  # noqa: E402
from graphseg.method.baselines import run_method  # noqa: E402
from graphseg.metrics import evaluate, mean_iou  # noqa: E402
from graphseg.pipeline import compute_masks, compute_matches, lift  # noqa: E402
from graphseg.testing.scenes import gt_cut_masks  # noqa: E402

YCBV = Path(__file__).resolve().parents[2] / "shared" / "data" / "ycbv"
HALVES = {"tune": list(range(0, 20, 2)), "check": list(range(1, 20, 2))}
VIEW_COUNTS = (3, 5, 10)


def frames(half: str, n: int) -> list[int]:
    """``n`` frames spread evenly over the half's 10 (first and last included)."""
    pool = HALVES[half]
    return [pool[i] for i in np.linspace(0, len(pool) - 1, n).round().astype(int)]


def _robust(contractor: object = "constrained", **update) -> Config:
    """The ``robust`` preset with another contractor or sections."""
    return Config.model_validate({**Config.preset("robust").to_dict(), "contractor": contractor, **update})


def _split(name: str, **split) -> Config:
    """Preset ``name`` with its ``split`` section replaced by ``split`` (nothing given: the split off)."""
    return Config.preset(name, split=split or {"enabled": False})


def variants() -> dict[str, Config]:
    """Rows: the presets, each also without the 3D split of objects, then one change each to ``robust`` (issue 21's items)."""
    return {
        "rgbd": Config.preset("rgbd"),
        "rgbd without split": _split("rgbd"),
        "rgbd, one split grid": Config.preset("rgbd", split={"fine_voxel_size": None}),
        "rgbd, no mask snap": Config.preset("rgbd", split={"snap_share": None}),
        "rgbd, no mask join": Config.preset("rgbd", split={"mask_join": None}),
        "rgbd + rim growing": Config.preset("rgbd", grow={"enabled": True}),
        "rgbd + borders drawn again": Config.preset("rgbd", split={"settle_band": 3}),
        "rgbd + rim growing + borders drawn again": Config.preset("rgbd", grow={"enabled": True}, split={"settle_band": 3}),
        "rgbd, split without merge": _split("rgbd", enabled=True, merge_ncut=None),
        "rgbd, split with mask guard 0.8 / 0.5": _split("rgbd", enabled=True, own_fraction=0.8, own_cover=0.5),
        "robust": Config.preset("robust"),
        "robust without split": _split("robust"),
        "multicut without split": _split("multicut"),
        "robust + refine": _robust(refine={"enabled": True}),
        "robust, gaec": _robust("gaec"),
        "robust, gaec repulsion 2": _robust({"gaec": {"repulsion": 2.0}}),
        "robust, gaec fragments 300 px": _robust({"gaec": {"fragment_area": 300.0}}),
        "robust, gaec, adjacency no colour": Config.preset("multicut"),
    }


def inputs(video: str, half: str, n: int, masks_kind: str, cache: Path | None):
    path = None if cache is None else cache / f"{video}-{half}-{n}-{masks_kind}.pkl"
    if path is not None and path.is_file():
        with open(path, "rb") as f:
            return pickle.load(f)
    cfg = Config.preset("rgbd")
    scene = lift(load_scene(YCBV / video, views=frames(half, n)), None, cfg)
    if masks_kind == "hed":
        from graphseg.backends.segmenters.geometric import GeometricSegmenter

        masks = compute_masks(scene, GeometricSegmenter(edges="hed"), cfg)
    else:
        masks = compute_masks(scene, "geometric", cfg)
        if masks_kind == "gt-cut":
            masks = gt_cut_masks(masks, scene)
    out = (scene, masks, compute_matches(scene, None, cfg))
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "wb") as f:
            pickle.dump(out, f)
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--half", choices=["tune", "check", "all"], default="all")
    ap.add_argument("--masks", nargs="*", default=["geometric", "gt-cut"])
    ap.add_argument("--variants", nargs="*", help="only these variants (default: all)")
    ap.add_argument("--cache", help="folder for the per-scene inputs (pickles), reused across runs")
    ap.add_argument("--json", default="benchmarks/results/ycb_views.json")
    args = ap.parse_args(argv)
    if not YCBV.is_dir():
        print(f"no YCB-Video frames at {YCBV}; nothing to measure")
        return
    var = variants()
    if args.variants:
        var = {k: var[k] for k in args.variants}
    halves = ["tune", "check"] if args.half == "all" else [args.half]
    cache = Path(args.cache) if args.cache else None
    per_scene = []
    t0 = time.perf_counter()
    assert VIEW_COUNTS[-1] == 10 and all(n < 10 for n in VIEW_COUNTS[:-1])  # the 10-view run comes last and holds every frame
    for half in halves:
        for masks_kind in args.masks:
            for video in ("0001", "0002"):
                for n in VIEW_COUNTS:
                    scene, masks, matches = inputs(video, half, n, masks_kind, cache)
                    gt = [v.instances for v in scene.views]
                    pts = [v.points for v in scene.views]
                    for vname, cfg in var.items():
                        t = time.perf_counter()
                        r = run_method(scene, masks, matches, cfg)
                        sec = time.perf_counter() - t
                        m = evaluate(r.labels, gt, pts, names=scene.objects)
                        ceiling = audit(r, scene)["summary"].get("majority_grouping_iou")
                        objects_only = [np.where(np.asarray(g) > 0, lab, 0) for lab, g in zip(r.labels, gt)]  # table pixels unlabelled: not counted
                        row = {
                            "half": half, "masks": masks_kind, "video": video, "views": n, "variant": vname,
                            "iou": m["mean"]["iou"], "iou_objects": mean_iou(objects_only, gt, pts), "precision": m["mean"]["precision"], "ceiling": ceiling,
                            "objects_pred": m["num_pred"], "objects_gt": m["num_gt"], "seconds": sec,
                        }
                        per_scene.append(row)
                        if n == 10:  # the 10-view run on the frames of each smaller scene of this video
                            at = {v.name: i for i, v in enumerate(scene.views)}
                            for small in per_scene:
                                if (small["half"], small["masks"], small["video"], small["variant"]) == (half, masks_kind, video, vname) and small["views"] < 10:
                                    idx = [at[nm] for nm in small["frames"]]
                                    sub = evaluate([r.labels[i] for i in idx], [gt[i] for i in idx], [pts[i] for i in idx])
                                    small["iou_10"] = sub["mean"]["iou"]
                        else:
                            row["frames"] = [v.name for v in scene.views]
                        print(f"  {half:5s} {masks_kind:9s} {video} {n:2d} views  {vname:24s} IoU {row['iou']:.3f}  ceiling {ceiling:.3f}  "
                              f"objects {row['objects_pred']}/{row['objects_gt']}  {sec:.2f} s", flush=True)
    rows = []
    for half in halves:
        for masks_kind in args.masks:
            for vname in var:
                sel = [r for r in per_scene if r["half"] == half and r["masks"] == masks_kind and r["variant"] == vname]
                row = {"half": half, "masks": masks_kind, "variant": vname}
                for n in VIEW_COUNTS:
                    s = [r for r in sel if r["views"] == n]
                    row[f"iou@{n}"] = float(np.mean([r["iou"] for r in s]))
                    row[f"ceil@{n}"] = float(np.mean([r["ceiling"] for r in s]))
                for n in VIEW_COUNTS[:-1]:
                    s = [r for r in sel if r["views"] == n]
                    row[f"same@{n}"] = float(np.mean([r["iou_10"] for r in s]))
                row["iou"] = float(np.mean([r["iou"] for r in sel]))
                row["of_ceiling"] = float(min(r["iou"] / r["ceiling"] for r in sel if r["ceiling"]))
                row["of_ceiling_objects"] = float(min(r["iou_objects"] / r["ceiling"] for r in sel if r["ceiling"]))
                row["max_s"] = float(max(r["seconds"] for r in sel if r["views"] == 10))
                rows.append(row)
    print()
    print("same@n: the 10-view run's IoU on the frames of the n-view scenes (compare with iou@n)")
    print("of_ceiling_objects: the lowest IoU / ceiling with the ground truth's table pixels not counted")
    print_table(rows, ["half", "masks", "variant", *(f"iou@{n}" for n in VIEW_COUNTS), *(f"same@{n}" for n in VIEW_COUNTS[:-1]), *(f"ceil@{n}" for n in VIEW_COUNTS), "iou", "of_ceiling", "of_ceiling_objects", "max_s"])
    print(f"total {time.perf_counter() - t0:.0f} s")
    write_json(args.json, {"rows": rows, "per_scene": per_scene, "halves": HALVES, "configs": {k: v.to_dict() for k, v in var.items()}})


if __name__ == "__main__":
    main()
