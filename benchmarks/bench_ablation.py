"""Ablation of robust contraction and the baselines, on equal inputs (issue 12).

Scenes (one configuration for all; no per-scene tuning)
    * synthetic dev scenes: seeds 100..109 with 3/5/10 views (as
      ``bench_quality.py``), ``geometric`` segmenter; oracle parts k = 1..4 on
      seeds 100..102 (100 has 3 views);
    * synthetic stress set: seeds 200..203, ``layout="touching"`` and
      ``"stacked"``, 5 views, ``geometric`` segmenter;
    * YCB-Video dev videos 0001 and 0002 (``../shared/data/ycbv``), 3, 5 and 10
      views, ``geometric``; oracle parts k = 1..4 with 10 views.

Variants (rows): GraphSeg [rgbd] (components contraction: the paper's
method and the reference), GraphSeg-minus, and each robust component switched
on: ``depth_repulsion`` cannot-links (depth jumps; + concave creases) with the
constrained union-find; concave creases with jumps only above 10 cm;
``smooth_adjacency`` (parts that meet along a smooth, convex boundary that is
no colour edge) in the 3D stage; both together with DBSCAN outlier removal
before the Chamfer test (the ``robust`` preset), the preset without that
outlier removal, and the preset with greedy additive edge contraction
(``gaec``), with weighted cannot-links (``repulsion`` 2), with fragments
that join one cluster only (``fragment_area`` 300 px), and with per-pixel
refinement (issue 21); ``core_attach`` (small masks follow one edge),
``view_consensus`` in place of ``pixel_match``; then the baselines
``maskclustering`` and ``sam3d``. Inputs (lifted scene, masks, matches) are
computed once per scene and segmenter and shared by every row.

Metrics (``graphseg.metrics.evaluate``): mean IoU, F1, IoU_sel, precision,
pixel utility, averaged over scenes.

Usage: python benchmarks/bench_ablation.py [--quick] [--cache DIR] [--only GROUP ...] [--variants PREFIX ...] [--json PATH]
       python benchmarks/bench_ablation.py --merge A.json B.json --json benchmarks/results/ablation.json
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from _common import print_table, write_json  # noqa: E402

from graphseg.config import Config  # noqa: E402
from graphseg.io import load_scene  # noqa: E402
from graphseg.method.baselines import run_method  # noqa: E402
from graphseg.metrics import evaluate  # noqa: E402
from graphseg.pipeline import compute_masks, compute_matches, lift  # noqa: E402

YCBV = Path(__file__).resolve().parents[2] / "shared" / "data" / "ycbv"
KEYS = ("iou", "f1", "iou_sel", "precision", "pixel_utility")

JUMP: dict = {}
CONCAVE = {"concave": 0.2, "fraction": 0.5, "reach": 4}
ROBUST = Config.preset("robust").criterion_options("depth_repulsion")  # concave creases + jumps > 10 cm


def _variant(base: Config, **update) -> Config:
    return Config.model_validate({**base.to_dict(), **update})


def _with_repulsion(base: Config, opts: dict) -> list:
    """The base's stages (with their options) plus depth_repulsion in each stage."""
    return [[*stage, {"depth_repulsion": dict(opts)}] for stage in base.to_dict()["stages"]]


def _without_outliers(cfg: Config) -> Config:
    """``cfg`` with ``chamfer_3d``'s per-node outlier removal switched off."""
    stages = []
    for stage in cfg.to_dict()["stages"]:  # each entry is {criterion name: options}
        entries = []
        for entry in stage:
            ((name, opts),) = entry.items()
            entries.append({name: {**opts, "outliers": None} if name == "chamfer_3d" else opts})
        stages.append(entries)
    return _variant(cfg, stages=stages)


