"""Next-best-view (:mod:`graphseg.nbv`) against random and evenly spaced views.

Scenes
    The pybullet scenes of the family pairs 0, 2, ..., 10 of
    :mod:`graphseg.sim.families` (every other arc pair: 12 scenes; 3 spread,
    2 touching and 1 stacked pair; bundled, procedural and mixed objects; 3-9
    objects), each with its family's objects, table and light, rendered at
    320x240 with cameras of our own (below). The split is the family's (seed
    parity): weights are chosen on the **tune** half only (``--tune``); both
    halves are reported.

Views
    Two initial views at the family's camera distance (0.5 m from the table
    centre, the family's height above the top), 30 degrees apart, from an
    azimuth drawn from the seed. From them, the candidate set:
    :func:`graphseg.nbv.sample_candidates` (24 poses, one every 15 degrees, on
    the ring at the observed working distance and mean elevation, looking at
    the objects' centre, the first aligned with the first view). Every strategy
    picks from these 24; every pose is rendered by pybullet's TinyRenderer in
    the same settled scene (the family's ``synthesize`` with its cameras moved to
    the poses asked for) when a strategy first asks for it and cached (the
    renderer is deterministic: a pose rendered again gives the same image).

    * **suggested**: from the 2 initial views, run, rank the unused candidates
      with :func:`graphseg.nbv.suggest_views` (its default weights; ties, such
      as all scores 0, go to the candidate farthest in angle from the cameras
      so far), add the best, repeat up to 10 views;
    * **random**: from the 2 initial views, add unused candidates in a random
      order (3 orders per scene, averaged);
    * **even**: for each n, the n candidates evenly spaced on the ring
      (indices ``round(24 k / n)``): not nested, not starting from the initial pair.

Runs
    RGB-D lifting with the true depth, ``Config.preset("rgbd")`` (geometric
    segmenter, reprojection matcher); each view's masks and each pair's matches
    are computed once and reused (both are per view or per pair), so a run equals
    ``graphseg.pipeline.run`` on the same views (checked on the first scene).

Measures (n = 2..10 views)
    ``view IoU``: the mean over ground-truth objects of their best IoU over the
    views used (:func:`graphseg.metrics.mean_iou`, pixels with a true point), the
    measure of every other benchmark. ``scene IoU``: the same over all 24
    candidate views (every other pixel), with labels carried over from the
    objects found: every labelled pixel of the views used votes for its object
    in a 1 cm voxel of the true points (neighbouring voxels vote at 1/10), and a
    pixel takes its voxel's winner (0 where none): what the robot knows of the
    whole scene. Target: suggested views reach the IoU of 10 evenly spaced
    views with at most 6 views, on the mean over the scenes.

Writes ``benchmarks/results/nbv.json`` and ``nbv.md`` and ``docs/nbv_views.png``
(a full run); ``--tune`` writes ``benchmarks/results/nbv.tune.json`` (the
weight grid on the tune half: every term on or off, and three mixes; objective
the mean view IoU over 3..6 views, ties broken by the scene IoU, then by the
order of the grid), which a full run copies into its table.

Usage: python benchmarks/bench_nbv.py [--tune] [--scenes NAME,...] [--quick] [--report JSON]
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import sys
import time
from pathlib import Path
from typing import Any
from unittest import mock

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, os.path.dirname(__file__))

from _common import git_state  # noqa: E402

from graphseg import Config  # noqa: E402
from graphseg.backends.registry import matchers, segmenters  # noqa: E402
from graphseg.geometry import scene_scale, select_pairs  # noqa: E402
from graphseg.method.segment import segment  # noqa: E402
from graphseg.metrics import mean_iou  # noqa: E402
from graphseg.nbv import DEFAULT_WEIGHTS, TERMS, sample_candidates, suggest_views  # noqa: E402
from graphseg.pipeline import lift  # noqa: E402
from graphseg.scene import Scene, View  # noqa: E402

RESULTS = ROOT / "benchmarks" / "results"
PLOT = ROOT / "docs" / "nbv_views.png"
SIZE = (320, 240)
NUM_CANDIDATES = 24
N_MAX = 10
RANDOM_ORDERS = 3
INITIAL_GAP_DEG = 30.0
FOV = 50.0
VOXEL = 0.01
EVAL_STRIDE = 2
STRATEGIES = ("suggested", "random", "even")
QUICK = 2  # --quick: the first pair only
#: The family pairs used (every other arc pair; the ring pairs 11-14 differ only in their cameras, which are replaced here).
PAIRS = (0, 2, 4, 6, 8, 10)


# ----------------------------------------------------------------------------- rendering
class Renderer:
    """Renders one family scene at any camera pose; every pose once (cached by key)."""

    def __init__(self, spec: Any) -> None:
        self.spec = spec
        self.cache: dict[str, View] = {}
        self.calls = 0

    def render(self, poses: dict[str, tuple[np.ndarray, np.ndarray]]) -> dict[str, View]:
        """Views for ``{key: (eye, target)}``; poses not yet rendered are rendered in one call."""
        todo = [k for k in poses if k not in self.cache]
        if todo:
            for k, v in zip(todo, _render_poses(self.spec, [poses[k] for k in todo])):
                self.cache[k] = v.replace(name=k)
            self.calls += 1
        return {k: self.cache[k] for k in poses}


def _render_poses(spec: Any, poses: list[tuple[np.ndarray, np.ndarray]]) -> list[View]:
    """The family scene ``spec`` (same seed, objects, layout, table, light: the same settled objects) seen from ``poses``.

    The family's ``make_scene`` is run with ``pybullet_scenes.render_view`` asked
    for the given (eye, target) poses instead of its own ring (the camera draws
    happen after the objects settle, so the objects do not move).
    """
    from graphseg.sim import families
    from graphseg.sim import pybullet_scenes as ps

    queue = list(poses)
    real = ps.render_view

    def at_pose(p: Any, cid: int, eye: Any, target: Any, size: Any, fov: float, near: float = 0.05, far: float = 6.0, light: Any = None) -> Any:
        e, t = queue.pop(0)
        return real(p, cid, np.asarray(e, np.float64), np.asarray(t, np.float64), size, fov, near, far, light)

    with mock.patch.object(ps, "render_view", at_pose):
        s = families.make_scene(spec, views=len(poses), size=SIZE, fov_deg=FOV)
    assert not queue
    return list(s.views)


def initial_poses(spec: Any) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Two views 30 degrees apart at the family's distance and height, from an azimuth drawn from the seed."""
    from graphseg.sim.pybullet_scenes import TABLE_TOP

    rng = np.random.default_rng([spec.seed, 7])
    a0 = rng.uniform(0, 2 * np.pi)
    centre = np.array([0.0, 0.0, TABLE_TOP])
    out = {}
    for i, a in enumerate((a0, a0 + np.radians(INITIAL_GAP_DEG))):
        out[f"i{i}"] = (centre + np.array([0.5 * np.cos(a), 0.5 * np.sin(a), spec.height]), centre)
    return out


