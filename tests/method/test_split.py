import numpy as np
import pytest
from scipy.sparse import csr_matrix

from graphseg.config import Config, SplitConfig
from graphseg.method import segment
from graphseg.method.masks import majority_objects
from graphseg.method.split import (
    convexity_graph,
    merge_objects,
    normalized_cut,
    settle_parts,
    split_objects,
    voxelize,
)
from graphseg.metrics import evaluate
from graphseg.sim.boxes import Box
from graphseg.testing.scenes import box_scene, exact_matches

EYE = np.array([[1.0, 0, 0, 0.05], [0, 1, 0, 0], [0, 0, 1, 0.8], [0, 0, 0, 1]])  # a camera 0.8 m above the table


def dome(cx, r=0.05, step=0.003):
    """The upper half of a sphere of radius r at (cx, 0, 0), sampled on a grid seen from above."""
    g = np.arange(-r, r + 1e-9, step)
    x, y = np.meshgrid(g, g)
    k = x**2 + y**2 <= r * r
    return np.c_[cx + x[k], y[k], np.sqrt(r * r - x[k] ** 2 - y[k] ** 2)]


def test_voxelize_shapes_means_and_edge_cases():
    pts = np.array([[0.0, 0, 0], [0.004, 0.002, 0], [0.011, 0, 0], [-0.001, 0, 0]])
    c, inv, n = voxelize(pts, 0.01)
    assert c.shape == (3, 3) and inv.shape == (4,) and n.tolist() == [1, 2, 1]
    assert inv.tolist() == [1, 1, 2, 0]  # -0.001 falls in the voxel below 0
    assert np.allclose(c[1], [0.002, 0.001, 0]) and np.allclose(c[2], [0.011, 0, 0])
    c, inv, n = voxelize(np.zeros((0, 3)), 0.01)
    assert c.shape == (0, 3) and inv.size == n.size == 0
    with pytest.raises(ValueError, match=r"shape \[N, 3\] \(got \[4, 2\]\)"):
        voxelize(pts[:, :2], 0.01)
    with pytest.raises(ValueError, match="voxel_size > 0"):
        voxelize(pts, 0.0)


def fold(sign):
    """Two 45-degree faces meeting along the y axis: a valley (sign -1) or a ridge (+1), seen from above."""
    g = np.arange(-0.05, 0.05 + 1e-9, 0.005)
    x, y = np.meshgrid(g, g)
    return np.c_[x.ravel(), y.ravel(), sign * -np.abs(x.ravel())]


def test_convexity_graph_weakens_links_across_a_concave_crease_only():
    for sign, expected in ((-1, 0.1), (1, 1.0)):  # valley: concave; ridge: convex
        X = fold(sign)
        W = convexity_graph(X, np.tile([0.0, 0, 1.0], (len(X), 1)), radius=0.0115, normal_neighbors=5, concave_weight=0.1)
        assert W.shape == (len(X), len(X)) and (W != W.T).nnz == 0
        a, b = W.nonzero()
        across = (X[a, 0] < -0.004) & (X[b, 0] > 0.004)  # links from one face to the other (5 neighbours fit each face's own plane)
        assert across.any() and np.allclose(np.asarray(W[a[across], b[across]]).ravel(), expected)
        flat = (X[a, 0] < -0.02) & (X[b, 0] < -0.02)
        assert np.allclose(np.asarray(W[a[flat], b[flat]]).ravel(), 1.0)  # inside one face: always full


def test_convexity_graph_edge_cases():
    assert convexity_graph(np.zeros((1, 3)), np.ones((1, 3)), radius=0.1).shape == (1, 1)
    far = np.array([[0.0, 0, 0], [1.0, 0, 0], [2.0, 0, 0]])
    assert convexity_graph(far, np.tile([0, 0, 1.0], (3, 1)), radius=0.5, normal_neighbors=3).nnz == 0  # nothing within reach


def test_normalized_cut_two_cliques_by_hand():
    A = np.ones((4, 4)) - np.eye(4)
    W = np.kron(np.eye(2), A)
    W[3, 4] = W[4, 3] = 0.1
    side, nc = normalized_cut(csr_matrix(W), min_size=2, rng=0)
    assert side.shape == (8,) and {int(side[:4].sum()), int(side[4:].sum())} == {0, 4}
    vol = 12 + 0.1  # each clique: 4 nodes of degree 3, plus the link
    assert nc == pytest.approx(0.1 / vol * 2)
    side, nc = normalized_cut(csr_matrix(W), min_size=5, rng=0)  # no cut leaves 5 on both sides
    assert not side.any() and nc == float("inf")
    W[0] = W[:, 0] = 0  # an isolated node: not a connected graph
    assert normalized_cut(csr_matrix(W), rng=0)[1] == float("inf")


