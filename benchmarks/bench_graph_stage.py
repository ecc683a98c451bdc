"""Benchmark the graph stage at the size of a 10-view 640x480 scene.

Inputs: 10 views of 640x480 with 100 masks each (1000 masks), 45 view pairs x
10,000 matches (10% uniform outliers, 0.5 px noise), 3.07 million world
points. Each of the 100 grid cells is one surface patch seen in every view, so
both stages do real work: 2D edges join a patch across views (noise leaves
some copies apart), and 3D edges join the copies the 2D stage missed.

Target (issue 3): 2D edge addition + both contractions + the Chamfer stage
<= 1.0 s wall on a 2-core machine; issue 9: segment() end to end (with
mask composition and the object clouds) <= 0.5 s. Per-step times (best of
--repeat) and peak RSS are printed and written as JSON.

Usage: python benchmarks/bench_graph_stage.py [--json PATH] [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from _common import peak_rss_mb, print_table, write_json  # noqa: E402

from graphseg.config import Config  # noqa: E402
from graphseg.graphs import (  # noqa: E402
    Chamfer3D,
    CorrespondenceGraph,
    Evidence,
    PixelMatch,
    coarsen,
    randomized_star_contraction,
)
from graphseg.method.segment import segment  # noqa: E402
from graphseg.scene import Matches, Scene, View  # noqa: E402


def make_inputs(views=10, h=480, w=640, rows=10, cols=10, matches=10_000, seed=0):
    rng = np.random.default_rng(seed)
    ch, cw = h // rows, w // cols
    yy, xx = np.mgrid[0:h, 0:w]
    r, c = yy // ch, xx // cw
    labels = (r * cols + c + 1).astype(np.int32)
    # object = 2x2 block of cells; objects sit 4 cm apart, parts of one object touch
    obj_r, obj_c = r // 2, c // 2
    scale = 0.002
    x = xx * scale + obj_c * 0.04
    y = yy * scale + obj_r * 0.04
    vs, masks, pts_all = [], [], []
    for v in range(views):
        z = 0.8 + 0.002 * np.sin(xx / 37.0 + v) + 1e-4 * v
        pts = np.stack([x, y, z], -1).astype(np.float32)
        T = np.eye(4)
        T[:3, 3] = [0.6, 0.5, 0.0]
        vs.append(View(f"{v:02d}", np.zeros((h, w, 3), np.uint8), points=pts, K=np.array([[500.0, 0, w / 2], [0, 500, h / 2], [0, 0, 1]]), cam_to_world=T))
        masks.append(labels)
        pts_all.append(pts)
    m = {}
    for i in range(views):
        for j in range(i + 1, views):
            xy = np.c_[rng.uniform(0, w - 1, matches), rng.uniform(0, h - 1, matches)]
            xy2 = xy + rng.normal(0, 0.5, xy.shape)
            out = rng.random(matches) < 0.1
            xy2[out] = np.c_[rng.uniform(0, w - 1, out.sum()), rng.uniform(0, h - 1, out.sum())]
            m[(i, j)] = Matches(xy, np.clip(xy2, 0, [w - 1, h - 1]), rng.uniform(0.5, 1, matches))
    return Scene(vs, name="bench"), masks, m


def run_steps(scene, masks, matches, cfg):
    t = {}
    points = [v.points for v in scene.views]
    s = time.perf_counter()
    g = CorrespondenceGraph.from_masks(masks, points)
    t["node_table"] = time.perf_counter() - s
    s = time.perf_counter()
    ev = Evidence.for_graph(g, matches=matches, points=points)
    es = PixelMatch(**cfg.criterion_options("pixel_match"))(g, ev)
    g2 = g.add_edges(es.edge_index, dict(es.edge_attr))
    t["pixel_match_edges"] = time.perf_counter() - s
    s = time.perf_counter()
    cl = randomized_star_contraction(g2.edge_index, g2.num_nodes, rng=0)
    t["contract_2d"] = time.perf_counter() - s
    s = time.perf_counter()
    sup = coarsen(g2, cl)
    t["coarsen_2d"] = time.perf_counter() - s
    s = time.perf_counter()
    adder = Chamfer3D(**cfg.criterion_options("chamfer_3d"))
    ev3 = Evidence.for_graph(sup, points=points)
    sets = adder.point_sets(sup, ev3)
    t["chamfer_gather_voxel"] = time.perf_counter() - s
    s = time.perf_counter()
    from graphseg.graphs import chamfer_edges

    es3 = chamfer_edges(sets, adder.options.tau, prune=adder.options.prune)
    t["chamfer_edges"] = time.perf_counter() - s
    s = time.perf_counter()
    sup2 = sup.add_edges(es3.edge_index, dict(es3.edge_attr))
    cl3 = randomized_star_contraction(sup2.edge_index, sup2.num_nodes, rng=0)
    final = coarsen(sup2, cl3)
    t["contract_3d"] = time.perf_counter() - s
    t["graph_stage_total"] = sum(v for k, v in t.items() if k != "node_table")
    info = {"masks": g.num_nodes, "edges_2d": es.num_edges, "supervertices": sup.num_nodes, "points_gathered": int(len(sets.points)),
            "chamfer_candidates": es3.info["candidates"], "edges_3d": es3.num_edges, "objects": final.num_nodes}
    return t, info


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--json", default="benchmarks/results/graph_stage.json")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    scene, masks, matches = make_inputs()
    cfg = Config(background={"enabled": False})
    npts = sum(int(np.isfinite(v.points).all(-1).sum()) for v in scene.views)
    print(f"inputs: {len(scene.views)} views 640x480, {sum(int(m.max()) for m in masks)} masks, "
          f"{len(matches)} pairs x 10000 matches, {npts} points")
    runs = [run_steps(scene, masks, matches, cfg) for _ in range(args.repeat)]
    best = {k: min(r[0][k] for r in runs) for k in runs[0][0]}
    info = runs[0][1]
    seg_runs = []
    for _ in range(args.repeat):  # best of --repeat, like the steps
        s = time.perf_counter()
        result = segment(scene, masks, matches, cfg)
        seg_runs.append((time.perf_counter() - s, result.info["timings"]))
    seg_total, seg_timings = min(seg_runs, key=lambda r: r[0])
    rows = [{"step": k, "seconds": v} for k, v in best.items()]
    rows.append({"step": "segment() end to end (incl. compose, outputs)", "seconds": seg_total})
    print_table(rows, ["step", "seconds"])
    print("graph:", info, "| objects from segment():", result.num_objects)
    rss = peak_rss_mb()
    target = best["graph_stage_total"] <= 1.0
    seg_target = seg_total <= 0.5
    print(f"peak RSS: {rss:.0f} MB; target graph stage <= 1.0 s: {'met' if target else 'MISSED'} ({best['graph_stage_total']:.3f} s)")
    print(f"target segment() end to end <= 0.5 s (issue 9): {'met' if seg_target else 'MISSED'} ({seg_total:.3f} s, best of {args.repeat})")
    write_json(args.json, {"steps_best_of": args.repeat, "seconds": best, "segment_seconds": seg_total, "graph": info,
                           "peak_rss_mb": rss, "target_met": bool(target), "segment_target_met": bool(seg_target),
                           "segment_timings": seg_timings})


if __name__ == "__main__":
    main()
