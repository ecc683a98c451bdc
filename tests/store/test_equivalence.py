"""Adding views one by one, in any order, gives the partition of one batch run over the same views."""

import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from graphseg.config import Config
from graphseg.store import SceneGraph
from graphseg.testing.scenes import box_scene, random_boxes

from .conftest import Lookup, batch_matches, partition, per_view_batch, same_labels

UNION_FIND = Config.preset("rgbd", contractor="union_find")


def _batch(sg, scene, config):
    """segment() over the store's views in the scene's order, with the store's masks, matches and background rule."""
    names = [v.name for v in scene.views]
    stored = sg.scene()
    views = [stored.views[sg.view_names.index(n)] for n in names]
    masks = [sg.view_data(n, masks=True).masks for n in names]
    with per_view_batch(config.seed) as segment:
        from graphseg.scene import Scene

        return segment(Scene(views, name="batch"), masks, batch_matches(names, sg.matches()), config)


def _grow(path, scene, lookup, order, chunks, config):
    sg = SceneGraph.open(path, config)
    reports, i = [], 0
    for size in chunks:
        part = [scene.views[k] for k in order[i : i + size]]
        i += size
        if part:
            reports.append(sg.add(part, segmenter=lookup.segment, matcher=lookup.match))
    return sg, reports


@settings(max_examples=8, deadline=None, phases=[Phase.explicit, Phase.reuse, Phase.generate], suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(order=st.permutations(range(5)), chunks=st.lists(st.integers(1, 3), min_size=5, max_size=5))
def test_any_order_and_batching_gives_the_batch_partition(boxes, order, chunks):
    scene, lookup = boxes
    with tempfile.TemporaryDirectory() as d:
        sg, reports = _grow(Path(d) / "s", scene, lookup, order, chunks, UNION_FIND)
        result = sg.result()
        batch = _batch(sg, scene, UNION_FIND)
        assert sorted(sg.view_names) == sorted(v.name for v in scene.views)
        assert partition(result) == partition(batch)
        assert same_labels(result, batch)
        assert result.num_objects == batch.num_objects
        assert sg.object_ids == sorted(sg.object_ids)


def test_each_add_equals_the_batch_over_the_views_so_far_and_reuses_edges(boxes, tmp_path):
    scene, lookup = boxes
    order = [4, 1, 3, 0, 2]
    sg = SceneGraph.open(tmp_path / "s", UNION_FIND)
    from graphseg.scene import Scene

    for n, k in enumerate(order, 1):
        report = sg.add(scene.views[k], segmenter=lookup.segment, matcher=lookup.match)
        sub = Scene([scene.views[i] for i in sorted(order[:n])])
        assert partition(sg.result()) == partition(_batch(sg, sub, UNION_FIND))
    # the last add reused the mask-graph edges of the pairs of old views and computed only the new pairs'
    assert report.recomputed["stage0/pixel_match"]["reused"] > 0
    assert report.recomputed["stage0/pixel_match"]["computed"] > 0
    assert len(report.matched) == 4  # five views: every pair (pairs.mode auto), four of them new


def test_a_whole_set_rule_is_recomputed_and_still_equals_the_batch(boxes, tmp_path):
    # the paper's 2D rule keeps the 78th percentile of all ratios: it depends on every view,
    # so the store runs it on the whole graph at every add
    scene, lookup = boxes
    cfg = Config.preset("paper", contractor="union_find")
    sg, reports = _grow(tmp_path / "s", scene, lookup, [2, 0, 4, 1, 3], [1, 1, 1, 1, 1], cfg)
    assert reports[-1].recomputed["stage0/pixel_match"]["reused"] == 0
    assert partition(sg.result()) == partition(_batch(sg, scene, cfg))


def test_star_contraction_gives_the_same_partition(boxes, tmp_path):
    # randomised star contraction contracts connected components fully: its partition does not depend on the draw
    scene, lookup = boxes
    cfg = Config.preset("rgbd")
    sg, _ = _grow(tmp_path / "s", scene, lookup, [3, 4, 0, 2, 1], [2, 1, 2, 0, 0], cfg)
    assert partition(sg.result()) == partition(_batch(sg, scene, cfg))


@pytest.mark.data
def test_ycbv_dev_frames_any_order_gives_the_batch_partition(ycbv_root, tmp_path):
    from graphseg.backends.matchers.reprojection import ReprojectionMatcher
    from graphseg.backends.segmenters.oracle_parts import OraclePartsSegmenter
    from graphseg.io import load_scene
    from graphseg.pipeline import lift

    cfg = Config.preset("rgbd", contractor="union_find", background={"ransac_sample": 5000})
    scene = lift(load_scene(ycbv_root / "0001", views=["000001", "000007", "000013", "000019"]), None, cfg)
    seg, match = OraclePartsSegmenter(parts=2), ReprojectionMatcher(num_matches=3000)
    names = [v.name for v in scene.views]
    masks = {v.name: seg(v) for v in scene.views}
    matches = {(names[i], names[j]): match(scene[i], scene[j]) for i in range(4) for j in range(i + 1, 4)}
    lookup = Lookup(masks, matches)
    batch = None
    for n, order in enumerate(([0, 1, 2, 3], [2, 0, 3, 1])):
        sg, _ = _grow(tmp_path / f"s{n}", scene, lookup, order, [1, 1, 1, 1], cfg)
        batch = batch or _batch(sg, scene, cfg)  # the same views, masks and matches whatever the order
        assert partition(sg.result()) == partition(batch)
    assert sg.result().num_objects >= 4  # the four objects of 0001 (fragments may add some)


def test_pairs_the_rule_drops_at_nine_views_lose_their_edges(tmp_path):
    # pairs.mode auto: every pair up to 8 views, close poses only from 9 on
    from graphseg.geometry import scene_scale, select_pairs
    from graphseg.testing.scenes import oracle_part_masks

    scene = box_scene(random_boxes(5, 3), views=10, shape=(40, 54), arc_deg=324, rng=2)
    masks = dict(zip([v.name for v in scene.views], oracle_part_masks(scene, 1, rng=0)))
    cfg = Config.preset("rgbd", contractor="union_find")
    sg = SceneGraph.open(tmp_path / "s", cfg)
    for v in scene.views:
        sg.add(v, segmenter=lambda view: masks[view.name])
    poses = [v.cam_to_world for v in scene.views]
    rule = select_pairs(poses, mode="auto", scale=scene_scale([v.points for v in scene.views], poses))
    names = [v.name for v in scene.views]
    assert sorted(sg.pairs) == sorted((names[i], names[j]) for i, j in rule) and len(rule) < 45
    g = sg.result().graphs[0]
    view_pairs = {tuple(sorted(int(g.node_attr["view"][u]) for u in e)) for e in g.edge_index.T}
    assert view_pairs <= {tuple(p) for p in rule}  # no edge from a dropped pair
    assert partition(sg.result()) == partition(_batch(sg, scene, cfg))
