"""RGB-only input (photos only) against the same scenes given their true depth.

Scenes
    The 30 fixed pybullet scenes of :mod:`graphseg.sim.families` (640x480): two
    object sets (pybullet's bundled objects; procedural boxes, cylinders and spheres
    with plain, striped, noise and photo-like textures; and both mixed), 3-9
    objects, spread, touching and stacked layouts, seven table tops, the default
    and varied lighting (direction, tint, coefficients, shadows), arcs of 20-90
    degrees with 3, 5, 8 and 10 views and 10-view rings of 120-360 degrees. The
    split into a **tune** half and a **check** half is fixed in
    :mod:`graphseg.sim.families` (seed parity; each half holds one scene of every
    pair). Settings are chosen on the tune half only; both halves are reported.
    ``--half extra`` runs the extra tuning pool instead (``families.EXTRA``: the
    tune scenes again with seeds + 100 and + 200 and vertical fields of view of
    44, 50 and 56 degrees; 30 scenes), written to ``rgb_only_extra.json`` /
    ``.md``; settings may be chosen on it too, and it never enters the halves' means.
    ``--ycb`` adds YCB-Video 0001 and 0002 (10 views over the 20 frames,
    ``../shared/data/ycbv``) as an extra group outside the halves: depth hidden
    (intrinsics and poses kept, metric scale) and fully RGB-only.

Runs
    Each scene is run twice with one configuration for all scenes (no per-scene
    tuning), each run in a fresh subprocess so that its peak resident memory is
    its own: (a) RGB-only = depth, poses *and* intrinsics removed
    (:func:`graphseg.sim.families.rgb_only_scene`), lifter ``sfm`` chosen
    automatically, with ``--config`` over ``Config.preset("rgbd")`` (the CLI
    default); (b) the same scene with its true depth (lifter ``rgbd``,
    ``--depth-config`` over the same preset). A failed RGB-only run (e.g. SfM
    registers too few views) counts as IoU, F1, precision and PQ 0 and is
    reported with its one-line error.

Measures (per scene)
    registered views / total (the ``sfm`` lifter keeps the views it registers when
    at least 2 do; a dropped view is labelled all background for the evaluation);
    rotation error (degrees, median over views) and camera centre error (median,
    as a fraction of the median camera-to-scene distance) after the best
    similarity between estimated and true camera centres (ill-conditioned for 3-4
    views on a narrow arc, whose centres are nearly collinear), and the relative
    rotation error (median over view pairs; needs no alignment); ``focal``: the
    estimated focal length over the true one (median over the registered views;
    the photos come without intrinsics) and ``sfm_pts``: the points structure
    from motion triangulated (``focal_err`` in the summary: mean of
    ``|focal - 1|``);
    depth error (median and 90th percentile of the relative error of the lifted
    depth, scaled by that similarity); lifted fraction (pixels with a lifted point
    / pixels with true depth) and ``dense`` (the part from stereo alone); IoU, F1,
    precision, PQ and predicted / true objects (:func:`graphseg.metrics.evaluate`
    on the *true* point maps for both runs: every pixel with true depth counts,
    so missing RGB-only points cannot flatter the score); seconds per stage (wall),
    total seconds, CPU seconds of the process (all threads), peak RSS; where the
    loss is (:func:`graphseg.audit.loss_breakdown`, both runs): the shares of the
    object pixels with no point, in the background class, in no mask, in a mask
    but unlabelled (a dropped object, or trimmed at a rim) and labelled, the
    masks' majority grouping and the IoU with
    every final object mapped to its majority object.

Summary
    Per half (tune, check, all = both halves; and extra, for the extra pool) and per group (arcs, rings, 10-view rings, each
    object set, each view count, touching/stacked vs spread): means of every
    measure, the gap (true-depth IoU minus RGB-only IoU), and the acceptance checks
    (check half: RGB-only mean IoU >= 0.85 and gap <= 0.05; 10-view rings of
    120-360 degrees: mean IoU >= 0.75; 8-view 640x480 scenes: RGB-only total
    <= 60 s and peak RSS <= 2 GB each). The tune half's values of the same checks
    are reported beside them.

Writes ``benchmarks/results/rgb_only.json`` and ``rgb_only.md`` for a full run
(``--half all``, no ``--scenes``, no ``--quick``), and ``rgb_only_extra.json`` /
``.md`` for ``--half extra``; a partial run writes ``rgb_only.partial.json`` (or
``rgb_only_extra.partial.json`` for extra-pool scenes) / ``.md`` unless ``--json``
is given, so it never replaces the full result. ``--poses`` keeps the intrinsics
and poses of the photos (depth still hidden: a robot's cameras) and writes
``rgb_only_poses*.json`` / ``rgb_only_extra_poses*.json``. ``--merge`` with extra-pool scenes
merges into ``rgb_only_extra.json``. ``--merge`` instead reruns the selected scenes and
merges their rows into the existing JSON (``--json``), recomputing the summary.
The JSON records the graphseg git commit and both configurations.

Usage: python benchmarks/bench_rgb_only.py [--half tune|check|all|extra] [--scenes NAME,...]
    [--config FILE] [--depth-config FILE] [--json PATH] [--quick] [--ycb] [--merge]
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from _common import git_state, print_table, write_json  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
YCBV = ROOT.parent / "shared" / "data" / "ycbv"
RESULTS = ROOT / "benchmarks" / "results"
# subprocesses import graphseg from this checkout
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])])}
#: The scenes of ``--quick``: the two cheapest pairs (3 views), one scene of each in either half.
QUICK = ("arc20-3v-bundled-s2000", "arc30-3v-bundled-s2001", "arc40-3v-procedural-s2002", "arc25-3v-procedural-s2003")
#: Seconds one subprocess may run before it is stopped (reported as an error).
CHILD_TIMEOUT = 1800
#: Acceptance targets (issue 20).
TARGET_IOU, TARGET_GAP, TARGET_RING_IOU, TARGET_SECONDS_8, TARGET_RSS_MB_8 = 0.85, 0.05, 0.75, 60.0, 2048.0


# ---------------------------------------------------------------------------- one run (child)


def _config(path: str | None):
    from graphseg.config import Config

    base = Config.preset("rgbd")
    return Config.load(path, base=base) if path else base


def _pose_errors(est, ref):
    """Scale, median rotation error (deg) and median centre error after the best similarity of camera centres."""
    from graphseg.backends.lifters.align import umeyama

    s, R, t = umeyama(np.array([T[:3, 3] for T in est]), np.array([T[:3, 3] for T in ref]))
    rot, cen = [], []
    for a, b in zip(est, ref):
        M = (R @ a[:3, :3]).T @ b[:3, :3]
        rot.append(np.degrees(np.arccos(np.clip((np.trace(M) - 1) / 2, -1, 1))))
        cen.append(np.linalg.norm(s * R @ a[:3, 3] + t - b[:3, 3]))
    return s, float(np.median(rot)), float(np.median(cen))


def _relative_rotation_error(est, ref) -> float:
    """Median angle (deg) between estimated and true relative rotations over all view pairs (no alignment needed)."""
    errs = []
    for i in range(len(est)):
        for j in range(i + 1, len(est)):
            Re = est[i][:3, :3].T @ est[j][:3, :3]
            Rg = ref[i][:3, :3].T @ ref[j][:3, :3]
            errs.append(np.degrees(np.arccos(np.clip((np.trace(Re.T @ Rg) - 1) / 2, -1, 1))))
    return float(np.median(errs))


def _quality(labels, inst, gt_pts, names) -> dict[str, Any]:
    from graphseg.metrics import evaluate

    m = evaluate(labels, inst, gt_pts, names=names)
    out = {k: m["mean"].get(k) for k in ("iou", "f1", "precision", "recall", "iou_sel", "pq", "pixel_utility")}
    out["num_pred"], out["num_gt"] = m["num_pred"], m["num_gt"]
    return out


def _breakdown(result, scene, points: dict, eval_points: dict) -> dict[str, Any]:
    """:func:`graphseg.audit.loss_breakdown` of a run over its own views; ``points`` and ``eval_points`` map view names to point maps."""
    from graphseg.audit import loss_breakdown

    inst = {v.name: v.instances for v in scene.views}
    names = result.view_names
    return loss_breakdown(result, [inst[n] for n in names], [points[n] for n in names], eval_points=[eval_points[n] for n in names])


def _load_input(task: dict):
    from graphseg.io import load_scene

    if task.get("scene_file"):
        with open(task["scene_file"], "rb") as f:
            return pickle.load(f)
    return load_scene(YCBV / task["video"], num_views=10)


def one(task: dict) -> dict:
    """Run one scene in one mode in this process: ``rgb`` (photos only), ``nodepth`` (K + poses kept) or ``depth``."""
    from graphseg.pipeline import lift, run
    from graphseg.scene import SceneError
    from graphseg.sim.strip import rgb_only

    scene = _load_input(task)
    mode = task["mode"]
    cfg = _config(task.get("config"))
    truth = lift(scene, "rgbd", _config(None))  # the true point maps: what every run is evaluated on
    gt_pts = [v.points for v in truth.views]
    inst = [v.instances for v in scene.views]
    out: dict[str, Any] = {"mode": mode, "views": len(scene)}
    if mode == "depth":
        c0, t0 = time.process_time(), time.perf_counter()
        try:
            result = run(scene, cfg, lifter="rgbd")
        except (SceneError, ValueError) as err:
            out["error"] = str(err).splitlines()[0]
            out["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
            return out
        out["times"] = dict(result.info["pipeline"]["timings"])
        out["total_s"] = time.perf_counter() - t0
        out["cpu_s"] = time.process_time() - c0
        out.update(_quality(result.labels, inst, gt_pts, scene.objects))
        true_pts = {v.name: p for v, p in zip(scene.views, gt_pts)}
        out["breakdown"] = _breakdown(result, scene, true_pts, true_pts)
        out["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        return out
    inp = rgb_only(scene, keep_intrinsics=mode == "nodepth")
    if mode == "nodepth":  # depth hidden, intrinsics and poses kept
        inp = type(scene)([v.replace(cam_to_world=w.cam_to_world) for v, w in zip(inp.views, scene.views)], dict(scene.objects), scene.name, dict(inp.meta))
    c0, t0 = time.process_time(), time.perf_counter()
    try:
        lifted = lift(inp, None, cfg)
    except SceneError as err:
        msg = str(err).splitlines()[0]
        m = re.search(r"registered (\d+) of (\d+) views", msg)
        out.update(error=msg, registered=int(m.group(1)) if m else 0, total_s=time.perf_counter() - t0, cpu_s=time.process_time() - c0)
        out["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        return out
    t_lift = time.perf_counter() - t0
    result = run(lifted, cfg)
    times = dict(result.info["pipeline"]["timings"])
    times["lift"] = t_lift
    times["total"] = time.perf_counter() - t0
    out["times"] = times
    out["total_s"] = times["total"]
    out["cpu_s"] = time.process_time() - c0
    out["lifter"] = lifted.meta.get("lifter")
    # The lifter may keep only the views it registered (``meta["dropped_views"]``): map the
    # lifted views back to the scene's by name; a dropped view is labelled all background.
    at = {v.name: i for i, v in enumerate(lifted.views)}
    labels = [result.labels[at[v.name]] if v.name in at else np.zeros(v.shape, np.int32) for v in scene.views]
    out.update(_quality(labels, inst, gt_pts, scene.objects))
    out["breakdown"] = _breakdown(result, scene, {v.name: v.points for v in lifted.views}, {v.name: p for v, p in zip(scene.views, gt_pts)})
    out["dropped_views"] = [v.name for v in scene.views if v.name not in at]
    out["warnings"] = list(lifted.meta.get("warnings", []))
    sfm = lifted.meta.get("sfm", {})
    reg = [i for i, v in enumerate(scene.views) if v.name in at and lifted.views[at[v.name]].cam_to_world is not None and lifted.views[at[v.name]].points is not None]
    out["registered"] = int(sfm.get("registered", len(reg)))
    out["scale"] = lifted.meta.get("scale")
    if len(reg) >= 3:
        s, rot, cen = _pose_errors([lifted.views[at[scene.views[i].name]].cam_to_world for i in reg], [scene.views[i].cam_to_world for i in reg])
        dist = np.median([np.linalg.norm(np.nanmedian(gt_pts[i].reshape(-1, 3), 0) - scene.views[i].cam_to_world[:3, 3]) for i in reg])
        out["rot_err_deg"], out["centre_err_rel"] = rot, cen / float(dist)
    else:
        s = None
    # the estimated focal length against the true one (the photos come without intrinsics), and
    # how many points structure from motion triangulated: a weakly textured scene with few points
    # is where the shared focal length goes wrong (docs/results.md, round 18)
    pairs = [(lifted.views[at[scene.views[i].name]].K, scene.views[i].K) for i in reg]
    fx = [est[0, 0] / true[0, 0] for est, true in pairs if est is not None and true is not None]
    out["focal_ratio"] = float(np.median(fx)) if fx else None
    out["sfm_points"] = sfm.get("points")
    if len(reg) >= 2:
        out["rel_rot_err_deg"] = _relative_rotation_error([lifted.views[at[scene.views[i].name]].cam_to_world for i in reg], [scene.views[i].cam_to_world for i in reg])
    errs, lifted_frac, dense = [], [], []
    for i, g in enumerate(scene.views):
        ok_gt = g.depth > 0
        if i not in reg:
            lifted_frac.append(0.0)  # a view without points lifts nothing
            continue
        v = lifted.views[at[g.name]]
        cam = v.camera_points()
        ok = ok_gt & np.isfinite(cam).all(-1)
        lifted_frac.append(float(ok.sum() / max(ok_gt.sum(), 1)))
        dense.append(float(v.meta.get("dense_fraction", 0.0)))
        if s is not None:
            z = cam[..., 2] * s
            errs.append(np.abs(z[ok] - g.depth[ok]) / g.depth[ok])
    e = np.concatenate(errs) if errs else np.zeros(0)
    out["depth_err_med"] = float(np.median(e)) if e.size else None
    out["depth_err_p90"] = float(np.percentile(e, 90)) if e.size else None
    out["lifted_fraction"] = float(np.mean(lifted_frac))
    out["dense"] = float(np.mean(dense)) if dense else None
    out["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return out


# ---------------------------------------------------------------------------- driver (parent)


def _child(task: dict) -> dict:
    t = time.perf_counter()
    try:
        proc = subprocess.run([sys.executable, __file__, "--one", json.dumps(task)], capture_output=True, text=True, env=ENV, timeout=CHILD_TIMEOUT)
    except subprocess.TimeoutExpired:
        return {"mode": task["mode"], "error": f"timed out after {CHILD_TIMEOUT} s", "wall_child_s": time.perf_counter() - t}
    line = [x for x in proc.stdout.splitlines() if x.startswith("RESULT ")]
    if not line:
        print(proc.stdout[-2000:], proc.stderr[-4000:], file=sys.stderr)
        return {"mode": task["mode"], "error": "crashed: " + (proc.stderr.strip().splitlines() or [f"exit {proc.returncode}"])[-1], "wall_child_s": time.perf_counter() - t}
    out = json.loads(line[-1][7:])
    out["wall_child_s"] = time.perf_counter() - t
    return out


def run_scene(spec, tmp: Path, config: str | None, depth_config: str | None, mode: str = "rgb") -> dict:
    """Render ``spec`` once, then run its RGB-only (``mode`` ``"rgb"``, or ``"nodepth"``: intrinsics and poses kept) and true-depth subprocesses; one row."""
    from graphseg.sim.families import make_scene

    t = time.perf_counter()
    scene = make_scene(spec)
    render_s = time.perf_counter() - t
    path = tmp / f"{spec.name}.pkl"
    with open(path, "wb") as f:
        pickle.dump(scene, f, protocol=pickle.HIGHEST_PROTOCOL)
    row: dict[str, Any] = {**spec.to_dict(), "scene": spec.name, "group": "synthetic", "render_s": render_s, "objects_in_scene": len(scene.objects), "fell_off": scene.meta.get("fell_off", [])}
    del scene
    row["rgb"] = _child({"scene_file": str(path), "mode": mode, "config": config})
    row["depth"] = _child({"scene_file": str(path), "mode": "depth", "config": depth_config})
    path.unlink()
    return row


def run_ycb(config: str | None, depth_config: str | None) -> list[dict]:
    rows = []
    for vid in ("0001", "0002"):
        if not (YCBV / vid).is_dir():
            continue
        depth = _child({"video": vid, "mode": "depth", "config": depth_config})
        for mode in ("nodepth", "rgb"):
            label = f"ycbv-{vid}" + (" (depth hidden, K + poses)" if mode == "nodepth" else "")
            rows.append({"scene": label, "group": "ycbv", "video": vid, "views": 10, "rgb": _child({"video": vid, "mode": mode, "config": config}), "depth": depth})
            _progress(rows[-1])
    return rows


def _progress(r: dict) -> None:
    a, b = r["rgb"], r["depth"]
    print(
        f"{r['scene']:32s} reg {a.get('registered', 0)}/{r.get('views')} iou rgb {a.get('iou') or 0:.3f} depth {b.get('iou') or float('nan'):.3f} "
        f"rgb {a.get('total_s') or float('nan'):.1f}s depth {b.get('total_s') or float('nan'):.1f}s rss {a.get('peak_rss_mb') or float('nan'):.0f}MB {a.get('error', '')}{b.get('error', '')}",
        flush=True,
    )


# ---------------------------------------------------------------------------- summary


def _f(r: dict, run: str, key: str, fail_zero: bool = False):
    v = r[run].get(key)
    if v is None and fail_zero and "error" in r[run]:
        return 0.0
    return v if isinstance(v, (int, float)) and v == v else None


def _mean(vals):
    vals = [v for v in vals if v is not None]
    return float(np.mean(vals)) if vals else None


def scene_row(r: dict) -> dict:
    """The flat table row of one scene."""
    a, b = r["rgb"], r["depth"]
    iou_a = _f(r, "rgb", "iou", True)
    iou_b = _f(r, "depth", "iou")
    return {
        "scene": r["scene"],
        "half": r.get("half", "-"),
        "set": r.get("object_set", "-"),
        "reg": f"{a.get('registered', 0)}/{r.get('views')}",
        "rot_deg": a.get("rot_err_deg"),
        "rel_rot_deg": a.get("rel_rot_err_deg"),
        "focal": a.get("focal_ratio"),
        "sfm_pts": a.get("sfm_points"),
        "depth_err": a.get("depth_err_med"),
        "lifted": a.get("lifted_fraction"),
        "iou": iou_a,
        "f1": _f(r, "rgb", "f1", True),
        "prec": _f(r, "rgb", "precision", True),
        "pq": _f(r, "rgb", "pq", True),
        "pred/gt": f"{a.get('num_pred', '-')}/{a.get('num_gt', b.get('num_gt', '-'))}",
        "iou_d": iou_b,
        "f1_d": _f(r, "depth", "f1"),
        "prec_d": _f(r, "depth", "precision"),
        "pq_d": _f(r, "depth", "pq"),
        "pred/gt_d": f"{b.get('num_pred', '-')}/{b.get('num_gt', '-')}",
        "gap": None if iou_a is None or iou_b is None else iou_b - iou_a,
        "lift_s": (a.get("times") or {}).get("lift"),
        "segment_s": (a.get("times") or {}).get("segment"),
        "graph_s": (a.get("times") or {}).get("graph"),
        "total_s": a.get("total_s"),
        "depth_total_s": b.get("total_s"),
        "rss_mb": a.get("peak_rss_mb"),
        "error": _short((a.get("error") or (f"kept {r['views'] - len(a['dropped_views'])} views; dropped (labelled background): {', '.join(a['dropped_views'])}" if a.get("dropped_views") else "")) + (" | depth: " + b["error"] if b.get("error") else "")),
    }


def loss_row(r: dict) -> dict:
    """Where one scene's RGB-only run loses (:func:`graphseg.audit.loss_breakdown`), beside its true-depth run."""
    a, b = r["rgb"].get("breakdown") or {}, r["depth"].get("breakdown") or {}
    px = a.get("pixels") or {}
    return {
        "scene": r["scene"],
        "half": r.get("half", "-"),
        "no_point": px.get("no_point"),
        "background": px.get("background"),
        "no_mask": px.get("no_mask"),
        "unlabelled": px.get("dropped"),
        "labelled": px.get("labelled"),
        "masks_maj": a.get("masks_majority"),
        "obj_maj": a.get("objects_majority"),
        "iou": a.get("iou"),
        "masks_maj_d": b.get("masks_majority"),
        "obj_maj_d": b.get("objects_majority"),
        "iou_d": b.get("iou"),
    }


