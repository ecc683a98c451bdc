"""RGB-only input: the ``sfm`` lifter (structure from motion + stereo) against the same scenes given depth.

Scenes
    * synthetic pybullet scenes, 640x480, 5 objects: narrow arcs (a wrist-camera
      sweep) of 35 degrees / 5 views and 70 degrees / 8 views (seeds 200 and 201),
      50 degrees / 3, 5, 10 views, and full 360-degree rings of 3, 5 and 10 views
      (seed 200).
      RGB-only = depth, poses *and* intrinsics removed (``graphseg.sim.strip.rgb_only``).
    * YCB-Video 0001 and 0002 (10 views over the 20 frames, ``../shared/data/ycbv``,
      skipped if absent): depth hidden (intrinsics and poses kept, so the scale is
      metric) and fully RGB-only (intrinsics and poses hidden too).

Each scene is run twice with one configuration (``Config.preset("rgbd")``, the
CLI default; no per-scene tuning): given depth (lifter ``rgbd``) and RGB-only
(lifter ``sfm``, chosen automatically). Every run is a fresh subprocess, so
its peak resident memory is its own.

Measures
    registration rate; rotation error (degrees, median over views) and camera
    centre error (median, as a fraction of the median camera-to-scene distance)
    after the best similarity between SfM and true camera centres; depth error
    (median relative error of the lifted depth, scaled by that similarity)
    and coverage (pixels with a lifted point / pixels with true depth; ``dense``
    = stereo alone); segmentation quality with ``graphseg.metrics.evaluate``
    computed on the *true* point maps for both runs (every pixel with true
    depth counts, so missing RGB-only points cannot flatter the score); seconds
    per stage (wall) and the CPU seconds of the process (``time.process_time``,
    all threads: the machine was shared with other jobs); peak RSS.

Usage: python benchmarks/bench_rgb_only.py [--quick] [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from _common import print_table, write_json  # noqa: E402

YCBV = Path(__file__).resolve().parents[2] / "shared" / "data" / "ycbv"
ROOT = Path(__file__).resolve().parents[1]
# subprocesses import graphseg from this checkout
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])])}
SEEDS = (200, 201)
SYNTH = [
    ("arc35-5", 35.0, 5),
    ("arc70-8", 70.0, 8),
    ("arc50-3", 50.0, 3),
    ("arc50-5", 50.0, 5),
    ("arc50-10", 50.0, 10),
    ("ring-3", 360.0, 3),
    ("ring-5", 360.0, 5),
    ("ring-10", 360.0, 10),
]


def _scene(spec: dict):
    from graphseg.io import load_scene
    from graphseg.sim.pybullet_scenes import synthesize

    if spec["kind"] == "synth":
        return synthesize(seed=spec["seed"], objects=5, views=spec["views"], size=(640, 480), arc_deg=spec["arc"])
    return load_scene(YCBV / spec["video"], num_views=10)


def _pose_errors(est, ref):
    from graphseg.backends.align import umeyama

    s, R, t = umeyama(np.array([T[:3, 3] for T in est]), np.array([T[:3, 3] for T in ref]))
    rot, cen = [], []
    for a, b in zip(est, ref):
        M = (R @ a[:3, :3]).T @ b[:3, :3]
        rot.append(np.degrees(np.arccos(np.clip((np.trace(M) - 1) / 2, -1, 1))))
        cen.append(np.linalg.norm(s * R @ a[:3, 3] + t - b[:3, 3]))
    return s, float(np.median(rot)), float(np.median(cen))


def one(spec: dict) -> dict:
    """Run one scene in this process; returns the measures."""
    from graphseg.config import Config
    from graphseg.metrics import evaluate
    from graphseg.pipeline import lift, run
    from graphseg.scene import SceneError
    from graphseg.sim.strip import rgb_only

    cfg = Config.preset("rgbd")
    scene = _scene(spec)
    truth = lift(scene, None, cfg)
    gt_pts = [v.points for v in truth.views]
    inst = [v.instances for v in scene.views]
    out = {**spec, "views_n": len(scene)}
    if spec["mode"] == "depth":
        inp = scene
    else:
        inp = rgb_only(scene, keep_intrinsics=spec["mode"] == "nodepth")
        if spec["mode"] == "nodepth":  # depth hidden, intrinsics and poses kept
            inp = type(scene)([v.replace(cam_to_world=w.cam_to_world) for v, w in zip(inp.views, scene.views)], dict(scene.objects), scene.name, dict(scene.meta))
    c0, t0 = time.process_time(), time.perf_counter()
    try:
        lifted = lift(inp, None, cfg)
    except SceneError as err:
        out.update(error=str(err).splitlines()[0], registered=0.0)
        return out
    t_lift = time.perf_counter() - t0
    result = run(lifted, cfg)
    times = dict(result.info["pipeline"]["timings"])
    times["lift"] = t_lift
    times["total"] = time.perf_counter() - t0
    out["cpu_s"] = time.process_time() - c0
    out["times"] = times
    m = evaluate(result.labels, inst, gt_pts, names=scene.objects)
    out.update({k: m["mean"].get(k) for k in ("iou", "f1", "iou_sel", "precision", "pixel_utility")})
    out["objects_pred"] = m["num_pred"]
    out["objects_gt"] = m["num_gt"]
    if spec["mode"] != "depth":
        sfm = lifted.meta.get("sfm", {})
        out["registered"] = sfm.get("registered", 0) / len(scene)
        out["scale"] = lifted.meta.get("scale")
        s, rot, cen = _pose_errors([v.cam_to_world for v in lifted.views], [v.cam_to_world for v in scene.views])
        dist = np.median([np.linalg.norm(np.nanmedian(p.reshape(-1, 3), 0) - v.cam_to_world[:3, 3]) for p, v in zip(gt_pts, scene.views)])
        out["rot_err_deg"], out["centre_err_rel"] = rot, cen / float(dist)
        errs, cov, dense = [], [], []
        for v, g in zip(lifted.views, scene.views):
            z = v.camera_points()[..., 2] * s
            ok_gt = g.depth > 0
            ok = ok_gt & np.isfinite(z)
            errs.append(np.abs(z[ok] - g.depth[ok]) / g.depth[ok])
            cov.append(ok.sum() / max(ok_gt.sum(), 1))
            dense.append(v.meta.get("dense_fraction", 0.0))
        e = np.concatenate(errs)
        out["depth_err_med"] = float(np.median(e)) if e.size else None
        out["depth_err_p90"] = float(np.percentile(e, 90)) if e.size else None
        out["coverage"] = float(np.mean(cov))
        out["dense"] = float(np.mean(dense))
    out["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return out


def cli_timing(tmp: Path) -> dict:
    """``graphseg run`` on a folder of 8 plain 640x480 images (70-degree arc): wall, CPU, peak RSS of the child."""
    from graphseg.io.images import write_rgb
    from graphseg.sim.pybullet_scenes import synthesize

    scene = synthesize(seed=SEEDS[0], objects=5, views=8, size=(640, 480), arc_deg=70.0)
    folder = tmp / "photos"
    folder.mkdir(parents=True, exist_ok=True)
    for v in scene.views:
        write_rgb(folder / f"{v.name}.png", v.rgb)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "graphseg.cli", "run", str(folder), "-o", str(tmp / "out"), "--quiet"], capture_output=True, text=True, env=ENV)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return {
        "exit": proc.returncode,
        "wall_s": wall,
        "cpu_s": (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime),
        "peak_rss_mb": after.ru_maxrss / 1024,
        "stdout": proc.stdout.strip().splitlines()[:1],
    }


def specs(quick: bool) -> list[dict]:
    out = []
    for seed in SEEDS[:1] if quick else SEEDS:
        for k, (name, arc, n) in enumerate(SYNTH[:2] if quick else SYNTH):
            if seed != SEEDS[0] and k >= 2:
                continue  # the second seed for the two acceptance arcs only (CPU time on the shared machine)
            for mode in ("depth", "rgb"):
                out.append({"kind": "synth", "scene": f"{name} s{seed}", "group": name, "seed": seed, "arc": arc, "views": n, "mode": mode})
    if not quick:
        for vid in ("0001", "0002"):
            if (YCBV / vid).is_dir():
                for mode in ("depth", "nodepth", "rgb"):
                    out.append({"kind": "ycbv", "scene": f"ycbv-{vid}", "group": f"ycbv-{vid}", "video": vid, "mode": mode})
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="the two acceptance arcs, one seed")
    ap.add_argument("--json", default="benchmarks/results/rgb_only.json")
    ap.add_argument("--groups", nargs="+", help="rerun only these scene groups and merge them into the existing JSON")
    ap.add_argument("--one", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.one:
        print("RESULT " + json.dumps(one(json.loads(args.one)), default=float), flush=True)
        return 0
    rows = []
    todo = specs(args.quick)
    old_cli = None
    if args.groups:
        old = json.loads(Path(args.json).read_text())
        rows = [r for r in old["rows"] if r["group"] not in args.groups]
        old_cli = old.get("cli_8_views")
        todo = [s for s in todo if s["group"] in args.groups]
    for spec in todo:
        proc = subprocess.run([sys.executable, __file__, "--one", json.dumps(spec)], capture_output=True, text=True, env=ENV)
        line = [x for x in proc.stdout.splitlines() if x.startswith("RESULT ")]
        if not line:
            print(proc.stdout[-2000:], proc.stderr[-4000:], file=sys.stderr)
            rows.append({**spec, "error": "crashed: " + (proc.stderr.strip().splitlines() or ["?"])[-1]})
        else:
            rows.append(json.loads(line[0][7:]))
        r = rows[-1]
        print(f"{r['scene']:16s} {r['mode']:8s} iou {r.get('iou') or float('nan'):.3f} lift {r.get('times', {}).get('lift', float('nan')):.1f}s {r.get('error', '')}", flush=True)
    import tempfile

    if old_cli is not None:
        cli = old_cli
    else:
        with tempfile.TemporaryDirectory() as tmp:
            cli = cli_timing(Path(tmp))
    print(f"CLI run, 8 views 640x480 RGB-only: exit {cli['exit']}, {cli['wall_s']:.1f} s wall, {cli['cpu_s']:.1f} s CPU, {cli['peak_rss_mb']:.0f} MB peak RSS")
    table = summarise(rows)
    cols = ["scenes", "n", "registered", "rot_err_deg", "centre_err_rel", "depth_err_med", "coverage", "dense", "iou_depth", "iou_rgb", "f1_rgb", "util_rgb", "lift_s", "total_s", "cpu_s", "peak_rss_mb"]
    text = print_table(table, cols)
    write_json(args.json, {"rows": rows, "summary": table, "cli_8_views": cli})
    md = Path(args.json).with_suffix(".md")
    md.write_text(
        "# RGB-only (structure from motion)\n\n"
        + text
        + f"\n\n`graphseg run` on 8 plain 640x480 images (70-degree arc): exit {cli['exit']}, {cli['wall_s']:.1f} s wall, "
        f"{cli['cpu_s']:.1f} s CPU, {cli['peak_rss_mb']:.0f} MB peak RSS.\n"
    )
    print(f"wrote {md}")
    return 0


def summarise(rows: list[dict]) -> list[dict]:
    """Mean per scene group and mode (RGB-only rows next to their own given-depth runs)."""
    out = []
    groups: dict[tuple[str, str], list[dict]] = {}
    for r in rows:
        mode = r["mode"]
        groups.setdefault((r["group"], mode), []).append(r)

    def mean(rs: list[dict], key: str, sub: str | None = None):
        vals = [(r.get(sub, {}) or {}).get(key) if sub else r.get(key) for r in rs]
        vals = [v for v in vals if isinstance(v, (int, float)) and v == v]
        return float(np.mean(vals)) if vals else None

    for (group, mode), rs in groups.items():
        if mode == "depth":
            continue
        base = groups.get((group, "depth"), [])
        ok = [r for r in rs if "error" not in r]
        label = group if mode == "rgb" else f"{group} (depth hidden, K + poses)"
        out.append({
            "scenes": label,
            "n": f"{len(ok)}/{len(rs)}",
            "registered": float(np.mean([r.get("registered", 0.0) for r in rs])),
            "rot_err_deg": mean(ok, "rot_err_deg"),
            "centre_err_rel": mean(ok, "centre_err_rel"),
            "depth_err_med": mean(ok, "depth_err_med"),
            "coverage": mean(ok, "coverage"),
            "dense": mean(ok, "dense"),
            "iou_depth": mean(base, "iou"),
            "iou_rgb": float(np.mean([r.get("iou") or 0.0 for r in rs])),  # a failed run counts as 0
            "f1_rgb": float(np.mean([r.get("f1") or 0.0 for r in rs])),
            "util_rgb": mean(ok, "pixel_utility"),
            "lift_s": mean(ok, "lift", "times"),
            "total_s": mean(ok, "total", "times"),
            "cpu_s": mean(ok, "cpu_s"),
            "peak_rss_mb": mean(ok, "peak_rss_mb"),
        })
    return out


if __name__ == "__main__":
    sys.exit(main())