# ----------------------------------------------------------------------------- running
class Runner:
    """Runs the rgbd preset on any subset of views, reusing each view's masks and lift and each pair's matches."""

    def __init__(self, cfg: Config) -> None:
        self.cfg = cfg
        self.seg = segmenters.resolve(cfg.backends.segmenter, seed=cfg.seed)
        self.match = matchers.resolve(cfg.backends.matcher, num_matches=cfg.backends.num_matches, seed=cfg.seed)
        self.lifted: dict[str, View] = {}
        self.masks: dict[str, Any] = {}
        self.matches: dict[tuple[str, str], Any] = {}
        self.runs = 0
        self.seconds = 0.0

    def view(self, v: View) -> View:
        if v.name not in self.lifted:
            self.lifted[v.name] = lift(Scene([v]), None, self.cfg).views[0]
            self.masks[v.name] = self.seg(self.lifted[v.name])
        return self.lifted[v.name]

    def __call__(self, views: list[View], name: str) -> tuple[Scene, Any]:
        t = time.perf_counter()
        lv = [self.view(v) for v in views]
        scene = Scene(lv, {}, name, {"lifter": "rgbd"})
        poses = [v.cam_to_world for v in lv]
        pc = self.cfg.pairs
        pairs = select_pairs(
            poses, mode=pc.mode, max_rotation=pc.max_rotation, max_translation=pc.max_translation,
            translation_scale=pc.translation_scale, scale=scene_scale([v.points for v in lv], poses), auto_max_views=pc.auto_max_views,
        )
        matches = {}
        for i, j in pairs:
            key = (lv[i].name, lv[j].name)
            if key not in self.matches:
                self.matches[key] = self.match(lv[i], lv[j])
            matches[(i, j)] = self.matches[key]
        result = segment(scene, [self.masks[v.name] for v in lv], matches, self.cfg)
        self.runs += 1
        self.seconds += time.perf_counter() - t
        return scene, result