def loss_summary(rows: list[dict]) -> list[dict]:
    """Means of :func:`loss_row` per half (scenes whose RGB-only run failed are left out)."""
    out = []
    for half in HALF_KEYS:
        ls = [loss_row(r) for r in _in_half(rows, half) if r["rgb"].get("breakdown")]
        if ls:
            out.append({"scene": f"mean ({len(ls)})", "half": half, **{k: _mean([x[k] for x in ls]) for k in LOSS_COLS[2:]}})
    return out


def _short(msg: str, n: int = 110) -> str:
    """The error as the table shows it (the JSON keeps it whole)."""
    msg = msg.split(": views: ", 1)[-1]  # drop the scene name the SceneError repeats
    return msg if len(msg) <= n else msg[: n - 3] + "..."


#: The row sets summarised: the two halves, ``all`` (both halves) and the ``extra`` tuning pool (never part of ``all``).
HALF_KEYS = ("tune", "check", "all", "extra")


def _in_half(rows: list[dict], half: str) -> list[dict]:
    """The synthetic rows of one of :data:`HALF_KEYS`."""
    synth = [r for r in rows if r.get("group") == "synthetic"]
    return [r for r in synth if r["half"] in ("tune", "check")] if half == "all" else [r for r in synth if r["half"] == half]


