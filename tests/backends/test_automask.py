import numpy as np
import pytest

from graphseg.backends.segmenters.automask import (
    AutomaskOptions,
    box_iou,
    box_nms,
    crop_boxes,
    generate_masks,
    masks_to_boxes,
    point_grid,
    remove_small_regions,
    stability_score,
)


# ----------------------------------------------------------------------------- grid
def test_point_grid_shape_and_values():
    g = point_grid(4)
    assert g.shape == (16, 2)
    assert np.allclose(np.unique(g[:, 0]), [0.125, 0.375, 0.625, 0.875])
    assert np.allclose(g[:4, 1], 0.125)  # x varies fastest


def test_point_grid_single_and_invalid():
    assert point_grid(1).tolist() == [[0.5, 0.5]]
    with pytest.raises(ValueError, match="n_per_side >= 1"):
        point_grid(0)


# ----------------------------------------------------------------------------- stability
def test_stability_score_hand_computed():
    logits = np.full((2, 3, 4), -5.0)
    logits[0, :2, :2] = 5.0  # 4 pixels > +1
    logits[0, 2, :] = 0.5  # 4 more pixels > -1 only
    assert stability_score(logits).shape == (2,)
    assert stability_score(logits)[0] == pytest.approx(4 / 8)
    assert stability_score(logits)[1] == 0.0  # empty at both thresholds
    # with offset 0.25 the 0.5 pixels count in both masks
    assert stability_score(logits[0], offset=0.25) == pytest.approx(1.0)


def test_stability_score_shifted_threshold():
    logits = np.array([[[2.5, 1.5, 0.5]]])
    assert stability_score(logits, mask_threshold=1.0, offset=1.0)[0] == pytest.approx(1 / 3)


# ----------------------------------------------------------------------------- boxes
def test_masks_to_boxes_full_and_single_pixel():
    m = np.zeros((2, 3, 4), bool)
    m[0] = True
    m[1, 2, 3] = True
    assert masks_to_boxes(m).tolist() == [[0, 0, 4, 3], [3, 2, 4, 3]]
    with pytest.raises(ValueError, match=r"shape \[N, H, W\]"):
        masks_to_boxes(np.zeros((3, 4), bool))


def test_box_iou_hand_computed():
    a = np.array([[0, 0, 4, 4]])
    b = np.array([[2, 2, 6, 6], [0, 0, 4, 4], [0, 0, 0, 0]])
    assert box_iou(a, b)[0].tolist() == pytest.approx([4 / 28, 1.0, 0.0])
    assert box_iou(np.zeros((0, 4)), b).shape == (0, 3)


def test_box_nms_threshold_is_strict():
    b = np.array([[0, 0, 4, 4], [0, 0, 4, 2]])  # IoU 0.5
    assert box_nms(b, np.array([0.9, 0.8]), 0.5).tolist() == [0, 1]  # IoU == threshold is kept
    assert box_nms(b, np.array([0.9, 0.8]), 0.49).tolist() == [0]


def test_box_nms_chain_and_empty():
    # 1 suppresses 0 and 2 suppresses nothing; 0 cannot suppress 2 once removed
    b = np.array([[0, 0, 10, 10], [1, 0, 11, 10], [2, 0, 12, 10]])
    assert box_nms(b, np.array([0.5, 0.9, 0.4]), 0.7).tolist() == [1]
    assert box_nms(b, np.array([0.5, 0.9, 0.4]), 0.85).tolist() == [1, 0, 2]  # IoUs 9/11, 9/11, 8/12
    assert box_nms(np.zeros((0, 4)), np.zeros(0), 0.7).tolist() == []
    with pytest.raises(ValueError, match="one score per box"):
        box_nms(b, np.zeros(2), 0.5)


def test_box_nms_orders_by_score():
    b = np.array([[0, 0, 2, 2], [10, 10, 12, 12], [20, 20, 22, 22]])
    assert box_nms(b, np.array([0.1, 0.3, 0.2]), 0.5).tolist() == [1, 2, 0]


# ----------------------------------------------------------------------------- cleanup
def test_remove_small_regions_holes_and_islands():
    m = np.zeros((8, 8), bool)
    m[1:6, 1:6] = True
    m[3, 3] = False  # 1-pixel hole
    m[7, 7] = True  # 1-pixel island
    before = m.copy()
    filled, ch = remove_small_regions(m, 3, "holes")
    assert ch and filled[3, 3] and filled.sum() == 25 + 1
    cleaned, ch = remove_small_regions(m, 3, "islands")
    assert ch and not cleaned[7, 7] and cleaned.sum() == 24
    assert np.array_equal(m, before)  # input untouched


def test_remove_small_regions_unchanged_and_all_small():
    m = np.zeros((6, 6), bool)
    m[0:3, 0:3] = True
    out, ch = remove_small_regions(m, 2, "islands")
    assert not ch and np.array_equal(out, m) and out is not m
    m2 = np.zeros((6, 6), bool)
    m2[0, 0] = True
    m2[4:6, 4:6] = True  # both islands < 10: the largest is kept
    out, ch = remove_small_regions(m2, 10, "islands")
    assert ch and out.sum() == 4 and out[5, 5]
    with pytest.raises(ValueError, match="unknown mode"):
        remove_small_regions(m, 2, "specks")


# ----------------------------------------------------------------------------- crops
def test_crop_boxes_cover_the_image():
    b, layers = crop_boxes((90, 120), 2)
    assert len(b) == 1 + 4 + 16 and layers.tolist() == [0] + [1] * 4 + [2] * 16
    cover = np.zeros((90, 120), int)
    for x0, y0, x1, y1 in b[1:5]:
        cover[y0:y1, x0:x1] += 1
    assert cover.min() >= 1 and cover.max() == 4  # overlapping 2x2 crops
    assert crop_boxes((5, 7), 0)[0].tolist() == [[0, 0, 7, 5]]


