import numpy as np
import pytest

from graphseg.method.masks import compose_masks, paint_masks


def test_smaller_masks_painted_over_larger():
    big = np.ones((4, 4), bool)
    mid = np.zeros((4, 4), bool)
    mid[:2, :2] = True
    small = np.zeros((4, 4), bool)
    small[0, 0] = True
    lab, info = compose_masks([small, big, mid], max_overlap=0.09, min_area=1)  # order of input does not matter
    assert lab.dtype == np.int32 and lab.shape == (4, 4)
    assert lab[0, 0] == 1 and lab[0, 1] == 3 and lab[3, 3] == 2
    assert info["kept"] == [0, 1, 2]


def test_ties_are_deterministic():
    a = np.zeros((2, 2), bool)
    a[0] = True
    b = np.zeros((2, 2), bool)
    b[:, 0] = True
    lab1, _ = compose_masks([a, b], max_overlap=0.09, min_area=1)
    lab2, _ = compose_masks([a, b], max_overlap=0.09, min_area=1)
    assert np.array_equal(lab1, lab2) and lab1[0, 0] == 2  # equal area: lower index painted first


def test_background_overlap_drop_and_clear():
    bg = np.zeros((10, 10), bool)
    bg[9] = True
    m1 = np.zeros((10, 10), bool)
    m1[8:] = True  # 50% background -> dropped
    m2 = np.zeros((10, 10), bool)
    m2[:9, :5] = True
    m2[9, 0] = True  # 1/46 background -> kept, pixel cleared
    lab, info = compose_masks([m1, m2], background=bg, max_overlap=0.09, min_area=1)
    assert info["dropped_background"] == [0]
    assert lab[9, 0] == 0 and lab[0, 0] == 2


def test_min_area_and_label_image_input():
    lab_in = np.array([[1, 1, 2], [0, 3, 3]])
    lab, info = compose_masks(lab_in, min_area=2, max_overlap=0.09)
    assert lab.tolist() == [[1, 1, 0], [0, 3, 3]] and info["dropped_small"] == [1]
    bg = np.array([[False, False, True], [False, False, False]])
    lab, info = compose_masks(lab_in, background=bg, max_overlap=0.5, min_area=1)
    assert info["dropped_background"] == [1] and lab[0, 2] == 0


def test_errors():
    with pytest.raises(ValueError, match="at least one mask"):
        compose_masks([], max_overlap=0.09, min_area=1)
    with pytest.raises(ValueError, match="mask 1 is"):
        compose_masks([np.zeros((2, 2), bool), np.zeros((3, 3), bool)], max_overlap=0.09, min_area=1)
    with pytest.raises(ValueError, match=">= 0"):
        compose_masks(np.array([[-1, 0]]), max_overlap=0.09, min_area=1)


def test_zero_overlap_threshold_drops_only_masks_touching_background():
    bg = np.zeros((4, 4), bool)
    bg[0, 0] = True
    a = np.zeros((4, 4), bool)
    a[:2, :2] = True  # touches the background pixel
    b = np.zeros((4, 4), bool)
    b[2:, 2:] = True
    lab, info = compose_masks([a, b], background=bg, max_overlap=0.0, min_area=1)
    assert info["dropped_background"] == [0] and info["kept"] == [1]
    lab, info = compose_masks(np.array([[1, 1], [2, 2]]), background=np.zeros((2, 2), bool), max_overlap=0.0, min_area=1)
    assert info["kept"] == [0, 1]


def test_label_image_input_is_never_returned_or_mutated():
    lab = np.array([[1, 1, 0], [2, 2, 2]], np.int32)
    keep = lab.copy()
    out, info = compose_masks(lab, background=np.zeros((2, 3), bool), max_overlap=0.09, min_area=1)
    assert out is not lab and not np.shares_memory(out, lab) and out.dtype == np.int32
    out[:] = 9
    assert np.array_equal(lab, keep) and info["kept"] == [0, 1]
    out, _ = compose_masks(lab.astype(np.uint8), max_overlap=0.09, min_area=1)
    assert out.tolist() == keep.tolist() and out.dtype == np.int32