GROUPS: tuple[tuple[str, Any], ...] = (
    ("all", lambda r: True),
    ("arcs", lambda r: r["kind"] == "arc"),
    ("rings", lambda r: r["kind"] == "ring"),
    ("rings 10 views", lambda r: r["kind"] == "ring" and r["views"] == 10),
    ("bundled", lambda r: r["object_set"] == "bundled"),
    ("procedural", lambda r: r["object_set"] == "procedural"),
    ("mixed", lambda r: r["object_set"] == "mixed"),
    ("3 views", lambda r: r["views"] == 3),
    ("5 views", lambda r: r["views"] == 5),
    ("8 views", lambda r: r["views"] == 8),
    ("10 views", lambda r: r["views"] == 10),
    ("touching/stacked", lambda r: r["layout"] in ("touching", "stacked")),
    ("spread", lambda r: r["layout"] == "spread"),
    ("varied light", lambda r: r.get("lighting") is not None),
)


def summary_row(label: str, half: str, rs: list[dict]) -> dict:
    ok = [r for r in rs if "error" not in r["rgb"]]
    iou_a = _mean([_f(r, "rgb", "iou", True) for r in rs])
    iou_b = _mean([_f(r, "depth", "iou") for r in rs])
    return {
        "half": half,
        "group": label,
        "n": len(rs),
        "ok": len(ok),
        "registered": _mean([r["rgb"].get("registered", 0) / r["views"] for r in rs]),
        "rot_deg": _mean([_f(r, "rgb", "rot_err_deg") for r in ok]),
        "rel_rot_deg": _mean([_f(r, "rgb", "rel_rot_err_deg") for r in ok]),
        "focal_err": _mean([None if r["rgb"].get("focal_ratio") is None else abs(r["rgb"]["focal_ratio"] - 1.0) for r in ok]),
        "depth_err": _mean([_f(r, "rgb", "depth_err_med") for r in ok]),
        "lifted": _mean([_f(r, "rgb", "lifted_fraction") or 0.0 for r in rs]),
        "iou": iou_a,
        "f1": _mean([_f(r, "rgb", "f1", True) for r in rs]),
        "prec": _mean([_f(r, "rgb", "precision", True) for r in rs]),
        "pq": _mean([_f(r, "rgb", "pq", True) for r in rs]),
        "pred/gt": _mean([(r["rgb"].get("num_pred") or 0) / max(r["depth"].get("num_gt") or r["rgb"].get("num_gt") or 1, 1) for r in rs]),
        "iou_d": iou_b,
        "f1_d": _mean([_f(r, "depth", "f1") for r in rs]),
        "prec_d": _mean([_f(r, "depth", "precision") for r in rs]),
        "pq_d": _mean([_f(r, "depth", "pq") for r in rs]),
        "gap": None if iou_a is None or iou_b is None else iou_b - iou_a,
        "total_s": _mean([_f(r, "rgb", "total_s") for r in ok]),
        "max_total_s": max([r["rgb"]["total_s"] for r in rs if r["rgb"].get("total_s") is not None], default=None),
        "depth_total_s": _mean([_f(r, "depth", "total_s") for r in rs]),
        "max_rss_mb": max([r["rgb"]["peak_rss_mb"] for r in rs if r["rgb"].get("peak_rss_mb") is not None], default=None),
    }


