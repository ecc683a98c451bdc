"""The public steps of segment(): evidence_fields, run_stages, finish_segmentation, view_masks, finite_points."""

from __future__ import annotations

import numpy as np
import pytest

from graphseg import Config
from graphseg.graphs import CorrespondenceGraph
from graphseg.method.masks import compose_masks
from graphseg.method.segment import (
    evidence_fields,
    finish_segmentation,
    finite_points,
    run_stages,
    segment,
    view_masks,
)
from graphseg.scene import SceneError, View
from graphseg.testing.scenes import two_boxes_scene


def _inputs():
    scene, masks, matches = two_boxes_scene()
    labels = [compose_masks(m, max_overlap=0.09, min_area=1)[0] for m in masks]
    points = [np.asarray(v.points) for v in scene.views]
    return scene, masks, matches, labels, points


def test_steps_compose_to_segment_without_background():
    """run_stages + finish_segmentation on the composed masks give segment()'s partition (no background)."""
    scene, masks, matches, labels, points = _inputs()
    cfg = Config.preset("rgbd", background={"enabled": False})
    ref = segment(scene, masks, matches, cfg)
    shared = evidence_fields(cfg.requires(), scene.views, matches=matches, points=points, features=None, labels=labels, name=scene.name)
    g = CorrespondenceGraph.from_masks(labels, points)
    part, graphs, info = run_stages(g, cfg, shared, rng=np.random.default_rng(cfg.seed))
    res = finish_segmentation(scene.views, part, graphs, labels, points, [np.zeros(v.shape, bool) for v in scene.views], cfg, info={"stages": info})
    assert len(graphs) == len(cfg.edge_stages) == len(info)
    assert res.num_objects == ref.num_objects
    for a, b in zip(res.labels, ref.labels):
        np.testing.assert_array_equal(a, b)
    for a, b in zip(res.graphs, ref.graphs):
        np.testing.assert_array_equal(a.edge_index, b.edge_index)
        np.testing.assert_array_equal(a.node_attr["object"], b.node_attr["object"])
    assert list(res.info)[:1] == ["stages"] and "total" not in res.info["timings"]


def test_run_stages_without_stages_returns_the_graph():
    scene, _, matches, labels, points = _inputs()
    g = CorrespondenceGraph.from_masks(labels, points)
    cfg = Config.preset("rgbd").model_copy(update={"stages": []})
    part, graphs, info = run_stages(g, cfg, {}, rng=np.random.default_rng(0))
    assert part is g and graphs == [] and info == []


def test_run_stages_uses_the_edge_source():
    """An edge source that adds no edge leaves every mask its own object."""
    scene, _, matches, labels, points = _inputs()
    g = CorrespondenceGraph.from_masks(labels, points)
    calls = []

    def nothing(spec, stage, graph, evidence):
        calls.append((spec.name, stage, graph.num_nodes))
        return [(np.zeros((2, 0), np.int64), {})], {"edges": 0}

    part, graphs, info = run_stages(g, Config.preset("rgbd"), {"matches": matches, "points": points}, rng=np.random.default_rng(0), edges=nothing)
    assert calls == [("pixel_match", 0, 15), ("chamfer_3d", 1, 15)]
    assert part.num_nodes == g.num_nodes and [i["components"] for i in info] == [15, 15]
    assert graphs[0].edge_attr["stage"].shape == (0,)


def test_finish_segmentation_without_masks_warns():
    scene, _, _, _, points = _inputs()
    empty = [np.zeros(v.shape, np.int32) for v in scene.views]
    g = CorrespondenceGraph.from_masks(empty, points)
    res = finish_segmentation(scene.views, g, [g.copy()], empty, points, [np.zeros(v.shape, bool) for v in scene.views], Config(), start=0.0)
    assert res.num_objects == 0 and res.mask_object.shape == (0,)
    assert res.info["warnings"] == ["no usable masks (every mask was empty, background, or below masks.min_area): 0 objects"]
    assert res.info["timings"]["total"] > 0


def test_evidence_fields_checks():
    scene, _, matches, labels, points = _inputs()
    with pytest.raises(ValueError, match="requires features"):
        evidence_fields({"features"}, scene.views, matches=matches, points=points, features=None, labels=labels, name="s")
    out = evidence_fields({"cameras", "points"}, scene.views, matches=matches, points=points, features=None, labels=labels, name="s")
    assert sorted(out) == ["cameras", "normal_cache", "points"] and len(out["cameras"]) == scene.num_views


def test_view_masks_and_finite_points():
    v = View("a", np.zeros((2, 3, 3), np.uint8))
    lab = np.array([[0, 1, 1], [2, 2, 0]], np.int32)
    assert view_masks(lab, v) is lab
    stack = np.zeros((2, 2, 3), bool)
    got = view_masks(stack, v)
    assert isinstance(got, list) and len(got) == 2 and got[0].shape == (2, 3)
    assert view_masks([], v) == []
    with pytest.raises(SceneError, match="a: masks: expected an int label image"):
        view_masks(np.zeros((2, 3), bool), v)
    with pytest.raises(SceneError, match="got dict"):
        view_masks({}, v)
    p = np.ones((2, 3, 3))
    assert finite_points(p) is p
    p[1, 2, 1] = np.nan
    q = finite_points(p)
    assert q.dtype == np.float32 and np.isnan(q[1, 2]).all() and np.isfinite(q[0]).all() and not np.isnan(p[1, 2, 0])
