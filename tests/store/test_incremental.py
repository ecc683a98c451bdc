"""The incremental update: prepare_view, node keys, local criteria, reuse."""

import numpy as np
import pytest

from graphseg.config import Config, CriterionSpec
from graphseg.graphs import CorrespondenceGraph
from graphseg.scene import SceneError
from graphseg.store.incremental import local_rule, node_keys, prepare_view, update
from graphseg.testing.scenes import two_boxes_scene

from .conftest import partition, per_view_batch


@pytest.fixture(scope="module")
def two():
    return two_boxes_scene()


def test_prepare_view_shapes(two):
    scene, masks, _ = two
    d = prepare_view(scene.views[0], masks[0], Config(), uid=7)
    h, w = scene.views[0].shape
    assert d.uid == 7 and d.name == "000"
    assert d.labels.shape == (h, w) and d.labels.dtype == np.int32
    assert d.background.shape == (h, w) and d.background.dtype == bool
    assert d.masks.shape == (len(masks[0]), h, w) and d.masks.dtype == bool
    assert set(d.nodes) >= {"view", "mask_id", "area", "bbox", "num_points", "centroid_3d"}
    assert (d.nodes["view"] == 0).all() and int(d.nodes["area"].sum()) == int((d.labels > 0).sum())


def test_prepare_view_checks_its_inputs(two):
    scene, masks, _ = two
    with pytest.raises(SceneError, match=r"000: masks\[1\]: expected a bool mask \[96, 128\] \(got bool \[3, 3\]\)"):
        prepare_view(scene.views[0], [masks[0][0], np.zeros((3, 3), bool)], Config(), uid=0)
    with pytest.raises(SceneError, match="000: points: no 3D point map"):
        prepare_view(scene.views[0].replace(points=None), masks[0], Config(), uid=0)
    empty = prepare_view(scene.views[0], [], Config(), uid=0)  # no mask at all: a view with no node
    assert empty.nodes["view"].size == 0 and not empty.labels.any()


def test_node_keys_name_the_same_masks_whatever_the_node_order():
    a = CorrespondenceGraph(2, members={"view": [0, 0, 1], "mask_id": [0, 1, 0], "node": [0, 1, 0]}, level="super")
    b = CorrespondenceGraph(2, members={"view": [1, 0, 0], "mask_id": [0, 1, 0], "node": [1, 0, 1]}, level="super")
    ka, kb = node_keys(a, np.array([3, 4])), node_keys(b, np.array([3, 4]))
    assert ka[0] == kb[1] and ka[1] == kb[0] and ka[0] != ka[1]
    assert node_keys(CorrespondenceGraph(0), np.zeros(0, np.int64)) == []


@pytest.mark.parametrize(
    "spec, stage, rule",
    [
        ({"pixel_match": {"tau": 0.3, "normalization": "pair_hits"}}, 0, "matches"),
        ({"pixel_match": {"tau": 0.3, "normalization": "area"}}, 0, "matches"),
        ({"pixel_match": {"tau": 0.3, "normalization": "hits"}}, 0, None),  # hits add up over every pair
        ({"pixel_match": {"tau": 0.3}}, 1, None),  # super nodes: matches of many views
        ("pixel_match", 0, None),  # the 78th percentile of all ratios
        ("chamfer_3d", 1, "points"),
        ("chamfer_3d", 0, "points"),
        ({"chamfer_3d": {"fragment_ratio": 0.2}}, 1, None),  # keeps a node's strongest edge among all
        ("depth_repulsion", 0, None),
    ],
)
def test_local_rule(spec, stage, rule):
    assert local_rule(CriterionSpec.model_validate(spec), stage) == rule


def test_update_from_scratch_is_segment_with_the_per_view_background(two):
    scene, masks, matches = two
    for cfg in (Config(), Config.preset("rgbd", contractor="union_find")):
        views = [prepare_view(v, m, cfg, uid=i) for i, (v, m) in enumerate(zip(scene.views, masks))]
        out = update(views, matches, cfg)
        with per_view_batch(cfg.seed) as segment:
            ref = segment(scene, masks, matches, cfg)
        np.testing.assert_array_equal(out.result.mask_object, ref.mask_object)
        for a, b in zip(out.result.labels, ref.labels):
            np.testing.assert_array_equal(a, b)
        assert [g.num_edges for g in out.result.graphs] == [g.num_edges for g in ref.graphs]
        assert out.mask_uid.shape == out.result.mask_id.shape
        assert (out.mask_uid & ((1 << 24) - 1)).tolist() == out.result.mask_id.tolist()


def test_chamfer_edges_between_unchanged_nodes_are_reused(two):
    # one 3D stage on the masks: the new view's masks are the only new nodes
    scene, masks, _ = two
    cfg = Config(stages=[[{"chamfer_3d": {"tau": 1e-3}}]], contractor="union_find")
    views = [prepare_view(v, m, cfg, uid=i) for i, (v, m) in enumerate(zip(scene.views, masks))]
    first = update(views[:2], {}, cfg)
    again = update(views, {}, cfg, previous=first.snapshot)
    full = update(views, {}, cfg)
    assert again.recomputed["stage0/chamfer_3d"]["reused"] == first.result.graphs[0].num_edges > 0
    assert 0 < again.recomputed["stage0/chamfer_3d"]["computed"] < full.result.graphs[0].num_edges
    assert partition(again.result) == partition(full.result)
    assert again.result.graphs[0].num_edges == full.result.graphs[0].num_edges


def test_removed_pairs_drop_their_edges(two):
    scene, masks, matches = two
    cfg = Config.preset("rgbd")
    views = [prepare_view(v, m, cfg, uid=i) for i, (v, m) in enumerate(zip(scene.views, masks))]
    first = update(views, matches, cfg)
    fewer = {k: m for k, m in matches.items() if k != (0, 2)}
    again = update(views, fewer, cfg, previous=first.snapshot, changed_pairs={(0, 2)})
    full = update(views, fewer, cfg)
    assert again.recomputed["stage0/pixel_match"]["computed"] == 0 and again.recomputed["stage0/pixel_match"]["reused"] > 0
    assert again.result.graphs[0].num_edges == full.result.graphs[0].num_edges < first.result.graphs[0].num_edges