def view_iou(scene: Scene, result: Any) -> float:
    return float(mean_iou(result.labels, [v.instances for v in scene.views], [v.points for v in scene.views]) or 0.0)


def _keys(vox: np.ndarray) -> np.ndarray:
    v = vox.astype(np.int64) + 2**20
    return (v[:, 0] << 42) | (v[:, 1] << 21) | v[:, 2]


def scene_iou(scene: Scene, result: Any, evals: list[View]) -> float:
    """Mean IoU over the ``evals`` views with labels carried over from the objects found (see the module docstring)."""
    pts, labs = [], []
    for v, lab in zip(scene.views, result.labels):
        p = np.asarray(v.points)[::EVAL_STRIDE, ::EVAL_STRIDE].reshape(-1, 3)
        lab = np.asarray(lab)[::EVAL_STRIDE, ::EVAL_STRIDE].reshape(-1)
        ok = np.isfinite(p).all(1) & (lab > 0)
        pts.append(p[ok])
        labs.append(lab[ok])
    P, L = np.concatenate(pts), np.concatenate(labs).astype(np.int64)
    table_keys = np.zeros(0, np.int64)
    table_lab = np.zeros(0, np.int64)
    if len(P):
        vox = np.floor(P / VOXEL).astype(np.int64)
        uk, inv = np.unique(np.c_[vox, L], axis=0, return_inverse=True)
        count = np.bincount(inv.reshape(-1)).astype(np.float64)
        offs = np.array(list(itertools.product((-1, 0, 1), repeat=3)))
        allv = np.concatenate([uk[:, :3] + o for o in offs])
        alll = np.tile(uk[:, 3], len(offs))
        allw = np.concatenate([count * (1.0 if not o.any() else 0.1) for o in offs])
        keys = _keys(allv)
        order = np.lexsort((-allw, alll, keys))
        keys, alll, allw = keys[order], alll[order], allw[order]
        # sum the votes per (voxel, label), then keep the label with the most per voxel
        kl = np.c_[keys, alll]
        ukl, idx = np.unique(kl, axis=0, return_inverse=True)
        votes = np.bincount(idx.reshape(-1), weights=allw)
        best = np.lexsort((-votes, ukl[:, 0]))
        first = np.r_[True, ukl[best[1:], 0] != ukl[best[:-1], 0]]
        table_keys, table_lab = ukl[best[first], 0], ukl[best[first], 1]
    pred, gt, valid_pts = [], [], []
    for v in evals:
        p = backproject_true(v)[::EVAL_STRIDE, ::EVAL_STRIDE]
        g = np.asarray(v.instances)[::EVAL_STRIDE, ::EVAL_STRIDE]
        flat = p.reshape(-1, 3)
        lab = np.zeros(len(flat), np.int64)
        ok = np.isfinite(flat).all(1)
        if len(table_keys) and ok.any():
            k = _keys(np.floor(flat[ok] / VOXEL).astype(np.int64))
            pos = np.clip(np.searchsorted(table_keys, k), 0, len(table_keys) - 1)
            hit = table_keys[pos] == k
            lab[np.flatnonzero(ok)[hit]] = table_lab[pos[hit]]
        pred.append(lab.reshape(g.shape))
        gt.append(g)
        valid_pts.append(p)
    return float(mean_iou(pred, gt, valid_pts) or 0.0)