def summarise(rows: list[dict]) -> list[dict]:
    out = []
    for half in HALF_KEYS:
        hs = _in_half(rows, half)
        for label, pred in GROUPS:
            rs = [r for r in hs if pred(r)]
            if rs:
                out.append(summary_row(label, half, rs))
    return out


def checks(rows: list[dict]) -> list[dict]:
    """The acceptance checks, for the check half (the acceptance) and the tune half and extra pool (beside it)."""
    out = []
    for half in ("check", "tune", "all", "extra"):
        hs = _in_half(rows, half)
        if not hs:
            continue
        s = summary_row("all", half, hs)
        out.append({"half": half, "check": f"RGB-only mean IoU >= {TARGET_IOU}", "value": s["iou"], "n": len(hs), "pass": s["iou"] is not None and s["iou"] >= TARGET_IOU})
        out.append({"half": half, "check": f"gap (true-depth IoU - RGB-only IoU) <= {TARGET_GAP}", "value": s["gap"], "n": len(hs), "pass": s["gap"] is not None and s["gap"] <= TARGET_GAP})
        rings = [r for r in hs if r["kind"] == "ring" and r["views"] == 10 and 120 <= r["arc_deg"] <= 360]
        if rings:
            v = summary_row("rings", half, rings)["iou"]
            out.append({"half": half, "check": f"10-view rings over 120-360 deg: mean IoU >= {TARGET_RING_IOU}", "value": v, "n": len(rings), "pass": v is not None and v >= TARGET_RING_IOU})
        eight = [r for r in hs if r["views"] == 8 and tuple(r.get("size", ())) == (640, 480)]
        if eight:
            secs = [r["rgb"].get("total_s") for r in eight]
            rss = [r["rgb"].get("peak_rss_mb") for r in eight]
            ok_s = all(x is not None and x <= TARGET_SECONDS_8 for x in secs) and all("error" not in r["rgb"] for r in eight)
            out.append({"half": half, "check": f"8 views 640x480: RGB-only total <= {TARGET_SECONDS_8:.0f} s (every scene; max shown)", "value": max([x for x in secs if x is not None], default=None), "n": len(eight), "pass": ok_s})
            out.append({"half": half, "check": f"8 views 640x480: peak RSS <= {TARGET_RSS_MB_8:.0f} MB (every scene; max shown)", "value": max([x for x in rss if x is not None], default=None), "n": len(eight), "pass": all(x is not None and x <= TARGET_RSS_MB_8 for x in rss)})
    return out


