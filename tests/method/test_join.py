import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from graphseg.config import Config
from graphseg.method import segment
from graphseg.method.join import border_contact, join_by_masks, join_objects
from graphseg.metrics import evaluate
from graphseg.sim.boxes import Box
from graphseg.testing.scenes import box_scene, exact_matches

CAM = (np.eye(3), np.eye(4))  # camera at the origin


def flat(h=20, w=20, z=0.5):
    """A flat surface 0.5 m from the camera, 2 mm per pixel."""
    pts = np.zeros((h, w, 3))
    pts[..., 0] = np.arange(w) * 0.002
    pts[..., 1] = np.arange(h)[:, None] * 0.002
    pts[..., 2] = z
    return pts


def stripes(width=2):
    lab = np.zeros((20, 20), np.int32)
    lab[5:15, 2:18] = np.where(np.arange(2, 18) // width % 2 == 0, 1, 2)
    return lab


def test_border_contact_shapes_and_symmetry():
    lab = stripes()
    outline, between, contact = border_contact([lab, lab], [flat(), flat()], [CAM, CAM], num_objects=4)
    assert outline.shape == (5,) and between.shape == contact.shape == (5, 5)
    assert outline.dtype == between.dtype == contact.dtype == np.int64
    assert (between == between.T).all() and (contact == contact.T).all() and (contact <= between).all()
    assert outline[0] == 0 and between[0].sum() == 0 and np.diag(between).sum() == 0


def test_border_contact_by_hand():
    # 3 x 4: ids 1 | 2 | 3 by column pairs, a 10 cm depth step before column 3, one NaN point
    pts = flat(3, 4)
    pts[:, 3, 2] = 0.6
    pts[2, 1] = np.nan
    lab = np.array([[1, 1, 2, 3], [1, 1, 2, 3], [0, 1, 2, 3]], np.int32)
    outline, between, contact = border_contact([lab], [pts], [CAM])
    # id 1: 3 pairs with 2 across columns 1-2, 1 with the 0 at (2, 0) horizontally, 1 vertically (1, 0)-(2, 0)
    assert outline.tolist() == [0, 5, 6, 3]
    assert between[1, 2] == 3 and between[2, 3] == 3 and between[1, 3] == 0
    assert contact[1, 2] == 2  # the NaN point at (2, 1) is no contact
    assert contact[2, 3] == 0  # the depth step
    # the tolerance grows with the distance: 10 cm apart at 0.5 m is contact with depth_rel 0.3
    assert border_contact([lab], [pts], [CAM], depth_rel=0.3)[2][2, 3] == 3


def test_border_contact_edge_cases():
    lab = stripes()
    outline, between, contact = border_contact([lab], [flat()], [(None, None)])  # no camera: skipped
    assert outline.sum() == between.sum() == contact.sum() == 0 and outline.shape == (3,)
    outline, _, _ = border_contact([np.zeros((3, 3), np.int32)], [flat(3, 3)], [CAM])
    assert outline.tolist() == [0]
    assert border_contact([], [], [])[0].tolist() == [0]
    with pytest.raises(ValueError, match="same views"):
        border_contact([lab], [], [CAM])
    with pytest.raises(ValueError, match=r"expected points of shape \[20, 20, 3\] \(got \[4, 4, 3\]\)"):
        border_contact([lab], [flat(4, 4)], [CAM])
    with pytest.raises(ValueError, match="depth_abs >= 0"):
        border_contact([lab], [flat()], [CAM], depth_abs=-1.0)


def test_join_objects_joins_stripes_and_a_label_on_its_box():
    lab = stripes()
    before = lab.copy()
    out, info = join_objects([lab], [flat()], [CAM])
    assert np.unique(out[0]).tolist() == [0, 1] and out[0].dtype == lab.dtype
    assert [j["ids"] for j in info["joins"]] == [[1, 2]] and info["joins"][0]["shared"] >= 0.3
    assert info["mapping"].tolist() == [0, 1, 1] and info["num_objects"] == 1
    assert (lab == before).all() and out[0] is not lab  # the input is not modified
    box = np.ones((6, 6), np.int32)
    box[2:4, 2:4] = 2  # a label inside its box: all of its outline is contact
    out, info = join_objects([box], [flat(6, 6)], [CAM])
    assert (out[0] == 1).all() and info["joins"] == [{"ids": [1, 2], "shared": 1.0}]


def test_join_objects_keeps_touching_objects_and_depth_steps_apart():
    halves = np.zeros((20, 20), np.int32)
    halves[5:15, 2:10], halves[5:15, 10:18] = 1, 2  # contact 10 of an outline of 36
    out, info = join_objects([halves], [flat()], [CAM])
    assert info["joins"] == [] and out[0].tolist() == halves.tolist() and info["mapping"].tolist() == [0, 1, 2]
    assert join_objects([halves], [flat()], [CAM], min_shared=0.25)[1]["joins"][0]["ids"] == [1, 2]
    pts = flat()
    pts[stripes() == 2, 2] = 0.6  # the same stripes, but every other one 10 cm behind: no contact
    assert join_objects([stripes()], [pts], [CAM])[1]["joins"] == []
    assert join_objects([stripes()], [flat()], [CAM], min_shared=np.inf)[1]["joins"] == []  # never join


def test_join_objects_chains_renames_every_view_and_closes_id_gaps():
    lab = stripes()
    three = np.where(lab == 2, 3, lab)  # stripes 1 and 3, and a separate object 2 elsewhere
    three[0:2, 0:2] = 2
    other = np.full((20, 20), -1, np.int32)  # a second view: negative labels are kept
    other[0:3, 0:3] = 3
    out, info = join_objects([three, other], [flat(), flat()], [CAM, (None, None)], num_objects=4)
    assert [j["ids"] for j in info["joins"]] == [[1, 3]]
    assert info["mapping"].tolist() == [0, 1, 2, 1, 3] and info["num_objects"] == 3  # 4 moves down to 3
    assert np.unique(out[0]).tolist() == [0, 1, 2] and out[1][0, 0] == 1 and out[1][5, 5] == -1
    wide = np.zeros((20, 24), np.int32)  # three interleaved stripe sets: joined one after the other
    wide[5:15, 2:20] = np.arange(2, 20) // 2 % 3 + 1
    out, info = join_objects([wide], [flat(20, 24)], [CAM])
    assert len(info["joins"]) == 2 and np.unique(out[0]).tolist() == [0, 1]


def test_join_objects_edge_cases():
    out, info = join_objects([np.zeros((4, 4), np.int32)], [flat(4, 4)], [CAM])
    assert info == {"joins": [], "mapping": info["mapping"], "num_objects": 0} and info["mapping"].tolist() == [0]
    out, info = join_objects([stripes()], [np.full((20, 20, 3), np.nan)], [CAM])  # no points: no contact
    assert info["joins"] == []
    with pytest.raises(ValueError, match="min_shared >= 0"):
        join_objects([stripes()], [flat()], [CAM], min_shared=-0.1)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.integers(0, 4), min_size=36, max_size=36), st.floats(0.0, 1.0))