def backproject_true(v: View) -> np.ndarray:
    from graphseg.scene import backproject

    return backproject(v.depth, v.K, v.cam_to_world)


def even_indices(n: int, c: int = NUM_CANDIDATES) -> list[int]:
    """``n`` candidate indices evenly spaced on a ring of ``c`` (``round(c k / n)``).

    >>> even_indices(3), even_indices(10)[:4]
    ([0, 8, 16], [0, 2, 5, 7])
    """
    return sorted({int(round(c * k / n)) % c for k in range(n)})


# ----------------------------------------------------------------------------- one scene
def run_scene(spec: Any, weights: dict[str, float], *, strategies: tuple[str, ...] = STRATEGIES, check_pipeline: bool = False) -> dict[str, Any]:
    t0 = time.perf_counter()
    cfg = Config.preset("rgbd")
    runner = Runner(cfg)
    ren = Renderer(spec)
    init = ren.render(initial_poses(spec))
    init_views = [init["i0"], init["i1"]]
    s2, r2 = runner(init_views, spec.name)
    cands = sample_candidates(s2, r2, num=NUM_CANDIDATES)
    cpose = {f"c{k:02d}": (T[:3, 3], T[:3, 3] + T[:3, 2]) for k, T in enumerate(cands)}
    evals = list(ren.render(cpose).values())  # the evaluation views (every candidate)
    cview = {f"c{k:02d}": evals[k] for k in range(len(cands))}
    if check_pipeline:  # the cached runner equals graphseg.pipeline.run
        from graphseg.pipeline import run

        ref = run(Scene(init_views + [evals[5]], {}, spec.name), cfg)
        _, mine = runner(init_views + [evals[5]], spec.name)
        assert all((a == b).all() for a, b in zip(ref.labels, mine.labels)), "cached runner differs from pipeline.run"
    curves: dict[str, Any] = {}
    picks: dict[str, Any] = {}

    def measure(scene: Scene, result: Any) -> dict[str, float]:
        return {"view_iou": view_iou(scene, result), "scene_iou": scene_iou(scene, result, evals), "objects": result.num_objects}

    m2 = measure(s2, r2)
    nbv_seconds = 0.0
    if "suggested" in strategies:
        chosen: list[int] = []
        scene, result, rows = s2, r2, [m2]
        terms_log = []
        while 2 + len(chosen) < N_MAX:
            rest = [k for k in range(len(cands)) if k not in chosen]
            t = time.perf_counter()
            ranked = suggest_views(scene, result, cands[rest], weights=weights)
            nbv_seconds += time.perf_counter() - t
            pick = rest[ranked[0].index]
            terms_log.append(ranked[0].terms)
            chosen.append(pick)
            scene, result = runner(init_views + [cview[f"c{k:02d}"] for k in chosen], spec.name)
            rows.append(measure(scene, result))
        curves["suggested"] = rows
        picks["suggested"] = chosen
        picks["suggested_terms"] = terms_log
    if "random" in strategies:
        orders = []
        all_rows = []
        for r in range(RANDOM_ORDERS):
            order = [int(k) for k in np.random.default_rng([spec.seed, 100 + r]).permutation(len(cands))[: N_MAX - 2]]
            rows = [m2]
            for n in range(1, len(order) + 1):
                scene, result = runner(init_views + [cview[f"c{k:02d}"] for k in order[:n]], spec.name)
                rows.append(measure(scene, result))
            orders.append(order)
            all_rows.append(rows)
        curves["random"] = [{k: float(np.mean([rows[i][k] for rows in all_rows])) for k in m2} for i in range(N_MAX - 1)]
        picks["random"] = orders
    if "even" in strategies:
        rows = []
        for n in range(2, N_MAX + 1):
            idx = even_indices(n)
            scene, result = runner([cview[f"c{k:02d}"] for k in idx], spec.name)
            rows.append(measure(scene, result))
        curves["even"] = rows
    return {
        "scene": spec.name,
        "half": spec.half,
        "layout": spec.layout,
        "objects": spec.objects,
        "object_set": spec.object_set,
        "curves": curves,
        "picks": picks,
        "runs": runner.runs,
        "run_seconds": runner.seconds,
        "nbv_seconds": nbv_seconds,
        "render_calls": ren.calls,
        "seconds": time.perf_counter() - t0,
    }