def test_split_objects_two_domes_in_two_views():
    two = np.r_[dome(0.0), dome(0.1)]
    lab = np.ones((1, len(two)), np.int32)
    lab2 = np.full((1, len(two)), 5, np.int32)  # another object id in view 1 (ids may have gaps)
    lab2[0, :10] = 0
    views = [lab, np.r_[lab2]]
    out, info = split_objects([lab, np.where(lab2 == 5, 1, 0).astype(np.int32)], [two[None], two[None]], [(None, EYE)] * 2, rng=0)
    assert [o.shape for o in out] == [(1, len(two))] * 2 and info["num_objects"] == 2
    n = len(dome(0.0))
    for o in out:  # both views: the same two ids, one per dome (the cut may wander by a voxel or two at the contact)
        assert np.mean(o[0, 10:n] == 1) > 0.97 and np.mean(o[0, n:] == 2) > 0.97
    assert np.array_equal(out[0][0, 10:], out[1][0, 10:])
    assert out[1][0, :10].tolist() == [0] * 10
    assert views[0].max() == 1  # inputs untouched
    again, _ = split_objects([lab, np.where(lab2 == 5, 1, 0).astype(np.int32)], [two[None], two[None]], [(None, EYE)] * 2, rng=0)
    assert all(np.array_equal(a, b) for a, b in zip(out, again))


def test_split_objects_keeps_one_body_and_skips_views_without_a_camera():
    one = dome(0.0)
    lab = np.ones((1, len(one)), np.int32)
    out, info = split_objects([lab], [one[None]], [(None, EYE)], rng=0)
    assert out[0].tolist() == lab.tolist() and info["objects"][0]["parts"] == 1
    two = np.r_[dome(0.0), dome(0.1)]
    lab = np.ones((1, len(two)), np.int32)
    out, info = split_objects([lab], [two[None]], [(None, None)], rng=0)  # no camera: nothing to orient normals by
    assert out[0].tolist() == lab.tolist() and info == {"objects": [], "num_objects": 1, "first_new": 2, "settled": 0}
    nan = np.full((1, 4, 3), np.nan)
    out, info = split_objects([np.ones((1, 4), np.int32)], [nan], [(None, EYE)])  # no points
    assert out[0].tolist() == [[1, 1, 1, 1]] and info["objects"] == []
    with pytest.raises(ValueError, match="same views"):
        split_objects([lab], [], [])


def test_majority_objects():
    masks = [np.array([[1, 1, 1, 2, 2, 3]]), np.array([[1, 1]])]
    labels = [np.array([[4, 4, 7, 7, 7, 0]]), np.array([[0, 0]])]
    view, mid = np.array([0, 0, 0, 1]), np.array([0, 1, 2, 0])
    out = majority_objects(masks, labels, view, mid, np.array([4, 0, 4, 4]))
    assert out.tolist() == [4, 0, 4, 4]  # mask 1 stays dropped; masks without labelled pixels keep theirs
    assert majority_objects(masks, labels, view, mid, np.array([4, 4, 4, 4])).tolist() == [4, 7, 4, 4]


TOUCHING = (  # two boxes side by side, touching along x = 0; the front faces are 2 cm apart (coplanar ones would not split)
    Box((-0.05, 0.0, 0.05), (0.10, 0.10, 0.10), yaw=0.0, color=(200, 60, 60)),
    Box((0.045, 0.03, 0.035), (0.09, 0.12, 0.07), yaw=0.0, color=(60, 90, 200)),
)


def test_segment_with_split_separates_touching_boxes_joined_by_straddling_masks():
    scene = box_scene(TOUCHING, views=3, shape=(240, 320), arc_deg=50.0)
    masks = [[v.instances > 0] for v in scene.views]  # one mask over both boxes in every view
    matches = exact_matches(scene)
    gt, pts = [v.instances for v in scene.views], [v.points for v in scene.views]
    rgbd = Config.preset("rgbd").to_dict()
    assert "split" in Config().step_names() and "split" not in Config.preset("paper").step_names()  # in the default method, not in the paper's
    plain = segment(scene, masks, matches, Config.model_validate({**rgbd, "split": {"enabled": False}}))
    assert plain.num_objects == 1
    guarded = segment(scene, masks, matches, Config.model_validate({**rgbd, "split": {"enabled": True, "own_fraction": 0.8}}))
    assert guarded.num_objects == 1  # no mask lies in one box only: with the mask guard the cut is undone
    res = segment(scene, masks, matches, Config.preset("rgbd"))
    m = evaluate(res.labels, gt, pts)
    assert res.num_objects == 2 and m["mean"]["iou"] > 0.95, m["mean"]
    assert "split" in res.info["timings"] and [e["parts"] for e in res.info["split"]["objects"]] == [2]
    assert res.mask_object.tolist() == [1, 1, 1]  # each straddling mask keeps the object with most of its pixels
    assert sorted(np.unique(res.graphs[-1].node_attr["object"]).tolist()) == [1]