def test_join_objects_only_renames_objects(cells, min_shared):
    lab = np.array(cells, np.int32).reshape(6, 6)
    out, info = join_objects([lab], [flat(6, 6)], [CAM], min_shared=min_shared, num_objects=4)
    mapping = info["mapping"]
    assert (out[0] == mapping[lab]).all()  # every pixel follows its object; 0 stays 0
    assert mapping[0] == 0 and (mapping <= np.arange(mapping.size)).all()  # a joined object takes the smaller id
    assert sorted(set(mapping[1:].tolist())) == list(range(1, info["num_objects"] + 1))  # no gap
    assert info["num_objects"] == 4 - len(info["joins"]) == mapping.max()
    assert all(j["shared"] >= min_shared - 5e-7 for j in info["joins"])  # the record is rounded to 6 digits


def test_segment_joins_stripes_of_one_box_for_estimated_points_only():
    box = (Box((0.0, 0.0, 0.05), (0.12, 0.10, 0.10), yaw=0.0, color=(200, 60, 60)),)
    scene = box_scene(box, views=3, shape=(240, 320), arc_deg=50.0)
    band = [(np.floor(v.points[..., 0] / 0.01) % 2 == 0) for v in scene.views]  # 1 cm stripes of world x (each set stays one body in 3D)
    masks = [[(v.instances > 0) & b, (v.instances > 0) & ~b] for v, b in zip(scene.views, band)]
    base = Config.preset("rgbd").to_dict()
    base["stages"] = base["stages"][:1]  # 2D edges only: each stripe set matches itself in the other views; no 3D cut (max_ncut 0)
    apart = segment(scene, masks, exact_matches(scene), Config.model_validate({**base, "split": {"enabled": True, "max_ncut": 0.0, "merge_ncut": None}}))
    assert apart.num_objects == 2 and apart.info["split"]["joins"] == []
    res = segment(scene, masks, exact_matches(scene), Config.model_validate({**base, "split": {"enabled": True, "max_ncut": 0.0, "merge_ncut": None, "join_shared": 0.3}}))
    assert res.num_objects == 1 and [sorted(j["ids"]) for j in res.info["split"]["joins"]] == [[1, 2]]
    assert res.mask_object.tolist() == [1] * 6 and np.unique(res.graphs[-1].node_attr["object"]).tolist() == [1]
    assert all(set(np.unique(lab).tolist()) <= {0, 1} for lab in res.labels)
    assert Config.preset("rgbd").split.join_shared is None and Config.preset("rgbd").for_lifter("sfm").split.join_shared == 0.3