# ----------------------------------------------------------------------------- summary
def mean_curves(rows: list[dict[str, Any]], measure: str) -> dict[str, list[float]]:
    out = {}
    for s in STRATEGIES:
        have = [r["curves"][s] for r in rows if s in r["curves"]]
        if have:
            out[s] = [float(np.mean([c[i][measure] for c in have])) for i in range(N_MAX - 1)]
    return out


def target_check(curves: dict[str, list[float]]) -> dict[str, Any]:
    """Views the suggested order needs to reach the IoU of 10 evenly spaced views (None: not within 10)."""
    if "suggested" not in curves or "even" not in curves:
        return {}
    goal = curves["even"][-1]
    need = next((n for n, v in zip(range(2, N_MAX + 1), curves["suggested"]) if v >= goal - 1e-9), None)
    # vacuous: 10 evenly spaced views do no better than the 2 initial views (more views did not help)
    return {"even_10": goal, "suggested_6": curves["suggested"][4], "start_2": curves["suggested"][0], "views_needed": need, "met": need is not None and need <= 6, "vacuous": goal <= curves["suggested"][0] + 1e-9}


def summarise(rows: list[dict[str, Any]], weights: dict[str, float]) -> dict[str, Any]:
    out = {}
    for half in ("tune", "check", "all"):
        sel = [r for r in rows if half == "all" or r["half"] == half]
        if not sel:
            continue
        out[half] = {"scenes": len(sel)}
        for m in ("view_iou", "scene_iou"):
            c = mean_curves(sel, m)
            out[half][m] = {"curves": c, "target": target_check(c), "mean_3_10": {k: float(np.mean(v[1:])) for k, v in c.items()}}
        terms = [t for r in sel for t in r["picks"].get("suggested_terms", [])]
        scored = sum(sum(weights[k] * x for k, x in t.items()) > 0 for t in terms)
        out[half]["picks_scored"] = {"nonzero": scored, "picks": len(terms)}
    return out