def tails(rows: list[dict]) -> list[dict]:
    """Per half: the worst scene and how many scenes fall below 0.4, 0.5 and 0.6 (photos only; a failed run counts as 0).

    A mean hides a catastrophic scene; this table shows it (issue 54).
    """
    out = []
    for half in ("tune", "check", "extra"):
        hs = _in_half(rows, half)
        if not hs:
            continue
        ious = sorted(((_f(r, "rgb", "iou", True) or 0.0), r["name"]) for r in hs)
        out.append(
            {
                "half": half,
                "n": len(hs),
                "mean": _mean([x for x, _ in ious]),
                "worst": ious[0][1],
                "worst_iou": ious[0][0],
                "below_0.4": sum(x < 0.4 for x, _ in ious),
                "below_0.5": sum(x < 0.5 for x, _ in ious),
                "below_0.6": sum(x < 0.6 for x, _ in ious),
            }
        )
    return out


SCENE_COLS = ["scene", "half", "set", "reg", "rot_deg", "rel_rot_deg", "focal", "sfm_pts", "depth_err", "lifted", "iou", "f1", "prec", "pq", "pred/gt", "iou_d", "f1_d", "prec_d", "pq_d", "pred/gt_d", "gap", "lift_s", "segment_s", "graph_s", "total_s", "depth_total_s", "rss_mb", "error"]
SUMMARY_COLS = ["half", "group", "n", "ok", "registered", "rot_deg", "rel_rot_deg", "focal_err", "depth_err", "lifted", "iou", "f1", "prec", "pq", "pred/gt", "iou_d", "f1_d", "prec_d", "pq_d", "gap", "total_s", "max_total_s", "depth_total_s", "max_rss_mb"]
CHECK_COLS = ["half", "check", "n", "value", "pass"]
TAIL_COLS = ["half", "n", "mean", "worst", "worst_iou", "below_0.4", "below_0.5", "below_0.6"]
LOSS_COLS = ["scene", "half", "no_point", "background", "no_mask", "unlabelled", "labelled", "masks_maj", "obj_maj", "iou", "masks_maj_d", "obj_maj_d", "iou_d"]
LOSS_NOTE = (
    "Shares of the ground-truth object pixels of the RGB-only run's views: no lifted point, taken by the background class, "
    "in no mask, in a mask but unlabelled (its object dropped, or the pixel trimmed at an object's rim), labelled. `masks_maj`: every mask to its majority object (the masks' "
    "ceiling); `obj_maj`: every final object to its majority object (pieces joined, merges kept); so `masks_maj - obj_maj` "
    "is roughly the cost of wrong grouping and `obj_maj - iou` the cost of pieces. `*_d`: the true-depth run. IoUs on the "
    "true point maps over the run's own views (`graphseg.audit.loss_breakdown`)."
)


