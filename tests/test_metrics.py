import numpy as np
import pytest

from graphseg.metrics import chamfer_distance, contingency, evaluate, f1_score, iou


def line_points(n, x0=0.0):
    p = np.zeros((1, n, 3), np.float32)
    p[0, :, 0] = x0 + np.arange(n) * 0.1
    return p


def test_iou_f1_chamfer_hand_computed():
    assert iou(np.array([1, 1, 1, 0], bool), np.array([0, 1, 1, 1], bool)) == pytest.approx(0.5)
    assert iou(np.zeros(3, bool), np.zeros(3, bool)) == 0.0
    assert f1_score(0.0, 0.0) == 0.0
    assert f1_score(1.0, 0.5) == pytest.approx(2 / 3)
    a = np.array([[0.0, 0, 0], [1, 0, 0]])
    b = np.array([[0.0, 0, 0]])
    # a->b: (0 + 1) / 2 = 0.5 ; b->a: 0  => 0.5
    assert chamfer_distance(a, b) == pytest.approx(0.5)
    assert chamfer_distance(a, np.zeros((0, 3))) == np.inf


def test_contingency_counts():
    gt = [np.array([[1, 1, 2, 0]])]
    pr = [np.array([[3, 0, 3, 3]])]
    t, gids, pids = contingency(pr, gt)
    assert gids.tolist() == [0, 1, 2] and pids.tolist() == [0, 3]
    assert t.tolist() == [[0, 1], [1, 1], [0, 1]]
    with pytest.raises(ValueError, match="differ in shape"):
        contingency([np.zeros((2, 2))], [np.zeros((2, 3))])


def test_evaluate_hand_computed_two_views():
    # view 0: gt [1 1 1 2 2 0], pred [7 7 8 8 8 0]
    # view 1: gt [1 1 0 2 2 2], pred [7 7 0 8 8 0]
    gt = [np.array([[1, 1, 1, 2, 2, 0]]), np.array([[1, 1, 0, 2, 2, 2]])]
    pr = [np.array([[7, 7, 8, 8, 8, 0]]), np.array([[7, 7, 0, 8, 8, 0]])]
    pts = [line_points(6), line_points(6, 10.0)]
    m = evaluate(pr, gt, pts, voxel_size=None)
    o1, o2 = m["objects"]
    # object 1: |G|=5, best pred 7: inter 4, |P|=4 -> IoU 4/5, precision 1, recall 4/5
    assert o1["pred"] == 7 and o1["iou"] == pytest.approx(4 / 5)
    assert o1["precision"] == pytest.approx(1.0) and o1["recall"] == pytest.approx(0.8)
    assert o1["f1"] == pytest.approx(2 * 0.8 / 1.8)
    # object 2: |G|=5, pred 8: |P|=5, inter 4 -> IoU 4/6
    assert o2["pred"] == 8 and o2["iou"] == pytest.approx(4 / 6)
    # chamfer-selected object for gt 1 is pred 7 (its points are a subset)
    assert o1["pred_sel"] == 7 and o1["iou_sel"] == pytest.approx(0.8)
    g1 = np.concatenate([line_points(6)[0, :3], line_points(6, 10.0)[0, :2]])
    p7 = np.concatenate([line_points(6)[0, :2], line_points(6, 10.0)[0, :2]])
    assert o1["chamfer"] == pytest.approx(chamfer_distance(g1, p7))
    # pixel utility: 10 gt object pixels; all 5 of view 0 and 4 of view 1 have a prediction
    assigned = 5 + 4
    assert m["mean"]["pixel_utility"] == pytest.approx(assigned / 10)
    assert m["num_gt"] == 2 and m["num_pred"] == 2
    assert m["mean"]["iou"] == pytest.approx((0.8 + 4 / 6) / 2)


def test_evaluate_ignores_invalid_points_and_handles_no_prediction():
    gt = [np.array([[1, 1, 1]])]
    pr = [np.array([[0, 0, 0]])]
    pts = line_points(3)
    pts[0, 2] = np.nan
    m = evaluate(pr, gt, [pts])
    assert m["objects"][0]["iou"] == 0.0 and m["objects"][0]["pred"] is None
    assert m["objects"][0]["pixels"] == 2
    assert m["mean"]["pixel_utility"] == 0.0 and m["mean"]["chamfer"] is None