def variants() -> dict[str, Config]:
    base = Config.preset("rgbd")
    stages = base.to_dict()["stages"]
    return {
        "GraphSeg [rgbd]": base,
        "GraphSeg-minus [rgbd]": base.without_3d(),
        "+ repulsion (jump), constrained UF": _variant(base, stages=_with_repulsion(base, JUMP), contractor="constrained"),
        "+ repulsion (jump+concave), constrained UF": _variant(base, stages=_with_repulsion(base, CONCAVE), contractor="constrained"),
        "+ repulsion (jump 10 cm + concave), constrained UF": _variant(base, stages=_with_repulsion(base, ROBUST), contractor="constrained"),
        "+ smooth_adjacency, constrained UF": _variant(base, stages=[stages[0], [*stages[1], "smooth_adjacency"]], contractor="constrained"),
        "robust preset: repulsion (jump 10 cm + concave) + smooth_adjacency + Chamfer DBSCAN, constrained UF": Config.preset("robust"),
        "robust preset without Chamfer outlier removal": _without_outliers(Config.preset("robust")),
        "robust preset with the gaec contractor": _variant(Config.preset("robust"), contractor="gaec"),
        "robust preset, gaec with cannot-links of weight 2": _variant(Config.preset("robust"), contractor={"gaec": {"repulsion": 2.0}}),
        "robust preset, gaec, fragments (< 300 px) join one cluster": _variant(Config.preset("robust"), contractor={"gaec": {"fragment_area": 300.0}}),
        "robust preset + per-pixel refinement": _variant(Config.preset("robust"), refine={"enabled": True}),
        "robust preset, gaec, smooth_adjacency without its colour test": Config.preset("multicut"),
        "GraphSeg [rgbd] without the 3D split of objects": _variant(base, split={"enabled": False}),
        "robust preset without the 3D split of objects": _variant(Config.preset("robust"), split={"enabled": False}),
        "multicut preset without the 3D split of objects": _variant(Config.preset("multicut"), split={"enabled": False}),
        "GraphSeg [rgbd], split without the 3D merge of objects": _variant(base, split={"enabled": True, "merge_ncut": None}),
        "+ core_attach": _variant(base, contractor="core_attach"),
        "+ repulsion (jump+concave), core_attach": _variant(base, stages=_with_repulsion(base, CONCAVE), contractor="core_attach"),
        "view_consensus for pixel_match": _variant(base, stages=[["view_consensus"], *stages[1:]]),
        "MaskClustering-style": _variant(base, method="maskclustering"),
        "SAM3D-style": _variant(base, method="sam3d"),
    }


def scene_specs(quick: bool):
    """(group, name, loader, segmenter, backend options) for every scene."""
    from graphseg.sim.pybullet_scenes import synthesize

    views = [3, 5, 10]
    seeds = list(range(100, 103 if quick else 110))
    for k, seed in enumerate(seeds):
        n_obj = 5 + (seed * 7) % 6
        nv = views[k % 3]
        yield "synthetic", f"synth-{seed}", lambda s=seed, n=n_obj, v=nv: synthesize(seed=s, objects=n, views=v, size=(640, 480)), "geometric", {}
    for layout in ("touching", "stacked"):
        for seed in range(200, 202 if quick else 204):
            yield f"stress-{layout}", f"{layout}-{seed}", lambda s=seed, lay=layout: synthesize(seed=s, objects=6, views=5, size=(640, 480), layout=lay), "geometric", {}
    for parts in (1, 2, 3, 4):
        for k, seed in enumerate(range(100, 103)):
            n_obj = 5 + (seed * 7) % 6
            nv = views[k % 3]
            yield f"synthetic oracle k={parts}", f"synth-{seed}", lambda s=seed, n=n_obj, v=nv: synthesize(seed=s, objects=n, views=v, size=(640, 480)), "oracle-parts", {"oracle-parts": {"parts": parts}}
    for vid in ("0001", "0002"):
        if not (YCBV / vid).is_dir():
            continue
        for nv in (3, 5, 10):
            yield f"ycbv {nv} views", f"ycbv-{vid}-{nv}", lambda v=vid, n=nv: load_scene(YCBV / v, num_views=n), "geometric", {}
        for parts in (1, 2, 3, 4):
            yield f"ycbv oracle k={parts}", f"ycbv-{vid}-10", lambda v=vid: load_scene(YCBV / v, num_views=10), "oracle-parts", {"oracle-parts": {"parts": parts}}