def test_a_fragment_joins_one_object_and_never_bridges_two():
    lab = np.zeros((20, 24), np.int32)
    lab[4:16, 2:11], lab[4:16, 11:20] = 1, 2  # two touching objects: contact 9 of an outline of 42
    lab[13:16, 9:13] = 3  # a fragment in the bottom of their seam: 5 of its 14 outline pairs on each
    outline, between, contact = border_contact([lab], [flat(20, 24)], [CAM])
    assert contact[1, 2] / min(outline[1], outline[2]) < 0.3 <= contact[1, 3] / outline[3]
    # measured again after the fragment joined 1, the pair would reach 0.3: a re-measuring rule bridges here
    assert (contact[1, 2] + contact[2, 3]) / min(outline[1] + outline[3] - 2 * between[1, 3], outline[2]) >= 0.3
    out, info = join_objects([lab], [flat(20, 24)], [CAM])
    assert [j["ids"] for j in info["joins"]] == [[3, 1]] and info["num_objects"] == 2  # equal shares: the smaller id
    assert np.unique(out[0]).tolist() == [0, 1, 2] and (out[0][4:16, 2:9] == 1).all() and (out[0][4:13, 11:20] == 2).all()


def test_smaller_pieces_come_along_when_their_piece_joins():
    lab = np.zeros((20, 24), np.int32)
    lab[4:16, 2:14] = 1  # a large object
    lab[8:12, 14:16] = 2  # a piece on its right side: 4 of its 12 outline pairs on 1
    lab[9:11, 16] = 3  # a smaller piece touching only the piece: 2 of 6
    out, info = join_objects([lab], [flat(20, 24)], [CAM])
    assert sorted(j["ids"] for j in info["joins"]) == [[2, 1], [3, 2]] and np.unique(out[0]).tolist() == [0, 1]


YELLOW, BLUE = (230, 200, 40), (40, 60, 200)


def painted(lab, colors):
    """A uint8 image with every object id painted in its colour (0: grey)."""
    img = np.full((*lab.shape, 3), 128, np.uint8)
    for k, c in colors.items():
        img[lab == k] = c
    return img


def banana():
    """One yellow object cut in two (ids 1, 2) beside a blue one (3); each view's mask spans 1 and 2."""
    lab = np.zeros((10, 12), np.int32)
    lab[2:8, 1:4], lab[2:8, 4:6], lab[2:8, 7:11] = 1, 2, 3
    mk = np.zeros((10, 12), np.int64)
    mk[2:8, 1:6], mk[2:8, 7:11] = 1, 2
    return lab, mk, painted(lab, {1: YELLOW, 2: YELLOW, 3: BLUE})


def test_join_by_masks_shapes_and_inputs_kept():
    lab, mk, img = banana()
    before = (lab.copy(), mk.copy(), img.copy())
    out, info = join_by_masks([lab, lab], [mk, mk], [img, img], num_objects=4)
    assert len(out) == 2 and out[0].shape == lab.shape and out[0].dtype == lab.dtype and out[0] is not lab
    assert all((x == y).all() for x, y in zip((lab, mk, img), before))  # no input is modified
    assert info["mapping"].shape == (5,) and info["mapping"].dtype == np.int64
    assert info["num_objects"] == 3  # 1 and 2 joined; 4 (unused) moves down to 3


def test_join_by_masks_by_hand():
    lab, mk, img = banana()
    out, info = join_by_masks([lab], [mk], [img])
    # object 2 (12 px) lies wholly in mask 1, which holds 1 (18 px, 60%): cover 1.0; same colour
    assert info["joins"] == [{"ids": [2, 1], "cover": 1.0, "color": 0.0}]
    assert info["mapping"].tolist() == [0, 1, 1, 2] and np.unique(out[0]).tolist() == [0, 1, 2]
    assert (out[0][lab == 3] == 2).all() and (out[0][lab == 2] == 1).all()
    # a mask holds an object at 30% of its labelled pixels: 2 holds 12 / 30 = 40% of mask 1, so 1 is
    # covered by 2 too, but 1 is the larger and only joins a larger object
    assert join_by_masks([lab], [mk], [img], straddle=0.5)[1]["joins"] == [{"ids": [2, 1], "cover": 1.0, "color": 0.0}]
    assert join_by_masks([lab], [mk], [img], straddle=0.7)[1]["joins"] == []  # no mask holds 1 at 70% (60%)


