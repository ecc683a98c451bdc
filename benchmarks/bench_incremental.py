"""Adding the 20th view to a store vs one batch run over the 20 views (issue 23).

For each scene (YCB-Video 0001, 20 frames, when ../shared/data/ycbv is there; a
pybullet scene of 20 views around 6 objects, 640x480):

* ``batch``: :func:`graphseg.pipeline.run` on the 20 views (lift, segment,
  match the pairs the rule selects, graph), the default backends
  (``geometric`` segmenter, ``reprojection`` matcher) and ``--preset rgbd``;
* ``store``: a :class:`graphseg.store.SceneGraph` that gets the first 19 views
  one by one, then the 20th. ``warm``: the add in a process that has the store
  open (a robot's loop); ``cold``: opening the store from disk and adding (what
  ``graphseg add STORE VIEW`` does).

Time is wall-clock seconds; memory is the peak of tracemalloc (numpy arrays
included) during the step, in a separate run of the same step: with the views
already in memory (``batch``, warm adds), and including reading them (the scene
folder for the batch, the store for a cold add). The store's
partition is checked against a batch ``segment()`` with the store's masks,
matches and per-view background (equal: the order-equivalence test on all 20
views) and compared with the batch run's (global background).

Run: ``python benchmarks/bench_incremental.py`` (about 10 minutes on 2 cores);
``--scenes synthetic`` or ``--scenes ycbv`` for one; ``--no-trace`` skips the
memory runs. Writes ``benchmarks/results/incremental.json`` and ``.md``.
"""

from __future__ import annotations

import argparse
import importlib
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, os.path.dirname(__file__))
from _common import peak_traced_mb, print_table, write_json  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
YCBV = ROOT.parent / "shared" / "data" / "ycbv" / "0001"


def _scene(name: str) -> Any:
    from graphseg.config import Config
    from graphseg.pipeline import lift

    cfg = Config.preset("rgbd")
    if name == "ycbv":
        from graphseg.io import load_scene

        return lift(load_scene(YCBV, num_views=20), None, cfg)
    from graphseg.sim.pybullet_scenes import synthesize

    return lift(synthesize(seed=0, objects=6, views=20, size=(640, 480)), None, cfg)


def _warm_copy(base: Path, dst: Path) -> Any:
    """A copy of the store ``base`` at ``dst``, opened with every view and the result in memory (a robot's loop)."""
    shutil.copytree(base, dst)
    from graphseg import SceneGraph

    sg = SceneGraph.open(dst, create=False)
    for n in sg.view_names:
        sg.view_data(n)
    sg.result()
    return sg


def _partition(result: Any) -> tuple[set[frozenset[tuple[str, int]]], frozenset[tuple[str, int]]]:
    groups: dict[int, set[tuple[str, int]]] = {}
    for v, m, o in zip(result.mask_view.tolist(), result.mask_id.tolist(), result.mask_object.tolist()):
        groups.setdefault(o, set()).add((result.view_names[v], m))
    return {frozenset(g) for k, g in groups.items() if k}, frozenset(groups.get(0, set()))


def _batch_like_store(sg: Any, config: Any) -> Any:
    """segment() on the store's views, masks and matches with the per-view background rule."""
    from graphseg.scene import Matches, Scene
    from graphseg.store import per_view_background

    seg = importlib.import_module("graphseg.method.segment")
    names = sg.view_names
    masks = [sg.view_data(n, masks=True).masks for n in names]
    matches = {}
    for (a, b), m in sg.matches().items():
        i, j = names.index(a), names.index(b)
        matches[(i, j) if i < j else (j, i)] = m if i < j else Matches(m.xy_j, m.xy_i, m.certainty)
    old = seg.background_masks
    seg.background_masks = lambda p, c, conf=None, rng=None: per_view_background(p, c, conf, seed=config.seed)
    try:
        return seg.segment(Scene(sg.scene().views, name="batch"), masks, matches, config)
    finally:
        seg.background_masks = old