def inputs(name, loader, seg, options, cache: Path | None):
    tag = seg if not options else f"{seg}{options[seg]['parts']}"
    path = None if cache is None else cache / f"{name}-{tag}.pkl"
    if path is not None and path.is_file():
        with open(path, "rb") as f:
            return pickle.load(f)
    base = Config.preset("rgbd")
    cfg = base.model_copy(update={"backends": base.backends.model_copy(update={"options": options})})
    scene = lift(loader(), None, cfg)
    out = (scene, compute_masks(scene, seg, cfg), compute_matches(scene, None, cfg))
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "wb") as f:
            pickle.dump(out, f)
    return out


def markdown(rows) -> str:
    """Per scene group, the paper's Table I layout: IoU, F1, IoU_sel, precision, pixel utility per variant."""
    out = []
    for group in dict.fromkeys(r["scenes"] for r in rows):
        sel = [r for r in rows if r["scenes"] == group]
        out.append(f"**{group}** (n = {sel[0]['n']})\n")
        out.append("| method | IoU | F1 | IoU_sel | precision | pixel utility |")
        out.append("|---|---|---|---|---|---|")
        for r in sel:
            out.append(f"| {r['variant']} | " + " | ".join("-" if r[k] is None else f"{r[k]:.3f}" for k in KEYS) + " |")
        out.append("")
    return "\n".join(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="fewer synthetic scenes")
    ap.add_argument("--cache", help="folder for the per-scene inputs (pickles), reused across runs")
    ap.add_argument("--only", nargs="*", help="run only these groups (prefix match)")
    ap.add_argument("--variants", nargs="*", help="run only these variants (prefix match)")
    ap.add_argument("--json", default="benchmarks/results/ablation.json")
    ap.add_argument("--merge", nargs="*", help="only merge these JSON files (rows and per-scene lists) into --json and print the markdown tables")
    args = ap.parse_args(argv)
    if args.merge:
        parts = [json.loads(Path(f).read_text()) for f in args.merge]
        merged = {"rows": [r for p in parts for r in p["rows"]], "per_scene": [r for p in parts for r in p["per_scene"]], "configs": parts[0]["configs"]}
        write_json(args.json, merged)
        print(markdown(merged["rows"]))
        return
    cache = Path(args.cache) if args.cache else None
    var = {k: v for k, v in variants().items() if not args.variants or any(k.startswith(p) for p in args.variants)}
    acc: dict[tuple[str, str], list[dict]] = {}
    per_scene = []
    t0 = time.perf_counter()
    for group, name, loader, seg, options in scene_specs(args.quick):
        if args.only and not any(group.startswith(o) for o in args.only):
            continue
        t = time.perf_counter()
        scene, masks, matches = inputs(name, loader, seg, options, cache)
        gt = [v.instances for v in scene.views]
        pts = [v.points for v in scene.views]
        line = []
        for vname, cfg in var.items():
            r = run_method(scene, masks, matches, cfg)
            m = evaluate(r.labels, gt, pts, names=scene.objects)
            acc.setdefault((group, vname), []).append(m["mean"])
            per_scene.append({"group": group, "scene": name, "variant": vname, "objects_gt": m["num_gt"], "objects_pred": m["num_pred"], **{k: m["mean"].get(k) for k in KEYS}})
            line.append(f"{m['mean']['iou']:.3f}")
        print(f"  {group:22s} {name:16s} {' '.join(line)}  ({time.perf_counter() - t:.0f} s)", flush=True)
    rows = []
    for (group, vname), ms in acc.items():
        row = {"scenes": group, "variant": vname, "n": len(ms)}
        for k in KEYS:
            vals = [a[k] for a in ms if a.get(k) is not None]
            row[k] = float(np.mean(vals)) if vals else None
        rows.append(row)
    rows.sort(key=lambda r: (r["scenes"], list(var).index(r["variant"])))
    print("\nvariants (columns above, in order):", "; ".join(var))
    print()
    print_table(rows, ["scenes", "variant", "n", *KEYS])
    print()
    print(markdown(rows))
    print(f"total {time.perf_counter() - t0:.0f} s")
    write_json(args.json, {"rows": rows, "per_scene": per_scene, "configs": {k: v.to_dict() for k, v in var.items()}})


if __name__ == "__main__":
    main()