def test_join_by_masks_keeps_objects_of_other_colours_and_separate_masks_apart():
    lab, mk, img = banana()
    two = painted(lab, {1: YELLOW, 2: BLUE, 3: BLUE})  # the same masks, but 2 is blue
    assert join_by_masks([lab], [mk], [two])[1]["joins"] == []
    d = join_by_masks([lab], [mk], [two], max_color=1000.0)[1]
    assert [j["ids"] for j in d["joins"]] == [[2, 1]] and d["joins"][0]["color"] > 100
    own = np.where(lab == 2, 3, mk)  # 2 in a mask of its own: nothing holds it with 1
    assert join_by_masks([lab], [own], [img])[1]["joins"] == []
    assert join_by_masks([lab], [mk], [img], min_cover=np.inf)[1]["joins"] == []  # never join


def test_join_by_masks_counts_cover_over_all_views():
    lab, mk, img = banana()
    own = np.where(lab == 2, 3, mk)  # a second view whose masks part 1 and 2
    assert join_by_masks([lab, lab], [mk, own], [img, img])[1]["joins"][0]["cover"] == 0.5
    assert join_by_masks([lab, lab], [mk, own], [img, img], min_cover=0.6)[1]["joins"] == []


def test_join_by_masks_a_piece_never_bridges_two_larger_objects():
    lab = np.zeros((10, 16), np.int32)
    lab[2:8, 1:7], lab[2:8, 7:9], lab[2:8, 9:15] = 1, 2, 3  # a small piece between two large yellow objects
    left = np.where(lab == 3, 2, np.where(lab > 0, 1, 0))  # view A: the piece in the mask of 1 (12 of 48 px)
    right = np.where(lab == 1, 1, np.where(lab > 0, 2, 0))  # view B: the piece in the mask of 3
    img = painted(lab, {1: YELLOW, 2: YELLOW, 3: YELLOW})
    out, info = join_by_masks([lab, lab], [left, right], [img, img])
    # the piece is covered by each at 0.5 and joins one (equal covers: the first, 1); no mask ever
    # holds 1 and 3 together, so they stay apart although the piece touched both
    assert info["joins"] == [{"ids": [2, 1], "cover": 0.5, "color": 0.0}]
    assert info["num_objects"] == 2 and np.unique(out[0]).tolist() == [0, 1, 2]


def test_join_by_masks_edge_cases():
    lab, mk, img = banana()
    out, info = join_by_masks([np.zeros((4, 4), np.int32)], [np.zeros((4, 4))], [np.zeros((4, 4, 3), np.uint8)])
    assert info == {"joins": [], "mapping": info["mapping"], "num_objects": 0} and info["mapping"].tolist() == [0]
    neg = np.where(lab == 3, -1, lab)  # negative labels are kept
    out, info = join_by_masks([neg], [mk], [img])
    assert (out[0][lab == 3] == -1).all() and info["mapping"].tolist() == [0, 1, 1]
    assert join_by_masks([lab], [np.zeros_like(mk)], [img])[1]["joins"] == []  # no masks: nothing holds anything
    with pytest.raises(ValueError, match="same views"):
        join_by_masks([lab], [], [img])
    with pytest.raises(ValueError, match=r"view 0: expected masks of shape \[10, 12\] \(got \[4, 4\]\)"):
        join_by_masks([lab], [np.zeros((4, 4))], [img])
    with pytest.raises(ValueError, match=r"view 0: expected a uint8 image of shape \[10, 12, 3\]"):
        join_by_masks([lab], [mk], [img.astype(np.float32)])
    with pytest.raises(ValueError, match="min_cover >= 0"):
        join_by_masks([lab], [mk], [img], min_cover=-1.0)
    with pytest.raises(ValueError, match="0 < straddle <= 1"):
        join_by_masks([lab], [mk], [img], straddle=0.0)