def test_evaluate_perfect_prediction():
    gt = [np.array([[1, 2, 2]])]
    m = evaluate([gt[0] * 3], gt, [line_points(3)], names={1: "mug"})
    assert all(o["iou"] == 1.0 and o["chamfer"] == 0.0 for o in m["objects"])
    assert m["objects"][0]["name"] == "mug" and m["mean"]["f1"] == 1.0


def test_mean_iou_matches_evaluate_and_edge_cases():
    from graphseg.metrics import mean_iou

    rng = np.random.default_rng(0)
    gt = [rng.integers(0, 4, (6, 7)) for _ in range(2)]
    pred = [rng.integers(0, 5, (6, 7)) for _ in range(2)]
    pts = [rng.normal(size=(6, 7, 3)) for _ in range(2)]
    pts[0][0, :3] = np.nan  # ignored pixels
    assert mean_iou(pred, gt, pts) == pytest.approx(evaluate(pred, gt, pts)["mean"]["iou"])
    # hand-computed: gt object 1 = 2 px, predicted 7 covers them and 1 more -> 2/3; object 2 unmatched -> 0
    assert mean_iou([np.array([[7, 7, 7, 0]])], [np.array([[1, 1, 0, 2]])], [np.zeros((1, 4, 3))]) == pytest.approx(1 / 3)
    assert mean_iou([np.zeros((1, 2), int)], [np.zeros((1, 2), int)], [np.zeros((1, 2, 3))]) is None  # no object
    assert mean_iou([np.zeros((1, 2), int)], [np.ones((1, 2), int)], [np.zeros((1, 2, 3))]) == 0.0  # nothing predicted


def test_panoptic_quality_hand_computed():
    from graphseg.metrics import panoptic_quality

    t = np.array([[0.8, 0.2, 0.0, 0.0], [0.0, 0.0, 0.5, 0.0], [0.0, 0.0, 0.0, 0.7]])
    q = panoptic_quality(t)  # matches (0, 0) and (2, 3); IoU 0.5 is no match
    assert (q["tp"], q["fp"], q["fn"]) == (2, 2, 1)
    assert q["sq"] == pytest.approx(0.75)
    assert q["rq"] == pytest.approx(2 / (2 + 1 + 0.5))
    assert q["pq"] == pytest.approx(0.75 * 2 / 3.5)
    assert panoptic_quality(np.zeros((0, 0)))["pq"] == 1.0
    assert panoptic_quality(np.zeros((2, 0)))["pq"] == 0.0
    with pytest.raises(ValueError, match=r"\[G, P\]"):
        panoptic_quality(np.zeros(3))


def test_evaluate_counts_phantom_objects():
    """IoU cannot see an extra predicted object that covers only background; PQ and num_pred can."""
    gt = [np.array([[1, 1, 0, 0, 2, 2]])]
    pts = [np.zeros((1, 6, 3), np.float32)]
    clean = evaluate([np.array([[1, 1, 0, 0, 2, 2]])], gt, pts)
    phantom = evaluate([np.array([[1, 1, 3, 4, 2, 2]])], gt, pts)
    assert clean["mean"]["iou"] == phantom["mean"]["iou"] == 1.0
    assert (clean["num_pred"], phantom["num_pred"], phantom["num_gt"]) == (2, 4, 2)
    assert clean["mean"]["pq"] == 1.0
    assert phantom["mean"]["pq"] == pytest.approx(2 / 3) and phantom["panoptic"] == {"tp": 2, "fp": 2, "fn": 0}


@pytest.mark.parametrize("offset", [0, 10**12, -7])
def test_contingency_ids_of_any_size(offset):
    """Small ids are counted, huge or negative ones sorted: the same table either way."""
    pred = [np.array([[offset + 3, offset + 3, 0, offset + 9]])]
    gt = [np.array([[1, 2, 2, 0]])]
    table, gt_ids, pred_ids = contingency(pred, gt)
    assert gt_ids.tolist() == [0, 1, 2]
    assert pred_ids.tolist() == sorted({0, offset + 3, offset + 9})
    col = {v: i for i, v in enumerate(pred_ids.tolist())}
    assert table[1, col[offset + 3]] == 1 and table[2, col[offset + 3]] == 1 and table[2, col[0]] == 1 and table[0, col[offset + 9]] == 1
    assert table.sum() == 4
