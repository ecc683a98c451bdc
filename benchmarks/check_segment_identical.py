"""Check that segment() outputs stay identical across a code change (issue 9, speed work).

Run on the old code with ``save``, then on the new code with ``compare``; the
outputs compared exactly (NaN == NaN) are the labels, mask_object, every stage
graph (edge_index, edge and node columns), the object clouds and the background,
on the graph-stage benchmark input and on scenes from graphseg.testing.scenes
(bool-mask lists, bool stacks, label images, non-finite points)::

    git stash; PYTHONPATH=. python benchmarks/check_segment_identical.py save /tmp/ref.pkl
    git stash pop; PYTHONPATH=. python benchmarks/check_segment_identical.py compare /tmp/ref.pkl

Exit status 1 when anything differs.
"""

from __future__ import annotations

import os
import pickle
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
sys.path.insert(1, os.path.join(ROOT, "benchmarks"))

import bench_graph_stage as bench  # noqa: E402

import graphseg  # noqa: E402
from graphseg.config import Config  # noqa: E402
from graphseg.method.segment import segment  # noqa: E402
from graphseg.testing import scenes  # noqa: E402


def cases():
    scene, masks, matches = bench.make_inputs()
    yield "bench_nobg", scene, masks, matches, Config.preset("paper", background={"enabled": False})
    yield "bench_bg", scene, masks, matches, Config.preset("paper")
    for seed in (0, 1):
        scene, masks, matches = scenes.two_boxes_scene(seed=seed)
        yield f"two_boxes{seed}", scene, masks, matches, Config.preset("paper")
    scene, masks, matches = scenes.two_boxes_scene(parts=3, views=4, seed=2)
    yield "two_boxes_p3", scene, masks, matches, Config.preset("paper")
    yield "two_boxes_p3_nobg", scene, masks, matches, Config.preset("paper", background={"enabled": False})
    scene = scenes.demo_box_scene(seed=0, views=4, objects=4, shape=(120, 160))
    masks = scenes.oracle_part_masks(scene, parts=2, rng=0)
    matches = scenes.exact_matches(scene, rng=0)
    yield "demo", scene, masks, matches, Config.preset("paper")
    yield "demo_minus", scene, masks, matches, Config.preset("paper").without_3d()
    scene = scenes.demo_box_scene(seed=3, views=3, objects=3, shape=(120, 160))
    for view in scene.views:  # non-finite points: inf in one coordinate, NaN rows
        p = view.points.copy()
        p[5:9, 10:40, 1] = np.inf
        p[50:52, :, 0] = np.nan
        view.points = p
    masks = scenes.oracle_part_masks(scene, parts=2, rng=1)
    yield "demo_inf", scene, masks, scenes.exact_matches(scene, rng=1), Config.preset("paper")
    stacks = [np.stack(m) for m in masks]
    yield "demo_inf_stack", scene, stacks, scenes.exact_matches(scene, rng=1), Config.preset("paper", output={"voxel_size": None})
    # the presets' steps after the last contraction (split, merge, joins, snap, refiners)
    scene = scenes.demo_box_scene(seed=5, views=4, objects=4, shape=(120, 160))
    masks = scenes.oracle_part_masks(scene, parts=2, rng=2)
    matches = scenes.exact_matches(scene, rng=2)
    for name in ("rgbd", "robust", "multicut"):
        yield f"preset_{name}", scene, masks, matches, Config.preset(name)
    yield "rgbd_sfm", scene, masks, matches, Config.preset("rgbd").for_lifter("sfm")
    yield "rgbd_refine", scene, masks, matches, Config.preset("rgbd", refine={"enabled": True}, split={"join_shared": 0.3})


def summarize(r):
    return {
        "labels": [lab.copy() for lab in r.labels],
        "mask_object": r.mask_object.copy(),
        "mask_view": r.mask_view.copy(),
        "mask_id": r.mask_id.copy(),
        "edge_index": [g.edge_index.copy() for g in r.graphs],
        "edge_attr": [{k: np.asarray(v).copy() for k, v in g.edge_attr.items()} for g in r.graphs],
        "node_attr": [{k: np.asarray(v).copy() for k, v in g.node_attr.items()} for g in r.graphs],
        "object_points": r.object_points.points.copy(),
        "object_ptr": r.object_points.ptr.copy(),
        "object_colors": None if r.object_points.colors is None else r.object_points.colors.copy(),
        "masks_info": r.info["masks"],
        "stages": [{k: v for k, v in s.items() if k != "seconds"} for s in r.info["stages"]],
        "background": [b.copy() for b in r.background],
    }


def same(a, b) -> bool:
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    if isinstance(a, np.ndarray):
        return isinstance(b, np.ndarray) and a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b, equal_nan=a.dtype.kind == "f")
    return a == b


def main(argv=None) -> int:
    mode, path = (argv or sys.argv[1:])[:2]
    if not graphseg.__file__.startswith(ROOT):
        raise SystemExit(f"imported {graphseg.__file__}, not this checkout; run with PYTHONPATH=.")
    results = {}
    for name, scene, masks, matches, cfg in cases():
        t = time.perf_counter()
        r = segment(scene, masks, matches, cfg)
        print(f"{name}: {time.perf_counter() - t:.3f} s, {r.num_objects} objects", flush=True)
        results[name] = summarize(r)
    if mode == "save":
        with open(path, "wb") as f:
            pickle.dump(results, f)
        print(f"wrote {path}")
        return 0
    with open(path, "rb") as f:
        ref = pickle.load(f)
    bad = [f"{name}.{k}" for name in ref for k in ref[name] if not same(ref[name][k], results[name][k])]
    for b in bad:
        print("DIFFERS:", b)
    print("ALL IDENTICAL" if not bad else f"{len(bad)} differences")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