def markdown(payload: dict[str, Any]) -> str:
    lines = [
        f"Next-best-view, {payload['scenes']} pybullet scenes (family pairs {list(PAIRS)}, {SIZE[0]}x{SIZE[1]}, true depth, `Config.preset(\"rgbd\")`), "
        f"weights {payload['weights']}; `python benchmarks/bench_nbv.py {' '.join(payload['argv'])}`, commit `{payload['git'].get('commit')}`, {payload['elapsed_s']:.0f} s.",
        "",
    ]
    for m, title in (("view_iou", "view IoU (views used)"), ("scene_iou", "scene IoU (all 24 candidate views)")):
        lines += [f"**{title}**", "", "| half | strategy | " + " | ".join(str(n) for n in range(2, N_MAX + 1)) + " | mean 3-10 |", "|---|---|" + "---|" * N_MAX]
        for half in ("tune", "check", "all"):
            if half not in payload["summary"]:
                continue
            summ = payload["summary"][half][m]
            for s, c in summ["curves"].items():
                mean = summ.get("mean_3_10", {}).get(s, float(np.mean(c[1:])))
                lines.append(f"| {half} | {s} | " + " | ".join(f"{x:.3f}" for x in c) + f" | {mean:.3f} |")
        lines.append("")
        for half in ("tune", "check", "all"):
            t = payload["summary"].get(half, {}).get(m, {}).get("target")
            if t:
                verdict = "met" if t["met"] else "not met"
                if t.get("vacuous", t["even_10"] <= t.get("start_2", -1)):
                    verdict += f", but vacuously: 10 evenly spaced views do no better than the 2 initial views ({t.get('start_2', float('nan')):.3f})"
                lines.append(
                    f"- {half}: 10 evenly spaced views {t['even_10']:.3f}; suggested at 6 views {t['suggested_6']:.3f}; "
                    f"suggested views needed to reach it: {t['views_needed'] if t['views_needed'] is not None else '> 10'} "
                    f"(target <= 6: {verdict})"
                )
        lines.append("")
    for half in ("tune", "check", "all"):
        ps = payload["summary"].get(half, {}).get("picks_scored")
        if ps:
            lines.append(f"- {half}: {ps['nonzero']} of {ps['picks']} suggested picks had a score above 0; the others were ties at 0, ranked by the spread tie-break (angle to the nearest camera).")
    lines.append("")
    if payload.get("tuning"):
        lines += ["**Weight choice (tune half only; mean over 3..6 views of the suggested curve)**", "", "| ambiguity | under_seen | table | view IoU | scene IoU |", "|---|---|---|---|---|"]
        for g in payload["tuning"]["grid"]:
            w = g["weights"]
            lines.append(f"| {w['ambiguity']:g} | {w['under_seen']:g} | {w['table']:g} | {g['view_iou_3_6']:.4f} | {g['scene_iou_3_6']:.4f} |")
        lines.append("")
    return "\n".join(lines)


