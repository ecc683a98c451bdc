import json
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from graphseg.audit import (
    audit,
    audit_html,
    format_audit,
    impure_masks,
    lift_edges,
    majority,
    mask_gt_counts,
    min_cut_edges,
    wrong_edges,
)
from graphseg.config import Config
from graphseg.graphs import CorrespondenceGraph, coarsen
from graphseg.method.segment import segment
from graphseg.testing.scenes import two_boxes_scene


def test_mask_gt_counts_shape_and_values():
    masks = [np.array([[1, 1, 2, 0]]), np.array([[1, 1, 1, 1]])]
    gt = [np.array([[1, 2, 2, 2]]), np.array([[0, 0, 1, -1]])]
    c = mask_gt_counts(masks, np.array([0, 0, 1]), np.array([0, 1, 0]), gt)
    assert c.shape == (3, 3)
    assert c.tolist() == [[0, 1, 1], [0, 0, 1], [3, 1, 0]]  # negative gt counts as background


def test_mask_gt_counts_shape_mismatch():
    with pytest.raises(ValueError, match="view 0"):
        mask_gt_counts([np.zeros((2, 2), int)], np.array([0]), np.array([0]), [np.zeros((3, 2), int)])


def test_majority_wrong_impure():
    obj, share = majority(np.array([[0, 6, 4], [0, 0, 0]]))
    assert obj.tolist() == [1, -1] and share.tolist() == [0.6, 0.0]
    assert impure_masks(np.array([[0, 6, 4], [0, 9, 1]])).tolist() == [0]
    assert wrong_edges(np.array([[0, 1], [1, 2]]), np.array([1, 1, -1])).tolist() == []  # unknown ends are not wrong


def test_min_cut_is_the_bridge():
    # two triangles joined by the single edge 2-3
    ei = np.array([[0, 1, 0, 3, 4, 3, 2], [1, 2, 2, 4, 5, 5, 3]])
    assert min_cut_edges(ei, np.array([0]), np.array([5])).tolist() == [6]
    assert min_cut_edges(ei[:, :6], np.array([0]), np.array([5])).size == 0  # not connected
    assert min_cut_edges(ei, np.array([0]), np.array([0])).size == 0


def fake_run():
    """Four masks in two views over two objects; one wrong edge merges them."""
    masks = [np.array([[1, 1, 2, 2]]), np.array([[1, 1, 2, 2]])]
    gt = [np.array([[1, 1, 2, 2]]), np.array([[1, 1, 2, 2]])]
    g = CorrespondenceGraph.from_masks(masks)
    ei = np.array([[0, 1, 0], [2, 3, 3]])  # 0-2 right, 1-3 right, 0-3 wrong
    g = g.add_edges(ei, {"criterion": np.array(["pixel_match"] * 3), "weight": np.array([0.9, 0.8, 0.4]), "stage": np.zeros(3, np.int64)})
    cluster = np.zeros(4, np.int64)
    g1 = coarsen(g, cluster)
    result = SimpleNamespace(graphs=[g, g1], mask_view=np.array([0, 0, 1, 1]), mask_id=np.array([0, 1, 0, 1]), mask_object=np.ones(4, np.int64))
    scene = SimpleNamespace(views=[SimpleNamespace(instances=x) for x in gt], objects={1: "box", 2: "can"})
    return result, scene


def test_audit_finds_the_wrong_edge_and_its_cut():
    result, scene = fake_run()
    rep = audit(result, scene)
    json.dumps(rep)
    assert rep["summary"]["wrong_edges"] == [1, 0] and rep["summary"]["merge_errors"] == 1
    assert rep["stages"][0]["wrong_edges"][0]["objects"] == ["box", "can"]
    (merge,) = rep["merge_errors"]
    assert merge["gt"] == ["box", "can"] and len(merge["cut"]) == 1 and merge["cut"][0]["edge"] == 2
    assert "merges box and can" in format_audit(rep)
    assert audit_html(rep).startswith("<h2>Edge audit</h2>")


def test_lift_edges_uses_largest_member():
    result, _ = fake_run()
    ei, stage, idx = lift_edges(result.graphs, np.array([1.0, 5.0, 2.0, 2.0]))
    assert ei.shape == (2, 3) and stage.tolist() == [0, 0, 0] and idx.tolist() == [0, 1, 2]