# ----------------------------------------------------------------------------- generator
def _square_predictor(h, w, half=5, iou=1.0, k=1, scale=10.0):
    yy, xx = np.mgrid[0:h, 0:w]
    calls = []

    def predict(points, labels):
        calls.append(len(points))
        assert (labels == 1).all()
        m = np.array([(np.abs(xx - x) <= half) & (np.abs(yy - y) <= half) for x, y in points])
        logits = np.where(m, scale, -scale)[:, None].repeat(k, 1).astype(np.float32)
        return logits, np.full((len(points), k), iou, np.float32)

    return predict, calls


def test_generate_masks_shapes_and_batching():
    predict, calls = _square_predictor(40, 40)
    props = generate_masks(predict, (40, 40), AutomaskOptions(points_per_side=4, points_per_batch=5))
    assert calls == [5, 5, 5, 1]
    assert props.masks.shape == (16, 40, 40) and props.masks.dtype == bool
    assert props.boxes.shape == (16, 4) and props.points.shape == (16, 2)
    # the prompt at (5, 5) makes the box [0, 0, 11, 11)
    i = int(np.argmin(np.abs(props.points - 5).sum(1)))
    assert props.boxes[i].tolist() == [0, 0, 11, 11]


def test_generate_masks_nms_removes_duplicates():
    # k=2 identical candidates per prompt: one survives each
    predict, _ = _square_predictor(40, 40, k=2)
    assert len(generate_masks(predict, (40, 40), AutomaskOptions(points_per_side=2)).masks) == 4


def test_generate_masks_iou_and_stability_filters():
    predict, _ = _square_predictor(40, 40, iou=0.5)
    assert len(generate_masks(predict, (40, 40), AutomaskOptions(points_per_side=2)).masks) == 0
    assert len(generate_masks(predict, (40, 40), AutomaskOptions(points_per_side=2, pred_iou_thresh=0.4)).masks) == 4
    # logits +-0.5: thresholded at +1 the mask is empty -> stability 0
    weak, _ = _square_predictor(40, 40, scale=0.5)
    assert len(generate_masks(weak, (40, 40), AutomaskOptions(points_per_side=2)).masks) == 0
    assert len(generate_masks(weak, (40, 40), AutomaskOptions(points_per_side=2, stability_score_offset=0.25)).masks) == 4


def test_generate_masks_resizes_low_res_logits():
    # logits at 20x20 for a 40x40 image: a 10x10 block becomes 20x20
    def predict(points, labels):
        lg = np.full((len(points), 1, 20, 20), -10.0, np.float32)
        lg[:, :, 5:15, 5:15] = 10.0
        return lg, np.ones((len(points), 1), np.float32)

    props = generate_masks(predict, (40, 40), AutomaskOptions(points_per_side=1))
    assert props.masks.shape == (1, 40, 40)
    assert props.boxes[0].tolist() == [10, 10, 30, 30]


def test_generate_masks_cleanup_removes_specks():
    def predict(points, labels):
        lg = np.full((len(points), 1, 30, 30), -10.0, np.float32)
        lg[:, :, 2:20, 2:20] = 10.0
        lg[:, :, 25, 25] = 10.0  # 1-pixel island
        lg[:, :, 10, 10] = -10.0  # 1-pixel hole
        return lg, np.ones((len(points), 1), np.float32)

    raw = generate_masks(predict, (30, 30), AutomaskOptions(points_per_side=1))
    assert raw.masks[0].sum() == 18 * 18 - 1 + 1
    clean = generate_masks(predict, (30, 30), AutomaskOptions(points_per_side=1, min_mask_region_area=5))
    assert clean.masks[0].sum() == 18 * 18 and clean.boxes[0].tolist() == [2, 2, 20, 20]


def test_generate_masks_crops_need_predict_crop_and_drop_edge_masks():
    predict, _ = _square_predictor(64, 64, half=3)
    with pytest.raises(ValueError, match="predict_crop"):
        generate_masks(predict, (64, 64), AutomaskOptions(points_per_side=2, crop_n_layers=1))
    seen = []

    def predict_crop(box):
        seen.append(box.tolist())
        h, w = box[3] - box[1], box[2] - box[0]
        return _square_predictor(h, w, half=3)[0]

    props = generate_masks(predict, (64, 64), AutomaskOptions(points_per_side=2, crop_n_layers=1), predict_crop=predict_crop)
    assert len(seen) == 4
    assert props.masks.shape[1:] == (64, 64)
    # layer 0: four 7x7 squares around (16, 16) ...; layer 1 (crops of 43 px at 0 and 21):
    # prompts at 10.75 / 32.25 in crop pixels give 6x6 squares; those within 20 px of an
    # inner crop edge (32.25 -> box end 36 vs crop end 43) are dropped, the four corner ones stay
    assert sorted(props.masks.sum((1, 2)).tolist()) == [36] * 4 + [49] * 4
    corner = props.masks.sum((1, 2)) == 36
    assert sorted(map(tuple, props.points[corner].tolist())) == [(10.75, 10.75), (10.75, 53.5), (53.5, 10.75), (53.5, 53.5)]


def test_generate_masks_rejects_bad_predictor_output():
    def bad(points, labels):
        return np.zeros((len(points), 4, 4)), np.zeros(len(points))

    with pytest.raises(ValueError, match=r"logits \[B, K, h, w\]"):
        generate_masks(bad, (4, 4), AutomaskOptions(points_per_side=1))