def test_paint_masks_shape_and_values():
    masks = [np.array([[0, 1, 1], [2, 2, 0]]), np.array([[3, 0, 0], [0, 0, 0]])]
    out = paint_masks(masks, np.array([0, 0, 1, 1, 1]), np.array([0, 1, 0, 1, 2]), np.array([5, 0, 9, 9, 6]))
    assert [o.shape for o in out] == [(2, 3), (2, 3)] and all(o.dtype == np.int64 for o in out)
    assert out[0].tolist() == [[0, 5, 5], [0, 0, 0]]  # mask 1 lies on the background: no object
    assert out[1].tolist() == [[6, 0, 0], [0, 0, 0]]
    assert paint_masks([np.zeros((1, 2), np.int64)], np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64))[0].tolist() == [[0, 0]]
    assert paint_masks(masks, np.array([0]), np.array([0]), np.array([3]), dtype=np.int32)[0].dtype == np.int32


def test_rename_objects_by_hand_and_edge_cases():
    from graphseg.method.masks import rename_objects

    lab = np.array([[0, 1, 2, 3], [3, 2, -1, 0]], np.int16)
    before = lab.copy()
    out = rename_objects([lab, lab[:1]], np.array([0, 1, 1, 2]))
    assert [o.tolist() for o in out] == [[[0, 1, 1, 2], [2, 1, -1, 0]], [[0, 1, 1, 2]]]
    assert out[0].dtype == np.int16 and (lab == before).all()  # same dtype, input kept
    copy = rename_objects([lab], None)[0]
    assert copy.tolist() == lab.tolist() and copy is not lab
    assert rename_objects([], np.array([0])) == []


def test_snap_to_masks_by_hand():
    from graphseg.method.masks import snap_to_masks

    masks = [np.array([[1, 1, 1, 1, 1, 2, 2, 2, 2, 0]], np.int32)]
    lab = np.array([[3, 3, 3, 3, 1, 1, 1, 3, 3, 2]], np.int16)  # mask 1: 4 of 5 in 3; mask 2: 2 of 4; id 2 outside any mask
    before = lab.copy()
    out, info = snap_to_masks([lab], masks, 0.8)
    assert out[0].tolist() == [[3, 3, 3, 3, 3, 1, 1, 3, 3, 2]] and out[0].dtype == np.int16
    assert info == {"pixels": 1, "masks": 1, "mapping": None, "num_objects": 3}
    assert (lab == before).all()  # the input is not modified
    out, info = snap_to_masks([lab], masks, 0.9)  # 4 of 5 is below 0.9: nothing moves
    assert out[0].tolist() == lab.tolist() and info["pixels"] == 0 and out[0] is not lab


def test_snap_to_masks_frees_the_id_of_an_object_it_empties():
    from graphseg.method.masks import snap_to_masks

    masks = [np.array([[1, 1, 1, 1, 1, 1, 2, 2]]), np.array([[1, 1, 0, 0, 0, 0, 0, 0]])]
    lab = [np.array([[1, 1, 1, 1, 1, 2, 3, 3]]), np.array([[3, 0, -1, 0, 0, 0, 0, 0]])]  # object 2: one pixel of mask 1
    out, info = snap_to_masks(lab, masks, 0.8)
    assert info["mapping"].tolist() == [0, 1, 1, 2] and info["num_objects"] == 2  # 2's pixel went to 1: so does its id
    assert out[0].tolist() == [[1, 1, 1, 1, 1, 1, 2, 2]]
    assert out[1].tolist() == [[2, 0, -1, 0, 0, 0, 0, 0]]  # unlabelled and negative pixels stay as they are
    out, info = snap_to_masks(lab, masks, 0.8, num_objects=4)  # ids in use beyond the labels' largest move down too
    assert info["mapping"].tolist() == [0, 1, 1, 2, 3] and info["num_objects"] == 3


def test_snap_to_masks_edge_cases():
    from graphseg.method.masks import snap_to_masks

    lab = [np.array([[1, 2]])]
    masks = [np.array([[1, 1]])]
    assert snap_to_masks(lab, masks, np.inf)[1]["pixels"] == 0  # never snap
    assert snap_to_masks([np.zeros((2, 2), np.int32)], [np.ones((2, 2), np.int32)], 0.9)[1] == {"pixels": 0, "masks": 0, "mapping": None, "num_objects": 0}
    assert snap_to_masks([], [], 0.9)[0] == []
    with pytest.raises(ValueError, match="min_share > 0.5"):
        snap_to_masks(lab, masks, 0.5)
    with pytest.raises(ValueError, match="masks for the 1 views"):
        snap_to_masks(lab, [], 0.9)
    with pytest.raises(ValueError, match=r"expected masks of shape \[1, 2\] \(got \[2, 2\]\)"):
        snap_to_masks(lab, [np.ones((2, 2), np.int32)], 0.9)