def bench(name: str, trace: bool) -> dict[str, Any]:
    from graphseg.config import Config
    from graphseg.job import evaluate_scene
    from graphseg.pipeline import run
    from graphseg.store import SceneGraph

    cfg = Config.preset("rgbd")
    scene = _scene(name)
    views = scene.views
    print(f"\n== {name}: {len(views)} views of {views[0].shape[1]}x{views[0].shape[0]}", flush=True)
    t = time.perf_counter()
    batch = run(scene, cfg)
    t_batch = time.perf_counter() - t
    print(f"batch run: {t_batch:.1f} s, {batch.num_objects} objects, {len(batch.info['pairs'])} pairs", flush=True)
    mem_batch = peak_traced_mb(lambda: run(scene, cfg)) if trace else None
    mem_batch_load = peak_traced_mb(lambda: run(_scene(name), cfg)) if trace else None  # reading the views included

    work = Path(tempfile.mkdtemp(prefix="bench-incremental-"))
    try:
        base = work / "store19"
        sg = SceneGraph.open(base, cfg)
        per_add = []
        mem_add: dict[int, float] = {}
        for k, v in enumerate(views[:-1], 1):
            t = time.perf_counter()
            if trace and k in (5, 10, 15):
                mem_add[k] = peak_traced_mb(lambda v=v: sg.add(v))
            else:
                sg.add(v)
            per_add.append(time.perf_counter() - t)
        print(f"store: 19 adds in {sum(per_add):.1f} s", flush=True)

        # warm: the store open in this process, its views in memory (a robot's loop)
        warm = _warm_copy(base, work / "warm")
        t = time.perf_counter()
        report = warm.add(views[-1])
        t_warm = time.perf_counter() - t
        # cold: open from disk and add (graphseg add STORE VIEW)
        cold_dir = work / "cold"
        shutil.copytree(base, cold_dir)
        t = time.perf_counter()
        SceneGraph.open(cold_dir, create=False).add(views[-1])
        t_cold = time.perf_counter() - t
        mem_cold = None
        if trace:
            mem_dir = work / "mem"
            shutil.copytree(base, mem_dir)
            mem_cold = peak_traced_mb(lambda: SceneGraph.open(mem_dir, create=False).add(views[-1]))
            wm = _warm_copy(base, work / "warm-mem")
            mem_add[20] = peak_traced_mb(lambda: wm.add(views[-1]))
        print(f"20th view: warm {t_warm:.2f} s ({100 * t_warm / t_batch:.1f} % of the batch), cold {t_cold:.2f} s ({100 * t_cold / t_batch:.1f} %)", flush=True)

        store_result = warm.result()
        same = _partition(store_result) == _partition(_batch_like_store(warm, cfg))
        same_global = _partition(store_result) == _partition(batch)
        m_store = evaluate_scene(store_result, warm.scene())
        m_batch = evaluate_scene(batch, scene)
        disk = sum(f.stat().st_size for f in warm.root.rglob("*") if f.is_file())
    finally:
        shutil.rmtree(work, ignore_errors=True)

    row: dict[str, Any] = {
        "scene": name,
        "views": len(views),
        "size": f"{views[0].shape[1]}x{views[0].shape[0]}",
        "batch_s": t_batch,
        "add20_warm_s": t_warm,
        "add20_cold_s": t_cold,
        "warm_pct": 100 * t_warm / t_batch,
        "cold_pct": 100 * t_cold / t_batch,
        "add20_steps_s": {k: round(v, 3) for k, v in report.timings.items()},
        "pairs_matched_by_add20": len(report.matched),
        "pairs_batch": len(batch.info["pairs"]),
        "add_s_per_view": [round(x, 3) for x in per_add],
        "batch_peak_mb": mem_batch,
        "batch_with_reading_peak_mb": mem_batch_load,
        "add_peak_mb": {str(k): v for k, v in mem_add.items()},
        "add20_cold_peak_mb": mem_cold,
        "store_mb_on_disk": disk / 2**20,
        "recomputed_by_add20": report.recomputed,
        "partition_equals_batch_with_per_view_background": same,
        "partition_equals_batch_run": same_global,
        "objects_store": store_result.num_objects,
        "objects_batch": batch.num_objects,
        "iou_store": None if m_store is None else m_store["mean"].get("iou"),
        "iou_batch": None if m_batch is None else m_batch["mean"].get("iou"),
    }
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", default="ycbv,synthetic", help="comma-separated: ycbv, synthetic")
    ap.add_argument("--no-trace", action="store_true", help="skip the peak-memory runs")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "incremental.json"))
    args = ap.parse_args()
    rows = []
    for name in [s.strip() for s in args.scenes.split(",") if s.strip()]:
        if name == "ycbv" and not YCBV.is_dir():
            print(f"skipping ycbv: {YCBV} not found")
            continue
        rows.append(bench(name, not args.no_trace))
    cols = ["scene", "views", "size", "batch_s", "add20_warm_s", "warm_pct", "add20_cold_s", "cold_pct", "pairs_batch", "pairs_matched_by_add20"]
    print()
    table = print_table(rows, cols)
    mem_cols = ["scene", "batch_peak_mb", "add5_peak_mb", "add10_peak_mb", "add15_peak_mb", "add20_peak_mb", "batch_with_reading_peak_mb", "add20_cold_peak_mb", "store_mb_on_disk"]
    keep = ("batch_peak_mb", "batch_with_reading_peak_mb", "add20_cold_peak_mb", "store_mb_on_disk")
    mem_rows = [{"scene": r["scene"], **{k: r[k] for k in keep}, **{f"add{k}_peak_mb": v for k, v in r["add_peak_mb"].items()}} for r in rows]
    print()
    mem_table = print_table(mem_rows, mem_cols)
    eq_cols = ["scene", "partition_equals_batch_with_per_view_background", "partition_equals_batch_run", "objects_store", "objects_batch", "iou_store", "iou_batch"]
    print()
    eq_table = print_table(rows, eq_cols)
    payload = {"target": "adding the 20th view <= 15 % of a batch run over 20 views; memory bounded", "config": "preset rgbd, geometric segmenter, reprojection matcher", "rows": rows}
    write_json(args.out, payload)
    md = Path(args.out).with_suffix(".md")
    steps = "\n".join(f"- {r['scene']}: " + ", ".join(f"{k} {v:.2f} s" for k, v in r["add20_steps_s"].items()) for r in rows)
    md.write_text(
        "# Incremental add vs batch run (benchmarks/bench_incremental.py)\n\n"
        "Wall-clock seconds on this machine (2 shared cores); peak memory from tracemalloc in a separate run of each step.\n"
        "`warm`: the store open in the process (its views in memory); `cold`: open from disk, then add.\n"
        "Memory: `batch` and `addN` (warm, the N-th add) count what the step allocates with the views already in memory;\n"
        "`batch_with_reading` and `add20_cold` include reading the views (the scene folder, or the store).\n\n"
        f"{table}\n\nSteps of the warm 20th add:\n\n{steps}\n\n## Memory (MB)\n\n{mem_table}\n\n## Same partition?\n\n{eq_table}\n",
        encoding="utf-8",
    )
    print(f"wrote {md}")


if __name__ == "__main__":
    main()
