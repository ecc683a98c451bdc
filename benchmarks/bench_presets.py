"""What each preset costs: ``segment()`` time, its steps and peak memory on real and synthetic scenes.

Scenes: YCB-Video 0001 and 0002 with 10 views (from ``../shared/data/ycbv``,
skipped when absent) and one synthetic pybullet scene (seed 103, 10 views,
640x480; skipped without the ``sim`` extra). The inputs (``rgbd`` lift,
``geometric`` masks, ``reprojection`` matches) are computed once per scene;
only ``segment()`` is timed, best of ``--repeat`` runs, with its own step
timings (background, mask composition, each stage, split, refine, rim growing and trimming, outputs) from the best run.
Peak memory is tracemalloc's peak over one more run (numpy included; the
inputs themselves are not counted). IoU is printed as a check (the YCB rows are
the scenes of ``bench_ablation.py``'s 10-view rows). Run it on an idle machine:
the timings are wall times.

Writes the table as Markdown next to the JSON (same name, ``.md``).

Besides the presets, ``--presets`` takes the variants of :data:`VARIANTS`
(issue 21: ``"robust + refine"``, per-pixel refinement after contraction;
``"robust, gaec"``, greedy additive edge contraction; ``"rgbd without split"``
and ``"robust without split"``, the presets without their 3D split and merge of
objects, whose time is the ``split`` column; ``"rgbd without merge"``, the
split alone; ``"rgbd, one split grid"``, the split without its fine 5 mm pass;
``"rgbd, no mask snap"``, rgbd without giving the pixels the voxel border cut off a mask back;
``"rgbd, no mask join"``, rgbd without joining the pieces its masks hold together (``split.mask_join``);
``"rgbd + rim growing"``, rgbd with the unlabelled pixels at each object's rim given to it up to the colour edge (``grow``, the ``grow`` column);
``"rgbd + borders drawn again"``, rgbd with the minimum cut that draws each split border again, ``split.settle_band`` 3;
``"rgbd + rim growing + borders drawn again"``, both).

Usage: python benchmarks/bench_presets.py [--presets rgbd paper robust "robust + refine" "robust, gaec"] [--repeat 3] [--json PATH]
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

sys.path.insert(0, os.path.dirname(__file__))
from _common import peak_traced_mb, print_table, timed, write_json  # noqa: E402

from graphseg.config import Config  # noqa: E402
from graphseg.io import load_scene  # noqa: E402
from graphseg.method.segment import segment  # noqa: E402
from graphseg.metrics import evaluate  # noqa: E402
from graphseg.pipeline import compute_masks, compute_matches, lift  # noqa: E402

YCBV = Path(__file__).resolve().parents[2] / "shared" / "data" / "ycbv"
STEPS = ("background", "compose", "stage0", "stage1", "split", "refine", "grow", "trim", "outputs")

#: Named configurations other than the presets.
VARIANTS = {
    "robust + refine": lambda: Config.preset("robust", refine={"enabled": True}),
    "robust, gaec": lambda: Config.model_validate({**Config.preset("robust").to_dict(), "contractor": "gaec"}),
    "rgbd without split": lambda: Config.preset("rgbd", split={"enabled": False}),
    "rgbd without merge": lambda: Config.preset("rgbd", split={"enabled": True, "merge_ncut": None}),
    "rgbd, one split grid": lambda: Config.preset("rgbd", split={"fine_voxel_size": None}),
    "rgbd, no mask snap": lambda: Config.preset("rgbd", split={"snap_share": None}),
    "rgbd, no mask join": lambda: Config.preset("rgbd", split={"mask_join": None}),
    "rgbd + rim growing": lambda: Config.preset("rgbd", grow={"enabled": True}),
    "rgbd + borders drawn again": lambda: Config.preset("rgbd", split={"settle_band": 3}),
    "rgbd + rim growing + borders drawn again": lambda: Config.preset("rgbd", grow={"enabled": True}, split={"settle_band": 3}),
    "robust without split": lambda: Config.preset("robust", split={"enabled": False}),
}


def config(name: str) -> Config:
    return VARIANTS[name]() if name in VARIANTS else Config.preset(name)


def scenes():
    """(name, loader) of every scene available here."""
    for vid in ("0001", "0002"):
        if (YCBV / vid).is_dir():
            yield f"ycbv-{vid} (10 views)", lambda v=vid: load_scene(YCBV / v, num_views=10)
    try:
        import pybullet  # noqa: F401

        from graphseg.sim.pybullet_scenes import synthesize
    except ImportError:
        print("pybullet missing (extra 'sim'): synthetic scene skipped")
        return
    yield "synthetic seed 103 (10 views)", lambda: synthesize(seed=103, objects=5 + (103 * 7) % 6, views=10, size=(640, 480))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--presets", nargs="*", default=["rgbd", "paper", "robust"])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", default="benchmarks/results/presets.json")
    args = ap.parse_args(argv)
    base = Config.preset("rgbd")
    rows = []
    for name, loader in scenes():
        scene = lift(loader(), None, base)
        masks = compute_masks(scene, "geometric", base)
        matches = compute_matches(scene, None, base)
        for preset in args.presets:
            cfg = config(preset)
            best, runs = float("inf"), None
            for _ in range(args.repeat):
                sec, result = timed(lambda: segment(scene, masks, matches, cfg))
                if sec < best:
                    best, runs = sec, result
            mem = peak_traced_mb(lambda: segment(scene, masks, matches, cfg))
            m = evaluate(runs.labels, [v.instances for v in scene.views], [v.points for v in scene.views])
            steps = runs.info["timings"]
            rows.append({"scene": name, "preset": preset, "segment_s": best, **{f"{k}_s": steps.get(k) for k in STEPS},
                         "peak_traced_mb": mem, "objects": runs.num_objects, "iou": m["mean"]["iou"]})
            print(f"  {name} {preset}: {best:.3f} s, {mem:.0f} MB, IoU {m['mean']['iou']:.3f}", flush=True)
    print()
    table = print_table(rows, ["scene", "preset", "segment_s", *[f"{k}_s" for k in STEPS], "peak_traced_mb", "objects", "iou"])
    write_json(args.json, {"repeat": args.repeat, "rows": rows})
    md = Path(args.json).with_suffix(".md")
    md.write_text(f"# bench_presets.py: segment() per preset (best of {args.repeat}, cached inputs; peak = tracemalloc)\n\n{table}\n")
    print(f"wrote {md}")


if __name__ == "__main__":
    main()