def plot(payload: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    ns = list(range(2, N_MAX + 1))
    colours = {"suggested": "tab:red", "random": "tab:grey", "even": "tab:blue"}
    for ax, (m, title) in zip(axes, (("view_iou", "IoU over the views used"), ("scene_iou", "IoU over all 24 candidate views"))):
        for half, style in (("tune", "--"), ("check", ":"), ("all", "-")):
            if half not in payload["summary"]:
                continue
            for s, c in payload["summary"][half][m]["curves"].items():
                ax.plot(ns, c, style, color=colours[s], marker="o" if half == "all" else None, ms=3, lw=2 if half == "all" else 1, label=f"{s} ({half})" if half == "all" else None)
        ax.set_xlabel("views")
        ax.set_ylabel("mean IoU")
        ax.set_title(title)
        ax.grid(alpha=0.3)
    axes[0].legend(title="solid: all; dashed: tune; dotted: check", fontsize=8, title_fontsize=8)
    fig.suptitle(f"Next-best-view on {payload['scenes']} pybullet scenes ({SIZE[0]}x{SIZE[1]}, true depth)")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    print(f"wrote {path}")


# ----------------------------------------------------------------------------- tuning
#: The weight grid of ``--tune``: every term on (1) or off (0), all off excluded.
GRID = [dict(zip(TERMS, map(float, w))) for w in itertools.product((0, 1), repeat=len(TERMS)) if any(w)] + [
    {"ambiguity": 1.0, "under_seen": 2.0, "table": 0.5},
    {"ambiguity": 0.5, "under_seen": 1.0, "table": 2.0},
    {"ambiguity": 2.0, "under_seen": 1.0, "table": 0.5},
]


def tune(specs: list[Any]) -> dict[str, Any]:
    """Suggested curves on the tune half for every weight setting of :data:`GRID`; the best by mean view IoU over 3..6 views."""
    rows = []
    for w in GRID:
        scores = []
        for spec in specs:
            r = run_scene(spec, w, strategies=("suggested",))
            c = r["curves"]["suggested"]
            scores.append({"scene": spec.name, "view_iou": [x["view_iou"] for x in c], "scene_iou": [x["scene_iou"] for x in c]})
        obj = float(np.mean([np.mean(s["view_iou"][1:5]) for s in scores]))
        obj2 = float(np.mean([np.mean(s["scene_iou"][1:5]) for s in scores]))
        rows.append({"weights": w, "objective_view_iou_3_6": obj, "scene_iou_3_6": obj2, "scenes": scores})
        print(f"tune {w}: view IoU 3..6 {obj:.4f}, scene IoU 3..6 {obj2:.4f}", flush=True)
    best = max(rows, key=lambda r: (r["objective_view_iou_3_6"], r["scene_iou_3_6"]))
    return {"grid": rows, "best": best["weights"]}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tune", action="store_true", help="run the weight grid on the tune half and write nbv_tune.json")
    ap.add_argument("--scenes", help="comma-separated scene names (graphseg.sim.families)")
    ap.add_argument("--quick", action="store_true", help="the first pair only")
    ap.add_argument("--json", help="output JSON (default benchmarks/results/nbv.json; nbv.partial.json for a partial run)")
    ap.add_argument("--report", help="rewrite the summary, Markdown and plot of an existing JSON (no runs)")
    args = ap.parse_args(argv)
    if args.report:
        path = Path(args.report)
        payload = json.loads(path.read_text())
        payload["summary"] = summarise(payload["rows"], payload["weights"])
        path.write_text(json.dumps(payload, indent=1, default=float))
        path.with_suffix(".md").write_text(markdown(payload) + "\n")
        if path.name == "nbv.json":
            plot(payload, PLOT)
        print(markdown(payload))
        return 0
    from graphseg.sim import families

    specs = [s for k, s in enumerate(families.SCENES) if (k // 2) in PAIRS]
    if args.scenes:
        specs = [families.get(n.strip()) for n in args.scenes.split(",") if n.strip()]
    if args.quick:
        specs = specs[:QUICK]
    t0 = time.perf_counter()
    if args.tune:
        out = tune([s for s in specs if s.half == "tune"])
        path = Path(args.json) if args.json else RESULTS / "nbv.tune.json"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps({"git": git_state(ROOT), "elapsed_s": time.perf_counter() - t0, **out}, indent=1, default=float))
        print(f"best weights {out['best']}; wrote {path}")
        return 0
    partial = bool(args.scenes) or args.quick
    rows = []
    for k, spec in enumerate(specs):
        rows.append(run_scene(spec, DEFAULT_WEIGHTS, check_pipeline=k == 0))
        r = rows[-1]
        print(
            f"{spec.name:30s} {spec.half:5s} " + "  ".join(f"{s}: {r['curves'][s][0]['view_iou']:.3f}->{r['curves'][s][4]['view_iou']:.3f}->{r['curves'][s][-1]['view_iou']:.3f}" for s in STRATEGIES)
            + f"  ({r['seconds']:.0f} s)",
            flush=True,
        )
    payload = {
        "argv": list(sys.argv[1:] if argv is None else argv),
        "git": git_state(ROOT),
        "machine_note": f"{os.cpu_count()} CPU cores, shared",
        "elapsed_s": time.perf_counter() - t0,
        "scenes": len(rows),
        "size": list(SIZE),
        "candidates": NUM_CANDIDATES,
        "random_orders": RANDOM_ORDERS,
        "weights": dict(DEFAULT_WEIGHTS),
        "config": "Config.preset('rgbd')",
        "rows": rows,
        "summary": summarise(rows, dict(DEFAULT_WEIGHTS)),
    }
    tuned = RESULTS / "nbv.tune.json"
    if tuned.is_file():
        t = json.loads(tuned.read_text())
        payload["tuning"] = {
            "best": t["best"],
            "git": t.get("git"),
            "grid": [{"weights": g["weights"], "view_iou_3_6": g["objective_view_iou_3_6"], "scene_iou_3_6": g["scene_iou_3_6"]} for g in t["grid"]],
        }
    path = Path(args.json) if args.json else RESULTS / ("nbv.partial.json" if partial else "nbv.json")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(payload, indent=1, default=float))
    md = markdown(payload)
    path.with_suffix(".md").write_text(md + "\n")
    print(md)
    print(f"wrote {path} and {path.with_suffix('.md')}")
    if not partial:
        plot(payload, PLOT)
    return 0


if __name__ == "__main__":
    sys.exit(main())