def test_snap_to_masks_with_points_moves_only_what_the_other_views_agree_on():
    from graphseg.method.masks import snap_to_masks

    # one row of 10 points seen by two views; voxels of 1 hold one point each
    pts = [np.stack([np.arange(10.0), np.zeros(10), np.zeros(10)], 1).reshape(1, 10, 3)] * 2
    # view 0: mask 1 covers points 0-9, 9 of them in object 1 and point 9 in object 2 (a superpixel over the border, or a voxel cut)
    lab0, m0 = np.array([[1] * 9 + [2]]), np.ones((1, 10), np.int32)
    # view 1 sees point 9 in a mask of its own, wholly object 2: the cut stands
    lab1, m1 = np.array([[1] * 9 + [2]]), np.array([[1] * 9 + [2]])
    out, info = snap_to_masks([lab0, lab1], [m0, m1], 0.85, points=pts, voxel_size=1.0)
    assert out[0].tolist() == lab0.tolist() and info["pixels"] == 0
    out, info = snap_to_masks([lab0, lab1], [m0, m1], 0.85)  # without points the share alone decides
    assert out[0].tolist() == [[1] * 10] and info["pixels"] == 1
    # view 1's mask holds point 9 with points 0-8 (in object 1): its vote gives the pixel back
    out, info = snap_to_masks([lab0, np.array([[1] * 10])], [m0, np.ones((1, 10), np.int32)], 0.85, points=pts, voxel_size=1.0)
    assert out[0].tolist() == [[1] * 10] and info["pixels"] == 1 and info["mapping"].tolist() == [0, 1, 1]
    # a voxel no other view sees, or a pixel without a point, keeps its label
    hidden = [pts[0], np.full((1, 10, 3), np.nan)]
    assert snap_to_masks([lab0, np.array([[1] * 10])], [m0, np.ones((1, 10), np.int32)], 0.85, points=hidden, voxel_size=1.0)[1]["pixels"] == 0
    nan9 = pts[0].copy()
    nan9[0, 9] = np.nan
    out, info = snap_to_masks([lab0, np.array([[1] * 10])], [m0, np.ones((1, 10), np.int32)], 0.85, points=[nan9, pts[1]], voxel_size=1.0)
    assert info["pixels"] == 0
    # the votes are counted: two views for object 2 outweigh one for object 1
    labs = [lab0, np.array([[1] * 10]), lab1, lab1]
    mks = [m0, np.ones((1, 10), np.int32), m1, m1]
    assert snap_to_masks(labs, mks, 0.85, points=[pts[0]] * 4, voxel_size=1.0)[1]["pixels"] == 0
    assert (lab0 == np.array([[1] * 9 + [2]])).all()  # inputs unchanged