def test_the_mask_guard_keeps_only_parts_that_masks_of_their_own_cover():
    two = np.r_[dome(0.0), dome(0.1)]
    n = len(dome(0.0))
    lab = [np.ones((1, len(two)), np.int32)]
    own = np.where(np.arange(len(two)) < n, 1, 2)[None]  # one mask per dome
    across = np.ones((1, len(two)), np.int32)  # one mask over both
    out, _ = split_objects(lab, [two[None]], [(None, EYE)], SplitConfig(own_fraction=0.8), masks=[own], rng=0)
    assert np.unique(out[0]).tolist() == [1, 2]
    out, info = split_objects(lab, [two[None]], [(None, EYE)], SplitConfig(own_fraction=0.8), masks=[across], rng=0)
    assert np.unique(out[0]).tolist() == [1] and info["objects"][0]["parts"] == 1
    idx = np.arange(len(two))
    half = np.where(idx < n // 3, 1, np.where(idx < n + n // 4, 3, 2))[None]  # mask 3 straddles: dome 0 is one third its own
    out, _ = split_objects(lab, [two[None]], [(None, EYE)], SplitConfig(own_fraction=0.8, own_cover=0.5), masks=[half], rng=0)
    assert np.unique(out[0]).tolist() == [1]
    out, _ = split_objects(lab, [two[None]], [(None, EYE)], SplitConfig(own_fraction=0.8, own_cover=0.3), masks=[half], rng=0)
    assert np.unique(out[0]).tolist() == [1, 2]


def test_split_config_is_validated_and_on_in_the_presets_only():
    from pydantic import ValidationError

    from graphseg.config import validation_message

    assert ["split" in Config.preset(p).step_names() for p in ("rgbd", "robust", "multicut", "paper")] == [True, True, True, False]
    for bad, field in (({"max_ncut": -1}, "max_ncut"), ({"min_voxels": 0}, "min_voxels"), ({"own_fraction": 1.5}, "own_fraction"), ({"merge_ncut": -1}, "merge_ncut")):
        with pytest.raises(ValidationError) as err:
            Config.model_validate({"split": bad})
        assert validation_message(err.value, Config).startswith(f"split.{field}: "), validation_message(err.value, Config)


def test_a_fine_grid_not_below_the_split_grid_means_one_pass(tmp_path):
    """Resolved when the split runs, not in the config: a config that sets a coarse voxel_size
    only, from a file over a preset or in lifted.split, loads and runs one pass."""
    scene = box_scene(TOUCHING, views=3, shape=(240, 320), arc_deg=50.0)
    masks = [[v.instances == 1, v.instances == 2] for v in scene.views]
    assert Config.preset("rgbd").split.fine_voxel_size == 0.005
    (tmp_path / "c.yaml").write_text("split:\n  voxel_size: 0.004\n")
    cfg = Config.load(tmp_path / "c.yaml", base=Config.preset("rgbd"))
    assert cfg.split.voxel_size == 0.004 and cfg.split.fine_voxel_size == 0.005  # kept as given
    res = segment(scene, masks, exact_matches(scene), cfg)
    assert res.info["split"]["fine_voxel_size"] is None and "fine_objects" not in res.info["split"]
    lifted = Config.preset("rgbd", lifted={"split": {"voxel_size": 0.004}}).for_lifter("sfm").split
    assert lifted.voxel_size == 0.004 and lifted.fine_voxel_size == 0.005
    assert Config.model_validate(cfg.to_dict()) == cfg


def test_the_fine_grid_parts_objects_the_split_grid_keeps_whole_where_the_masks_own_the_parts():
    """Two touching boxes joined by view 0's mask, which covers both; views 1 and 2 have a mask per box.
    A 12 mm grid finds no cut; the 6 mm pass does, and the masks of views 1 and 2 own its parts."""
    scene = box_scene(TOUCHING, views=3, shape=(240, 320), arc_deg=50.0)
    matches, gt, pts = exact_matches(scene), [v.instances for v in scene.views], [v.points for v in scene.views]
    v = scene.views
    masks = [[v[0].instances > 0]] + [[w.instances == 1, w.instances == 2] for w in v[1:]]
    coarse = {"voxel_size": 0.012, "min_voxels": 50, "merge_ncut": None}
    one = segment(scene, masks, matches, Config.preset("rgbd", split={**coarse, "fine_voxel_size": None}))
    assert one.num_objects == 1 and [e["parts"] for e in one.info["split"]["objects"]] == [1]
    res = segment(scene, masks, matches, Config.preset("rgbd", split={**coarse, "fine_voxel_size": 0.006}))
    assert res.num_objects == 2 and [e["parts"] for e in res.info["split"]["fine_objects"]] == [2]
    assert res.info["split"]["fine_voxel_size"] == 0.006 and res.info["split"]["fine_first_new"] == 2
    assert evaluate(res.labels, gt, pts)["mean"]["iou"] > 0.95
    assert res.mask_object.tolist() == [1, 1, 2, 1, 2] and max(int(lab.max()) for lab in res.labels) == 2
    assert res.object_points.num_nodes == 2
    across = [[w.instances > 0] for w in v]  # every mask covers both boxes: no mask owns a part
    guarded = segment(scene, across, matches, Config.preset("rgbd", split={**coarse, "fine_voxel_size": 0.006}))
    assert guarded.num_objects == 1
    unguarded = segment(scene, across, matches, Config.preset("rgbd", split={**coarse, "fine_voxel_size": 0.006, "fine_own_fraction": 0.01}))
    assert unguarded.num_objects == 2  # the cut exists on the fine grid; only the guard keeps it from standing


def test_segment_splits_again_on_the_fine_grid_where_the_masks_own_the_parts(monkeypatch):
    """The second pass: the fine grid, parts of the same area (200 voxels of 6 mm = 288 of 5 mm), the view masks as guard."""
    import sys

    seg_mod = sys.modules["graphseg.method.operations"]  # the graph operations after the last contraction
    scene = box_scene(TOUCHING, views=3, shape=(240, 320), arc_deg=50.0)
    masks = [[v.instances == 1, v.instances == 2] for v in scene.views]  # pure masks, one per box
    matches = exact_matches(scene)
    calls = []
    real = seg_mod.split_objects
    monkeypatch.setattr(seg_mod, "split_objects", lambda *a, **k: calls.append((a[3], k)) or real(*a, **k))
    res = segment(scene, masks, matches, Config.preset("rgbd"))
    assert [(o.voxel_size, o.min_voxels, k["masks"] is not None, o.own_fraction) for o, k in calls] == [(0.006, 200, False, None), (0.005, 288, True, 0.8)]
    assert calls[1][1]["num_objects"] == 2 and [e["parts"] for e in res.info["split"]["fine_objects"]] == [1, 1]
    calls.clear()
    one = segment(scene, masks, matches, Config.preset("rgbd", split={"fine_voxel_size": None}))
    assert len(calls) == 1 and "fine_objects" not in one.info["split"]
    assert np.array_equal(np.stack(one.labels), np.stack(res.labels))  # two pure boxes: nothing left for the fine grid to cut


def test_a_zero_concave_weight_removes_the_links_and_still_splits():
    two = np.r_[dome(0.0), dome(0.1)]
    lab = [np.ones((1, len(two)), np.int32)]
    out, info = split_objects(lab, [two[None]], [(None, EYE)], SplitConfig(concave_weight=0.0), rng=0)
    assert np.unique(out[0]).tolist() == [1, 2]
    out, info = split_objects(lab, [two[None]], [(None, EYE)], num_objects=6, rng=0)  # ids in use beyond the labels' largest
    assert np.unique(out[0]).tolist() == [1, 7] and info["first_new"] == 7 and info["num_objects"] == 7


def test_graph_nodes_take_the_object_with_most_pixels_after_a_split():
    scene = box_scene(TOUCHING, views=3, shape=(240, 320), arc_deg=50.0)
    per_box = [[(v.instances == k) for k in (1, 2)] for v in scene.views]
    masks = [per_box[0], [scene.views[1].instances > 0], per_box[2]]  # views 0 and 2: one mask per box; view 1: one over both
    res = segment(scene, masks, exact_matches(scene), Config.preset("rgbd"))
    assert res.num_objects == 2
    area = np.array([int(np.sum(masks[v][m])) for v, m in zip(res.mask_view, res.mask_id)])
    for g in res.graphs:
        node = np.asarray(g.members["node"])
        for n in range(g.num_nodes):
            own = node == n
            votes = np.bincount(res.mask_object[own], weights=area[own], minlength=res.num_objects + 1)
            assert g.node_attr["object"][n] == votes.argmax()  # the node's object: most of its masks' pixels
    mixed = [n for g in res.graphs for n in range(g.num_nodes) if len(set(res.mask_object[np.asarray(g.members["node"]) == n].tolist())) > 1]
    assert mixed  # the case of interest happens: one node, masks of two objects


def test_merge_objects_joins_the_halves_of_one_dome_and_closes_the_id_gap():
    one, other = dome(0.0), dome(0.2)  # the second dome is far away: never within reach
    pts = np.r_[one, other]
    n = len(one)
    lab = np.where(np.arange(len(pts)) < n, np.where(pts[:, 1] < 0, 1, 3), 2).astype(np.int32)[None]  # dome 0 as objects 1 and 3
    out, info = merge_objects([lab], [pts[None]], [(None, EYE)], SplitConfig(min_voxels=100), rng=0)
    assert out[0].shape == lab.shape and out[0].dtype == lab.dtype
    assert [m["ids"] for m in info["merges"]] == [[1, 3]] and info["merges"][0]["ncut"] > 0.05  # a dome's halves: far above 0.022
    assert info["mapping"].tolist() == [0, 1, 2, 1] and info["num_objects"] == 2
    assert out[0][0, :n].tolist() == [1] * n and out[0][0, n:].tolist() == [2] * len(other)
    assert lab.max() == 3  # input untouched
    again, _ = merge_objects([lab], [pts[None]], [(None, EYE)], SplitConfig(min_voxels=100), rng=0)
    assert np.array_equal(again[0], out[0])
    out, info = merge_objects([lab], [pts[None]], [(None, EYE)], SplitConfig(merge_ncut=None, min_voxels=100), rng=0)  # never join
    assert info["merges"] == [] and out[0].tolist() == lab.tolist() and out[0] is not lab


def test_merge_objects_joins_a_chain_of_pieces_in_order_and_renames_every_view():
    one = dome(0.0)
    ang = np.arctan2(one[:, 1], one[:, 0])
    thirds = np.digitize(ang, [-np.pi / 3, np.pi / 3])  # three wedges of one dome
    lab = np.array([2, 5, 7])[thirds].astype(np.int64)[None]  # ids with gaps
    blind = np.full((1, 4), 7, np.int64)  # a view without a camera: not measured, still renamed
    out, info = merge_objects([lab, blind], [one[None], np.zeros((1, 4, 3))], [(None, EYE), (None, None)], SplitConfig(min_voxels=100), rng=0)
    assert len(info["merges"]) == 2 and np.unique(out[0]).tolist() == [2]
    assert info["mapping"].tolist() == [0, 1, 2, 3, 4, 2, 5, 2] and info["num_objects"] == 5  # 6 (unused) moves down past the freed 5
    assert out[1].tolist() == [[2, 2, 2, 2]] and out[1].dtype == np.int64


def test_merge_objects_joins_one_surface_seen_under_two_ids():
    one = dome(0.0)
    views = [np.ones((1, len(one)), np.int32), np.full((1, len(one)), 2, np.int32)]  # the same points, another id in view 1
    out, info = merge_objects(views, [one[None], one[None]], [(None, EYE)] * 2, SplitConfig(min_voxels=100), rng=0)
    assert [m["ids"] for m in info["merges"]] == [[1, 2]] and [np.unique(o).tolist() for o in out] == [[1], [1]]


def test_merge_objects_keeps_two_touching_domes_apart():
    two = np.r_[dome(0.0), dome(0.1)]
    n = len(dome(0.0))
    lab = np.where(np.arange(len(two)) < n, 1, 2).astype(np.int32)[None]
    out, info = merge_objects([lab], [two[None]], [(None, EYE)], SplitConfig(min_voxels=100), rng=0)
    assert info["merges"] == [] and out[0].tolist() == lab.tolist()
    _, info = merge_objects([lab], [two[None]], [(None, EYE)], SplitConfig(merge_ncut=0.0, min_voxels=100), rng=0)  # join anyway, to read the cost
    assert info["merges"][0]["ncut"] < 0.012  # the crease between them: a cut the split would make


def test_merge_objects_edge_cases():
    one = dome(0.0)
    lab = np.where(one[:, 1] < 0, 1, 2).astype(np.int32)[None]
    out, info = merge_objects([lab], [one[None]], [(None, None)], rng=0)  # no camera: nothing measured
    assert info["merges"] == [] and out[0].tolist() == lab.tolist()
    out, info = merge_objects([np.ones((1, 4), np.int32)], [np.full((1, 4, 3), np.nan)], [(None, EYE)])  # no points
    assert info == {"merges": [], "mapping": info["mapping"], "num_objects": 1} and info["mapping"].tolist() == [0, 1]
    out, info = merge_objects([np.array([[1, 2, 2, 0]], np.int32)], [np.full((1, 4, 3), np.nan)], [(None, EYE)])  # two ids, no points
    assert info["merges"] == [] and out[0].tolist() == [[1, 2, 2, 0]]
    small = np.where(one[:, 1] < -0.045, 2, 1).astype(np.int32)[None]  # object 2 has fewer than min_voxels voxels: left alone
    assert merge_objects([small], [one[None]], [(None, EYE)], SplitConfig(min_voxels=100), rng=0)[1]["merges"] == []
    out, info = merge_objects([lab], [one[None]], [(None, EYE)], SplitConfig(min_voxels=100), num_objects=4, rng=0)  # ids beyond the labels' largest move down too
    assert info["mapping"].tolist() == [0, 1, 1, 2, 3] and info["num_objects"] == 3
    neg = np.where(np.arange(len(one)) < 5, -1, lab[0]).astype(np.int32)[None]  # labels <= 0 are kept
    out, _ = merge_objects([neg], [one[None]], [(None, EYE)], SplitConfig(min_voxels=100), rng=0)
    assert out[0][0, :5].tolist() == [-1] * 5 and np.unique(out[0][0, 5:]).tolist() == [1]
    with pytest.raises(ValueError, match="same views"):
        merge_objects([lab], [], [])
    with pytest.raises(ValueError, match="min_ncut >= 0"):
        merge_objects([lab], [one[None]], [(None, EYE)], SplitConfig().model_copy(update={"merge_ncut": -1.0}))  # past the config's own check


def test_segment_joins_the_halves_of_a_box_that_no_match_connects():
    box = (Box((0.0, 0.0, 0.05), (0.12, 0.10, 0.10), yaw=0.0, color=(200, 60, 60)),)
    scene = box_scene(box, views=3, shape=(240, 320), arc_deg=50.0)
    halves = [[(v.instances > 0) & (v.points[..., 0] < 0), (v.instances > 0) & (v.points[..., 0] >= 0)] for v in scene.views]
    base = Config.preset("rgbd").to_dict()
    base["stages"] = base["stages"][:1] + base["stages"][2:]  # 2D edges only (and rgbd's graph operations): each half matches itself in the other views, never the other half
    apart = segment(scene, halves, exact_matches(scene), Config.model_validate({**base, "split": {"enabled": True, "merge_ncut": None}}))
    assert apart.num_objects == 2
    res = segment(scene, halves, exact_matches(scene), Config.model_validate(base))
    gt, pts = [v.instances for v in scene.views], [v.points for v in scene.views]
    assert res.num_objects == 1 and evaluate(res.labels, gt, pts)["mean"]["iou"] > 0.97
    assert [m["ids"] for m in res.info["split"]["merges"]] == [[1, 2]] and res.info["split"]["merge_mapping"] == [0, 1, 1]
    assert apart.info["split"]["merge_mapping"] is None and apart.info["split"]["merges"] == []
    assert res.mask_object.tolist() == [1] * 6 and np.unique(res.graphs[-1].node_attr["object"]).tolist() == [1]
    touching = box_scene(TOUCHING, views=3, shape=(240, 320), arc_deg=50.0)
    kept = segment(touching, [[(v.instances == k) for k in (1, 2)] for v in touching.views], exact_matches(touching), Config.preset("rgbd"))
    assert kept.num_objects == 2 and kept.info["split"]["merges"] == []  # two touching boxes are not joined


def test_cut_cost_of_two_cliques_by_hand():
    from graphseg.method.split import _cut_cost

    A = np.ones((4, 4)) - np.eye(4)
    W = np.kron(np.eye(2), A)
    W[3, 4] = W[4, 3] = 0.1
    side = np.arange(8) < 4
    assert _cut_cost(csr_matrix(W), side) == pytest.approx(2 * 0.1 / 12.1)  # the same cut normalized_cut finds
    assert _cut_cost(csr_matrix(W), np.zeros(8, bool)) == float("inf")  # one side empty


def test_segment_gives_masks_the_voxel_border_cut_back_to_their_object(monkeypatch):
    """A split that moves a few pixels of a pure mask into the other box: the snap gives them back."""
    import sys

    seg_mod = sys.modules["graphseg.method.operations"]  # the graph operations after the last contraction
    scene = box_scene(TOUCHING, views=3, shape=(240, 320), arc_deg=50.0)
    masks = [[v.instances == 1, v.instances == 2] for v in scene.views]  # pure masks, one per box
    real = seg_mod.split_objects

    def ragged(*a, **k):  # the real split, then 5% of box 1's pixels in view 0 moved to box 2
        out, info = real(*a, **k)
        lab = out[0].copy()
        rows, cols = np.nonzero(lab == 1)
        lab[rows[::20], cols[::20]] = 2
        return [lab, *out[1:]], info

    monkeypatch.setattr(seg_mod, "split_objects", ragged)
    gt, pts = [v.instances for v in scene.views], [v.points for v in scene.views]
    off = segment(scene, masks, exact_matches(scene), Config.preset("rgbd", split={"snap_share": None}))
    res = segment(scene, masks, exact_matches(scene), Config.preset("rgbd"))  # the other views' masks agree: the pixels go back
    assert off.info["split"]["snapped"] == 0 and res.info["split"]["snapped"] > 0
    assert evaluate(res.labels, gt, pts)["mean"]["iou"] > evaluate(off.labels, gt, pts)["mean"]["iou"]
    box1, box1_off = (r.labels[0][scene.views[0].instances == 1] == 1 for r in (res, off))
    assert res.num_objects == 2 and box1_off.mean() < 0.95 and box1.mean() > 0.98  # back, but for pixels whose voxel only view 0 sees
    assert sorted(set(res.mask_object.tolist())) == [1, 2]
    assert Config.preset("paper").split.snap_share is None and Config().split.snap_share == 0.85  # on in rgbd (the default) only
    assert Config.preset("robust").split.snap_share is None  # it lowered robust on YCB-Video 0002 at 10 views
    with pytest.raises(ValueError, match="snap_share"):
        Config.preset("rgbd", split={"snap_share": 0.5})


def test_a_snap_that_empties_an_object_keeps_masks_and_nodes_on_the_object_that_took_its_pixels(monkeypatch):
    import sys

    seg_mod = sys.modules["graphseg.method.operations"]  # the graph operations after the last contraction
    scene = box_scene(TOUCHING, views=3, shape=(240, 320), arc_deg=50.0)
    masks = [[v.instances == 1, v.instances == 2] for v in scene.views]  # pure masks, one per box
    real = seg_mod.split_objects

    def shuffled(*a, **k):  # a split that gives 90% of box 1 a new id 3 and leaves 10% as 1
        out, info = real(*a, **k)
        new = []
        for lab in out:
            lab = lab.copy()
            rows, cols = np.nonzero(lab == 1)
            moved = np.ones(rows.size, bool)
            moved[::10] = False
            lab[rows[moved], cols[moved]] = 3
            new.append(lab)
        return new, {**info, "num_objects": 3}

    monkeypatch.setattr(seg_mod, "split_objects", shuffled)
    snap = seg_mod.snap_to_masks  # by share alone, so that it empties id 1 even where only one view sees a pixel
    monkeypatch.setattr(seg_mod, "snap_to_masks", lambda *a, points, **k: snap(*a, **k))
    base = {"merge_ncut": None, "fine_voxel_size": None, "mask_join": None}  # the mask join would join 1 and 3 first
    off = segment(scene, masks, exact_matches(scene), Config.preset("rgbd", split={**base, "snap_share": None}))
    assert off.num_objects == 3 and off.mask_object.tolist() == [3, 2] * 3
    res = segment(scene, masks, exact_matches(scene), Config.preset("rgbd", split={**base, "snap_share": 0.85}))
    assert res.num_objects == 2 and res.info["split"]["snapped"] > 0
    assert res.mask_object.tolist() == [2, 1] * 3  # no mask dropped: box 1's masks follow their pixels to id 3, now 2
    assert res.graphs[-1].node_attr["object"].tolist() == [2, 1]
    for v, lab in zip(scene.views, res.labels):
        assert np.unique(lab[v.instances == 1]).tolist() == [2] and np.unique(lab[v.instances == 2]).tolist() == [1]


def _chain(weights):
    """A path graph 0 - 1 - ... - n with the given link weights, as a symmetric csr matrix."""
    w = np.asarray(weights, float)
    a, b = np.arange(w.size), np.arange(1, w.size + 1)
    return csr_matrix((np.r_[w, w], (np.r_[a, b], np.r_[b, a])), shape=(w.size + 1, w.size + 1))


def test_settle_parts_redraws_the_border_on_the_weak_link_by_hand():
    W = _chain([1, 1, 1, 1, 1, 0.1, 1, 1, 1, 1])  # the link 5-6 is a crease
    left, right = np.arange(4), np.arange(4, 11)
    # band 3: voxels 1-6 are drawn again between the anchors 0 and 7; the cheapest cut is the weak link
    parts, moved = settle_parts(W, [left, right], band=3)
    assert [p.tolist() for p in parts] == [[0, 1, 2, 3, 4, 5], [6, 7, 8, 9, 10]] and moved == 2
    assert [p.dtype for p in parts] == [np.int64, np.int64]
    assert left.tolist() == [0, 1, 2, 3] and right.tolist() == list(range(4, 11))  # inputs untouched
    # band 1: only voxels 3 and 4 are drawn, between 2 and 5; every cut there costs one full link
    # (a tie), so both keep their parts
    parts1, moved1 = settle_parts(W, [left, right], band=1)
    assert [p.tolist() for p in parts1] == [[0, 1, 2, 3], [4, 5, 6, 7, 8, 9, 10]] and moved1 == 0
    # already on the weak link: nothing moves
    parts2, moved2 = settle_parts(W, parts, band=3)
    assert [p.tolist() for p in parts2] == [p.tolist() for p in parts] and moved2 == 0


def test_settle_parts_on_a_floor_and_wall_puts_the_border_on_the_crease():
    g = np.arange(-0.06, 0.0001, 0.004)
    ys = np.arange(0.0, 0.05, 0.004)
    floor = np.array([[x, y, 0.0] for x in g for y in ys])
    wall = np.array([[0.0, y, z] for z in np.arange(0.004, 0.061, 0.004) for y in ys])
    pts = np.r_[floor, wall]
    eyes = np.tile([-0.3, 0.02, 0.3], (len(pts), 1))  # a camera that sees the floor and the wall's front face
    W = convexity_graph(pts, eyes, radius=0.009)
    wrong = pts[:, 0] > -0.015  # the cut 1.5 cm into the floor: four columns of floor samples with the wall
    parts, moved = settle_parts(W, [np.flatnonzero(~wrong), np.flatnonzero(wrong)], band=4)
    floor_part = np.isin(np.arange(len(pts)), parts[0])
    on_wall = ~floor_part[: len(floor)]
    assert moved > len(ys) and on_wall.sum() == 4 * len(ys) - moved  # the column at x = -1.2 cm and more come back
    # the border now runs where the links turn weak: the normals, fitted over 20 samples, blend the
    # floor and the wall near the crease, so samples within 1 cm of it may stay with the wall
    assert not on_wall[floor[:, 0] < -0.01].any()
    assert not floor_part[len(floor) :].any()  # the wall stays apart


def test_settle_parts_edge_cases():
    W = _chain([1, 1, 1])
    parts = [np.array([0, 1]), np.array([2, 3])]
    out, moved = settle_parts(W, parts, band=0)
    assert [p.tolist() for p in out] == [[0, 1], [2, 3]] and moved == 0
    out, moved = settle_parts(W, [np.arange(4)], band=2)  # one part: nothing to draw
    assert [p.tolist() for p in out] == [[0, 1, 2, 3]] and moved == 0
    out, moved = settle_parts(W, parts, band=5)  # every voxel in the band: no anchor, nothing moves
    assert [p.tolist() for p in out] == [[0, 1], [2, 3]] and moved == 0
    # three parts in a row: each pair is drawn again; the middle part between two weak links keeps its voxel
    W3 = _chain([1, 1, 0.1, 0.1, 1, 1])
    out, moved = settle_parts(W3, [np.array([0, 1]), np.array([2, 3, 4]), np.array([5, 6])], band=1)
    assert [p.tolist() for p in out] == [[0, 1, 2], [3], [4, 5, 6]] and moved == 2
    with pytest.raises(ValueError, match="band >= 0"):
        settle_parts(W, parts, band=-1)
    with pytest.raises(ValueError, match=r"cover all 4 voxels once \(got 1 without a part, 3 indices\)"):
        settle_parts(W, [np.array([0, 1]), np.array([2])])
    with pytest.raises(ValueError, match=r"cover all 4 voxels once \(got 0 without a part, 5 indices\)"):
        settle_parts(W, [np.array([0, 1, 2]), np.array([2, 3])])  # overlapping parts
    with pytest.raises(ValueError, match=r"part indices in 0..3"):
        settle_parts(W, [np.array([0, 1]), np.array([2, -1])])
    with pytest.raises(TypeError):
        settle_parts(W, parts, band=2.5)  # type: ignore[arg-type]


def test_settle_parts_reads_one_way_links_and_refuses_capacities_beyond_32_bits():
    from scipy.sparse import triu

    W = _chain([1, 1, 1, 1, 1, 0.1, 1, 1, 1, 1])
    parts = [np.arange(4), np.arange(4, 11)]
    both = settle_parts(W, parts, band=3)
    one_way = settle_parts(triu(W).tocsr(), parts, band=3)  # each link stored once
    assert [p.tolist() for p in one_way[0]] == [p.tolist() for p in both[0]] and one_way[1] == both[1] == 2
    with pytest.raises(ValueError, match="fit in 32 bits"):
        settle_parts(_chain([2.2e6] * 5 + [2.2e5] + [2.2e6] * 4), parts, band=3)
    # the boundary of max_ratio: a cut of exactly 0.6 x the present border is drawn at max_ratio 0.6
    W6 = _chain([1, 1, 1, 1, 1, 0.6, 1, 1, 1, 1])
    assert settle_parts(W6, parts, band=3, max_ratio=0.6)[1] == 2 and settle_parts(W6, parts, band=3, max_ratio=0.59)[1] == 0


def test_settle_parts_property_a_partition_that_moves_only_near_a_border():
    from hypothesis import given, settings
    from hypothesis import strategies as st
    from scipy.sparse.csgraph import shortest_path

    @settings(max_examples=60, deadline=None)
    @given(st.integers(2, 25), st.integers(0, 10_000), st.integers(1, 3))
    def check(m, seed, band):
        gen = np.random.default_rng(seed)
        a, b = gen.integers(0, m, 3 * m), gen.integers(0, m, 3 * m)
        keep = a != b
        a, b = a[keep], b[keep]
        w = gen.choice([0.1, 1.0], a.size)
        W = csr_matrix((np.r_[w, w], (np.r_[a, b], np.r_[b, a])), shape=(m, m))
        label = gen.integers(0, 3, m)
        parts = [np.flatnonzero(label == k) for k in range(3)]
        before = [p.copy() for p in parts]
        out, moved = settle_parts(W, parts, band=band)
        assert len(out) == len(parts) and np.sort(np.concatenate(out)).tolist() == list(range(m))  # a partition
        assert all(np.array_equal(p, q) for p, q in zip(parts, before))  # inputs untouched
        new = np.empty(m, np.int64)
        for k, p in enumerate(out):
            new[p] = k
        changed = np.flatnonzero(new != label)
        assert moved == changed.size
        coo = W.tocoo()
        border = np.unique(coo.row[label[coo.row] != label[coo.col]])
        if changed.size:  # only voxels within band - 1 links of a border voxel move (pairs drawn one after another can chain)
            hops = shortest_path(W, unweighted=True, indices=border).min(0)
            assert (hops[changed] <= (band - 1) * 3 + 2).all()
        # no voxel changes to a part it had no link path to within the band
        assert set(np.unique(new).tolist()) <= set(np.unique(label).tolist())

    check()


def test_split_objects_settle_band_is_checked_and_reported():
    two = np.r_[dome(0.0), dome(0.1)]
    lab = np.ones((1, len(two)), np.int32)
    out0, info0 = split_objects([lab], [two[None]], [(None, EYE)], rng=0)
    out, info = split_objects([lab], [two[None]], [(None, EYE)], SplitConfig(settle_band=2), rng=0)
    assert info0["settled"] == 0 and isinstance(info["settled"], int)
    n = len(dome(0.0))
    assert np.mean(out[0][0, :n] == 1) > 0.97 and np.mean(out[0][0, n:] == 2) > 0.97
    assert lab.max() == 1  # input untouched
    with pytest.raises(ValueError, match="settle_band >= 0"):
        split_objects([lab], [two[None]], [(None, EYE)], SplitConfig().model_copy(update={"settle_band": -1}))  # past the config's own check


def test_segment_draws_the_split_border_again_only_when_asked():
    # off in every preset: on the touching boxes below the minimum cut moves box 2's rim to box 1
    # (docs/results.md, round 18)
    assert all(Config.preset(p).split.settle_band == 0 for p in ("rgbd", "robust", "multicut", "paper"))
    scene = box_scene(TOUCHING, views=3, shape=(240, 320), arc_deg=50.0)
    gt = [np.asarray(v.instances) for v in scene.views]
    pts = [np.asarray(v.points) for v in scene.views]
    masks = [[g > 0] for g in gt]  # one mask over both boxes: only the split can part them
    off = segment(scene, masks, exact_matches(scene), Config.preset("rgbd"))
    on = segment(scene, masks, exact_matches(scene), Config.preset("rgbd", split={"settle_band": 3}))
    assert off.info["split"]["settled"] == 0 and on.info["split"]["settled"] > 0
    assert on.num_objects == 2 and evaluate(on.labels, gt, pts)["mean"]["iou"] > 0.95
    changed = np.concatenate([(a != b).ravel() for a, b in zip(off.labels, on.labels)])
    assert 0 < changed.mean() < 0.01  # only pixels at the border between the boxes change
    # max_ratio: the border 3|4 crosses one full link (1000); the cheapest cut, the link 5-6, costs 600
    W = _chain([1, 1, 1, 1, 1, 0.6, 1, 1, 1, 1])
    parts = [np.arange(4), np.arange(4, 11)]
    moved_any = settle_parts(W, parts, band=3)[1]
    kept, moved = settle_parts(W, parts, band=3, max_ratio=0.5)  # 600 > 0.5 x 1000: left where it is
    assert moved_any == 2 and moved == 0 and [p.tolist() for p in kept] == [p.tolist() for p in parts]
    assert settle_parts(_chain([1, 1, 1, 1, 1, 0.1, 1, 1, 1, 1]), parts, band=3, max_ratio=0.5)[1] == 2  # 100 <= 500
    with pytest.raises(ValueError, match="max_ratio >= 0"):
        settle_parts(W, parts, max_ratio=-1.0)
    with pytest.raises(ValueError, match="settle_band"):
        Config.preset("rgbd", split={"settle_band": -1})