def partners_by_loops(lab, mk, blue, straddle=0.3):
    """Each object's partner and cover, pixel by pixel (one view; the colours are yellow but for ``blue``)."""
    size = {a: int((lab == a).sum()) for a in range(1, 5)}
    cover = {(a, b): 0 for a in size for b in size}
    for m in set(mk.ravel().tolist()) - {0}:
        inside = {a: int(((mk == m) & (lab == a)).sum()) for a in size}
        total = sum(inside.values())
        for a in size:
            for b in size:
                if a != b and total and inside[b] >= straddle * total:
                    cover[a, b] += inside[a]
    out = {}
    for a in size:
        if not size[a]:
            continue
        larger = [b for b in size if size[b] and (size[b], b) > (size[a], a)]
        shares = [(cover[a, b] / size[a], -b) for b in larger]
        if shares and max(shares)[0] > 0:
            c, b = max(shares)
            out[a] = (-b, c, (a in blue) == (-b in blue))
    return out


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(0, 4), min_size=36, max_size=36), st.lists(st.integers(0, 3), min_size=36, max_size=36), st.floats(0.0, 1.0))
def test_join_by_masks_only_renames_objects(cells, mask_cells, min_cover):
    lab = np.array(cells, np.int32).reshape(6, 6)
    mk = np.array(mask_cells, np.int64).reshape(6, 6)
    img = painted(lab, {1: YELLOW, 2: YELLOW, 3: BLUE, 4: YELLOW})
    out, info = join_by_masks([lab], [mk], [img], min_cover=min_cover, num_objects=4)
    expected = {a: b for a, (b, c, same) in partners_by_loops(lab, mk, {3}).items() if same and c >= min_cover}
    assert {j["ids"][0]: j["ids"][1] for j in info["joins"]} == expected  # the joins a pixel-by-pixel count gives
    mapping = info["mapping"]
    assert (out[0] == mapping[lab]).all()  # every pixel follows its object; 0 stays 0
    assert mapping[0] == 0 and (mapping <= np.arange(mapping.size)).all()
    assert sorted(set(mapping[1:].tolist())) == list(range(1, info["num_objects"] + 1))
    assert info["num_objects"] == 4 - len(info["joins"])
    assert all(j["cover"] >= min_cover and j["color"] <= 10.0 for j in info["joins"])
    assert all(3 not in j["ids"] for j in info["joins"])  # the blue one never joins a yellow one


def test_rgbd_preset_joins_by_masks():
    assert Config.preset("rgbd").split.mask_join == 0.5 and Config.preset("paper").split.mask_join is None
    assert Config.preset("robust").split.mask_join is None
    assert Config.preset("rgbd").for_lifter("sfm").split.mask_join == 0.5


TOUCHING = (  # a red and a blue box side by side, touching along x = 0 (as in test_split.py)
    Box((-0.05, 0.0, 0.05), (0.10, 0.10, 0.10), yaw=0.0, color=(200, 60, 60)),
    Box((0.045, 0.03, 0.035), (0.09, 0.12, 0.07), yaw=0.0, color=(60, 90, 200)),
)


def test_segment_joins_a_box_the_split_cut_in_two_but_not_two_boxes_one_mask_spans(monkeypatch):
    import sys

    seg_mod = sys.modules["graphseg.method.operations"]  # the graph operations after the last contraction
    scene = box_scene(TOUCHING, views=3, shape=(240, 320), arc_deg=50.0)
    masks = [[v.instances == 1, v.instances == 2] for v in scene.views]  # pure masks, one per box
    real = seg_mod.split_objects

    def halved(*a, **k):  # a split that also cuts the red box in two at x = -0.05 (new id 3)
        out, info = real(*a, **k)
        new = []
        for lab, p in zip(out, a[1]):
            lab = lab.copy()
            lab[(lab == 1) & (p[..., 0] > -0.05)] = info["num_objects"] + 1
            new.append(lab)
        return new, {**info, "num_objects": info["num_objects"] + 1}

    monkeypatch.setattr(seg_mod, "split_objects", halved)
    base = {"fine_voxel_size": None, "merge_ncut": None}  # no 3D merge, which would join the halves too
    off = segment(scene, masks, exact_matches(scene), Config.preset("rgbd", split={**base, "mask_join": None}))
    assert off.num_objects == 3 and off.info["split"]["mask_joins"] == []
    res = segment(scene, masks, exact_matches(scene), Config.preset("rgbd", split=base))
    assert res.num_objects == 2 and [sorted(j["ids"]) for j in res.info["split"]["mask_joins"]] == [[1, 3]]
    assert res.mask_object.tolist() == [1, 2] * 3
    for v, lab in zip(scene.views, res.labels):
        assert evaluate([lab], [v.instances], [v.points])["mean"]["iou"] > 0.95
    monkeypatch.setattr(seg_mod, "split_objects", real)
    one = [[v.instances > 0] for v in scene.views]  # one mask over both boxes in every view: the split parts them
    res = segment(scene, one, exact_matches(scene), Config.preset("rgbd"))
    assert res.num_objects == 2 and res.info["split"]["mask_joins"] == []  # red and blue: never joined