def test_audit_clean_run_and_missing_gt():
    scene, masks, matches = two_boxes_scene()
    rep = audit(segment(scene, masks, matches), scene)
    assert rep["summary"]["merge_errors"] == 0 and rep["summary"]["wrong_edges"] == [0, 0]
    bare = SimpleNamespace(views=[SimpleNamespace(instances=None)])
    with pytest.raises(ValueError, match="ground-truth"):
        audit(segment(scene, masks, matches), bare)


def test_cannot_links_are_not_wrong_edges():
    result, scene = fake_run()
    g = result.graphs[0].add_edges(np.array([[0, 0], [1, 2]]), {"criterion": np.array(["depth_repulsion"] * 2), "sign": -np.ones(2), "stage": np.zeros(2, np.int64)})
    result.graphs = [g, result.graphs[1]]
    st = audit(result, scene)["stages"][0]
    assert st["wrong"] == 1 and st["cannot_links"] == 2 and st["wrong_cannot_links"] == 1  # 0-2 is one object


def test_majority_grouping_is_the_perfect_graph_score():
    """The majority grouping scores what a graph that gets every mask right would score."""
    from graphseg.metrics import evaluate, mean_iou

    scene, masks, matches = two_boxes_scene()
    gt = [v.instances for v in scene.views]
    pts = [v.points for v in scene.views]
    r = segment(scene, masks, matches)
    rep = audit(r, scene)
    assert rep["summary"]["majority_grouping_iou"] == pytest.approx(evaluate(r.labels, gt, pts)["mean"]["iou"], abs=1e-4)  # this run is perfect
    assert "majority object" in format_audit(rep) and "majority object" in audit_html(rep)
    # a run that merged the two boxes scores below it
    merged = segment(scene, masks, matches, Config(stages=[[{"pixel_match": {"tau": 0.0, "min_matches": 1}}], [{"chamfer_3d": {"tau": 1e3}}]]))
    assert merged.num_objects == 1
    assert mean_iou(merged.labels, gt, pts) < audit(merged, scene)["summary"]["majority_grouping_iou"] - 0.2


def test_wrong_edges_by_criterion_read_as_text_in_html_and_terminal():
    from graphseg.audit import format_by_criterion

    rep: dict[str, Any] = {
        "summary": {"masks": 4, "impure_masks": 0, "edges": [5, 2], "wrong_edges": [4, 0], "merge_errors": 0, "cut_edges": 0},
        "stages": [
            {"stage": 0, "edges": 5, "wrong": 4, "wrong_by_criterion": {"pixel_match": 3, "chamfer_3d": 1}},
            {"stage": 1, "edges": 2, "wrong": 0, "wrong_by_criterion": {}},
        ],
        "merge_errors": [],
        "impure_masks": [],
    }
    page = audit_html(rep)
    assert "<td>pixel_match: 3, chamfer_3d: 1</td>" in page and "<td>-</td>" in page
    assert "{" not in page and "&#x27;" not in page  # no Python dict
    text = format_audit(rep)
    assert "  stage 0: 4 of 5 edges join different objects (pixel_match: 3, chamfer_3d: 1)" in text.splitlines()
    assert "  stage 1: 0 of 2 edges join different objects" in text.splitlines()  # nothing to list: no brackets
    assert format_by_criterion({"a<b": 1}) == "a<b: 1" and "a&lt;b: 1" in audit_html({**rep, "stages": [{**rep["stages"][0], "wrong_by_criterion": {"a<b": 1}}]})
    assert format_by_criterion(None, empty="-") == "-"


def _one_view_result(labels, masks, background=None):
    """A minimal result: one view, its final labels and its composed masks (mask_id + 1 per pixel)."""
    m = np.asarray(masks)
    ids = np.unique(m[m > 0]) - 1
    g = SimpleNamespace(masks=[m], members={"node": np.arange(ids.size), "view": np.zeros(ids.size, np.int64), "mask_id": ids.astype(np.int64)})
    return SimpleNamespace(labels=[np.asarray(labels)], graphs=[g], background=background)