def test_snap_to_masks_votes_are_for_the_masks_object_on_the_floor_grid_and_far_points_keep_keys_apart():
    from graphseg.method.masks import snap_to_masks

    row = np.stack([np.arange(10.0), np.zeros(10), np.zeros(10)], 1).reshape(1, 10, 3)
    lab0, m0 = np.array([[1] * 9 + [2]]), np.ones((1, 10), np.int32)
    # view 1 also has point 9 in object 2, but inside a mask whose main object is 1: it votes for 1, so the pixel moves
    lab1, m1 = np.array([[1] * 9 + [2]]), np.ones((1, 10), np.int32)
    masks, points = [m0, m1], [row, row.copy()]
    before = [a.copy() for a in (lab0, lab1, m0, m1, row)]
    out, info = snap_to_masks([lab0, lab1], masks, 0.85, points=points, voxel_size=1.0)
    assert out[0].tolist() == [[1] * 10] and out[1].tolist() == [[1] * 10] and info["pixels"] == 2
    assert all((a == b).all() for a, b in zip((lab0, lab1, m0, m1, row), before))  # no input modified
    # voxels are floor(point / voxel_size): 0.9 and 1.1 lie in different voxels, 1.1 and 1.9 in one
    p0 = np.array([[[0.5, 0, 0]] * 9 + [[1.1, 0, 0]]])
    lab_b, m_b = np.array([[2] * 10]), np.array([[1] * 10])  # view 1: object 2 alone, at 1.9
    assert snap_to_masks([lab0, lab_b], [m0, m_b], 0.85, points=[p0, np.array([[[1.9, 0, 0]] * 10])], voxel_size=1.0)[1]["pixels"] == 0  # 1.1 and 1.9: one voxel, votes 2
    assert snap_to_masks([lab0, lab_b], [m0, m_b], 0.85, points=[p0, np.array([[[0.9, 0, 0]] * 10])], voxel_size=1.0)[1]["pixels"] == 0  # no vote in 1.1's voxel
    lab_c = np.array([[1] * 10])
    assert snap_to_masks([lab0, lab_c], [m0, m_b], 0.85, points=[p0, np.array([[[1.5, 0, 0]] * 10])], voxel_size=1.0)[1]["pixels"] == 1  # votes 1 there
    # a far stray point makes the voxel box too large for a mixed-radix key; the votes still land in the right voxels
    far = row.copy()
    far[0, 0] = [1e7, 1e7, 1e7]
    assert snap_to_masks([lab0, np.array([[1] * 9 + [2]])], [m0, np.array([[1] * 9 + [2]])], 0.85, points=[row, far], voxel_size=1.0)[1]["pixels"] == 0
    huge = row.copy()
    huge[0, 3] = [1e300, 0, 0]  # beyond int64 once divided: no point
    assert snap_to_masks([lab0, lab1], masks, 0.85, points=[row, huge], voxel_size=1.0)[1]["pixels"] == 2


def test_snap_to_masks_memory_grows_with_the_pixels_not_the_square_of_the_ids():
    from graphseg.method.masks import snap_to_masks

    pts = [np.stack([np.arange(4.0), np.zeros(4), np.zeros(4)], 1).reshape(1, 4, 3)] * 2
    lab = [np.array([[1, 1, 1, 2]]), np.array([[1, 1, 1, 1]])]
    m = [np.ones((1, 4), np.int32)] * 2
    out, info = snap_to_masks(lab, m, 0.7, points=pts, voxel_size=1.0, num_objects=10**6)  # a dense [T, T] table would need 8 TB
    assert out[0].tolist() == [[1, 1, 1, 1]] and info["num_objects"] == 10**6 - 1 and info["mapping"][2] == 1
    many = [np.arange(1, 5001).reshape(50, 100)]  # 5,000 masks of one pixel, each wholly its own object
    out, info = snap_to_masks([many[0] * 0 + 7], many, 0.9, num_objects=10**6)  # a dense [masks, ids] table would need 40 GB
    assert info["pixels"] == 0 and (out[0] == 7).all()


def test_snap_to_masks_points_are_checked():
    from graphseg.method.masks import snap_to_masks

    lab, masks = [np.array([[1, 2]])], [np.array([[1, 1]])]
    with pytest.raises(ValueError, match="points for the 1 views"):
        snap_to_masks(lab, masks, 0.9, points=[])
    with pytest.raises(ValueError, match="voxel_size > 0"):
        snap_to_masks(lab, masks, 0.9, points=[np.zeros((1, 2, 3))], voxel_size=0.0)
    with pytest.raises(ValueError, match=r"expected points of shape \[1, 2, 3\] \(got \[2, 1, 3\]\)"):
        snap_to_masks(lab, masks, 0.9, points=[np.zeros((2, 1, 3))])


def test_close_id_gaps_by_hand_and_edge_cases():
    from graphseg.method.masks import close_id_gaps

    rep = np.array([0, 1, 1, 3, 3, 5])  # 2 joined 1, 4 joined 3
    freed = np.array([False, False, True, False, True, False])
    out = close_id_gaps(rep, freed)
    assert out.tolist() == [0, 1, 1, 2, 2, 3] and out.dtype == np.int64
    assert rep.tolist() == [0, 1, 1, 3, 3, 5]  # the input is not modified
    assert close_id_gaps(np.arange(4), np.zeros(4, bool)).tolist() == [0, 1, 2, 3]  # nothing freed
    assert close_id_gaps(np.array([0]), np.array([False])).tolist() == [0]