def report(payload: dict, path: Path) -> None:
    rows = payload["rows"]
    synth = [r for r in rows if r.get("group") == "synthetic"]
    print("\nPer scene (RGB-only: photos only, no depth, poses or intrinsics; *_d: the same scene with true depth):")
    t1 = print_table([scene_row(r) for r in synth], SCENE_COLS)
    print("\nSummary (means; a failed RGB-only run counts as IoU/F1/precision/PQ 0; rot/depth errors over the runs that succeeded):")
    t2 = print_table(payload["summary"], SUMMARY_COLS)
    print("\nAcceptance checks (issue 20; the check half is the acceptance, tune and all beside it):")
    t3 = print_table(payload["checks"], CHECK_COLS)
    print("\nThe tail (worst scene and scenes below 0.4 / 0.5 / 0.6, photos only, per half):")
    t6 = print_table(payload.get("tails") or tails(rows), TAIL_COLS)
    print("\nWhere the loss is (" + LOSS_NOTE + "):")
    t5 = print_table([loss_row(r) for r in synth if r["rgb"].get("breakdown")] + loss_summary(rows), LOSS_COLS)
    ycb = [r for r in rows if r.get("group") == "ycbv"]
    t4 = ""
    if ycb:
        print("\nYCB-Video (extra group, not part of the halves):")
        t4 = print_table([scene_row(r) for r in ycb], SCENE_COLS)
    write_json(str(path), payload)
    git = payload.get("git", {})
    md = path.with_suffix(".md")
    md.write_text(
        "# RGB-only (structure from motion) against true depth\n\n"
        f"`python benchmarks/bench_rgb_only.py {' '.join(payload.get('argv', []))}`; graphseg commit `{git.get('commit')}` "
        f"({git.get('uncommitted_files', 0)} uncommitted files); RGB-only config: {payload.get('config_source')}; true-depth config: {payload.get('depth_config_source')}; "
        f"{payload.get('elapsed_s', 0) / 60:.1f} min on {payload.get('machine_note', '')}.\n\n"
        + ("RGB-only = depth hidden, the intrinsics and poses kept (`--poses`: the cameras are given); " if payload.get("rgb_mode") == "nodepth" else "RGB-only = depth, poses and intrinsics removed; ")
        + "`*_d` = the same scene with its true depth. "
        "IoU, F1, precision and PQ are computed on the true point maps for both runs; a failed RGB-only run counts as 0.\n\n"
        "## Acceptance checks\n\n" + t3 + "\n\n## The tail\n\nPhotos only, per half; a failed run counts as 0.\n\n" + t6 + "\n\n## Summary per half and group\n\n" + t2 + "\n\n## Per scene\n\n" + t1 + "\n\n## Where the loss is\n\n" + LOSS_NOTE + "\n\n" + t5 + ("\n\n## YCB-Video (extra)\n\n" + t4 if t4 else "") + "\n"
    )
    print(f"wrote {md}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--half", choices=["tune", "check", "all", "extra"], default="all", help="'extra': the extra tuning pool (graphseg.sim.families.EXTRA), reported on its own")
    ap.add_argument("--scenes", help="comma-separated scene names (graphseg.sim.families)")
    ap.add_argument("--config", help="YAML config over Config.preset('rgbd') for the RGB-only runs")
    ap.add_argument("--depth-config", help="YAML config over Config.preset('rgbd') for the true-depth runs (default: the preset)")
    ap.add_argument("--json", help="output JSON (default benchmarks/results/rgb_only.json, rgb_only_extra.json for --half extra; *.partial.json for a partial run)")
    ap.add_argument("--quick", action="store_true", help=f"only {', '.join(QUICK)}")
    ap.add_argument("--ycb", action="store_true", help="add the YCB-Video rows (extra group)")
    ap.add_argument("--merge", action="store_true", help="merge the rows of the selected scenes into the existing JSON")
    ap.add_argument("--poses", action="store_true", help="keep the intrinsics and poses (depth hidden, a robot's cameras): the 'rgb' runs become 'nodepth' runs; written to rgb_only_poses*.json")
    ap.add_argument("--list", action="store_true", help="list the scenes and exit")
    ap.add_argument("--one", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.one:
        print("RESULT " + json.dumps(one(json.loads(args.one)), default=float), flush=True)
        return 0
    from graphseg.sim import families

    if args.list:
        print(families.describe(args.half))
        return 0
    todo = families.scenes(args.half)
    if args.scenes:
        names = [n.strip() for n in args.scenes.split(",") if n.strip()]
        todo = [families.get(n) for n in names]
    if args.quick:
        todo = [families.get(n) for n in QUICK if families.get(n) in todo]
    if not todo and not args.ycb:
        ap.error("no scene selected (--quick holds scenes of the halves only, not of --half extra)")
    extra = bool(todo) and all(s.extra for s in todo)
    if todo and not extra and any(s.extra for s in todo):
        ap.error("--scenes: give scenes of the halves or of the extra pool, not both (they are written to different files)")
    partial = args.quick or bool(args.scenes) or args.half != "all"
    full = ("rgb_only_extra" if extra else "rgb_only") + ("_poses" if args.poses else "") + ".json"
    path = Path(args.json) if args.json else RESULTS / (full.replace(".json", ".partial.json") if partial and not args.merge and not (extra and args.half == "extra" and not args.scenes) else full)
    config = str(Path(args.config).resolve()) if args.config else None
    depth_config = str(Path(args.depth_config).resolve()) if args.depth_config else None
    old_rows: list[dict] = []
    if args.merge:
        old = json.loads(path.read_text())
        names = {s.name for s in todo}
        old_rows = [r for r in old["rows"] if r["scene"] not in names and not (args.ycb and r.get("group") == "ycbv")]
    t0 = time.perf_counter()
    load0 = os.getloadavg()
    rows: list[dict] = []
    with tempfile.TemporaryDirectory(prefix="bench-rgb-only-") as tmp:
        for spec in todo:
            rows.append(run_scene(spec, Path(tmp), config, depth_config, "nodepth" if args.poses else "rgb"))
            _progress(rows[-1])
    if args.ycb:
        rows += run_ycb(config, depth_config)
    order = {s.name: i for i, s in enumerate(families.SCENES + families.HARD + families.EXTRA)}
    rows = sorted(old_rows + rows, key=lambda r: (r.get("group") != "synthetic", order.get(r["scene"], 10**6), r["scene"]))
    payload = {
        "argv": list(sys.argv[1:] if argv is None else argv),
        "rgb_mode": "nodepth" if args.poses else "rgb",
        "git": git_state(ROOT),
        "config_source": args.config or "Config.preset('rgbd')",
        "depth_config_source": args.depth_config or "Config.preset('rgbd')",
        "config": _config(config).to_dict(),
        "depth_config": _config(depth_config).to_dict(),
        "machine_note": f"{os.cpu_count()} CPU cores, shared (1/5/15-min load average at the start: {', '.join(f'{x:.1f}' for x in load0)}; at the end: {', '.join(f'{x:.1f}' for x in os.getloadavg())})",
        "elapsed_s": time.perf_counter() - t0,
        "families": [s.to_dict() for s in (families.EXTRA if extra else families.SCENES + families.HARD)],
        "targets": {"iou": TARGET_IOU, "gap": TARGET_GAP, "ring_iou": TARGET_RING_IOU, "seconds_8_views": TARGET_SECONDS_8, "rss_mb_8_views": TARGET_RSS_MB_8},
        "rows": rows,
        "summary": summarise(rows),
        "checks": checks(rows),
        "tails": tails(rows),
    }
    report(payload, path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