def test_loss_breakdown_by_hand():
    """Two objects of 3 pixels; one object pixel without a point, one in the background, one dropped."""
    from graphseg.audit import loss_breakdown

    gt = np.array([[1, 1, 1, 2, 2, 2, 0, 0]])
    pts = np.zeros((1, 8, 3))
    pts[0, 0] = np.nan  # object 1: no point
    masks = np.array([[0, 1, 1, 2, 2, 3, 3, 0]])  # mask 0 on object 1, mask 1 on object 2, mask 2 straddles 2 / table
    labels = np.array([[0, 5, 0, 7, 7, 0, 0, 0]])  # object of mask 0 partly dropped; mask 2's object dropped
    bg = np.zeros((1, 8), bool)
    bg[0, 2] = True  # object 1's third pixel: background class
    r = _one_view_result(labels, masks, [bg])
    b = loss_breakdown(r, [gt], [pts])
    assert b["pixels"] == pytest.approx({"no_point": 1 / 6, "background": 1 / 6, "no_mask": 0.0, "dropped": 1 / 6, "labelled": 3 / 6})
    assert sum(b["pixels"].values()) == pytest.approx(1.0)
    # IoU on pixels with a point: object 1 -> {1} of {1, 2} = 0.5; object 2 -> {3, 4} of {3, 4, 5} = 2/3
    assert b["iou"] == pytest.approx((1 / 2 + 2 / 3) / 2)
    # each final object is already on one object: the mapping changes nothing
    assert b["objects_majority"] == pytest.approx(b["iou"])
    # majority masks: mask 0 -> object 1 (pixels 1, 2), mask 1 -> object 2, mask 2 ties object 2 / table and takes the table
    assert b["masks_majority"] == pytest.approx((1.0 + 2 / 3) / 2)
    # no point anywhere in a view: every object pixel is "no_point"
    none = loss_breakdown(r, [gt], [np.full((1, 8, 3), np.nan)], eval_points=[pts])
    assert none["pixels"]["no_point"] == 1.0 and none["iou"] == b["iou"]


def test_loss_breakdown_pieces_and_errors():
    """Pieces of one object cost IoU that the objects-majority mapping gives back; bad inputs name the field."""
    from graphseg.audit import loss_breakdown

    gt = np.array([[1, 1, 1, 1, 0, 0]])
    pts = np.zeros((1, 6, 3))
    masks = np.array([[1, 1, 2, 2, 0, 0]])
    r = _one_view_result(np.array([[3, 3, 4, 4, 0, 0]]), masks)  # one object in two pieces
    b = loss_breakdown(r, [gt], [pts])
    assert b["iou"] == pytest.approx(0.5) and b["objects_majority"] == pytest.approx(1.0) and b["masks_majority"] == pytest.approx(1.0)
    with pytest.raises(ValueError, match="instances and points"):
        loss_breakdown(r, [gt, gt], [pts])
    with pytest.raises(ValueError, match="eval_points for the run's 1 views"):
        loss_breakdown(r, [gt], [pts], eval_points=[pts, pts])
    with pytest.raises(ValueError, match="view 0: eval_points are"):
        loss_breakdown(r, [gt], [pts], eval_points=[pts[:, :4]])
    with pytest.raises(ValueError, match="view 0: points are"):
        loss_breakdown(r, [gt], [pts[:, :4]])
    with pytest.raises(ValueError, match="ground truth is"):
        loss_breakdown(r, [gt[:, :4]], [pts[:, :4]])
    r.graphs[0].masks = None
    with pytest.raises(ValueError, match="no mask images"):
        loss_breakdown(r, [gt], [pts])


def test_loss_breakdown_no_mask_table_majority_and_negative_ids():
    """A pixel with a point outside every mask counts as no_mask; an object lying mostly on the table still maps to
    the ground-truth object it covers; negative ground-truth ids are background."""
    from graphseg.audit import loss_breakdown

    gt = np.array([[1, 1, 1, 0, 0, 0, -1]])
    pts = np.zeros((1, 7, 3))
    masks = np.array([[0, 1, 1, 1, 1, 1, 1]])  # object pixel 0 lies in no mask
    r = _one_view_result(np.array([[0, 4, 4, 4, 4, 4, 4]]), masks)  # one object: 2 object pixels, 4 table pixels
    b = loss_breakdown(r, [gt], [pts])
    assert b["pixels"]["no_mask"] == pytest.approx(1 / 3) and b["pixels"]["labelled"] == pytest.approx(2 / 3)
    assert b["iou"] == pytest.approx(2 / 7)  # -1 counts as background, not as a second class
    assert b["objects_majority"] == pytest.approx(b["iou"])  # mapped to object 1, not dropped for its table majority
    # a perfect run with a negative ground-truth id scores 1
    perfect = _one_view_result(np.array([[1, 1, 1, 0, 0, 0, 0]]), np.array([[1, 1, 1, 0, 0, 0, 0]]))
    p = loss_breakdown(perfect, [gt], [pts])
    assert p["iou"] == p["objects_majority"] == p["masks_majority"] == pytest.approx(1.0)
