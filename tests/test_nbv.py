"""graphseg.nbv: candidate sampling, the three terms, the ranking, bad input."""

import dataclasses
import json

import numpy as np
import pytest

from graphseg.method.segment import segment
from graphseg.nbv import (
    DEFAULT_WEIGHTS,
    TERMS,
    NextBestView,
    ViewScore,
    ambiguity_targets,
    closeness,
    sample_candidates,
    suggest_views,
    under_seen_targets,
    unseen_table_cells,
)
from graphseg.scene import Scene, SceneError
from graphseg.sim.boxes import Box, look_at
from graphseg.testing.scenes import box_scene, two_boxes_scene


@pytest.fixture(scope="module")
def boxes():
    scene, masks, matches = two_boxes_scene()
    return scene, segment(scene, masks, matches)


@pytest.fixture(scope="module")
def one_box_one_view():
    """One box seen by one camera (on the -y side, looking at the box): an object seen in one view."""
    scene = box_scene([Box((0.0, 0.0, 0.04), (0.08, 0.06, 0.08))], views=1, shape=(120, 160), arc_deg=0.0)
    masks = [v.instances.astype(np.int32) for v in scene.views]
    return scene, segment(scene, masks, {})


def _rotate_about(T, centre, deg):
    """``T`` turned by ``deg`` about the vertical axis through ``centre``."""
    a = np.radians(deg)
    Rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    out = np.eye(4)
    out[:3, :3] = Rz @ T[:3, :3]
    out[:3, 3] = Rz @ (T[:3, 3] - centre) + centre
    return out


# ----------------------------------------------------------------------------- shapes
def test_suggest_views_shapes(boxes):
    scene, result = boxes
    ranked = suggest_views(scene, result, num_candidates=12)
    assert len(ranked) == 12 and sorted(r.index for r in ranked) == list(range(12))
    assert all(isinstance(r, ViewScore) and r.cam_to_world.shape == (4, 4) for r in ranked)
    assert all(set(r.terms) == set(TERMS) == set(r.raw) and all(0 <= x <= 1 for x in r.terms.values()) for r in ranked)
    scores = [r.score for r in ranked]
    assert scores == sorted(scores, reverse=True)
    assert all(np.isclose(r.score, sum(DEFAULT_WEIGHTS[t] * r.terms[t] for t in TERMS)) for r in ranked)
    assert json.loads(json.dumps([r.to_dict() for r in ranked]))[0]["index"] == ranked[0].index
    # every term has a best candidate (normalised to 1) unless it is 0 everywhere
    for t in TERMS:
        assert max(r.terms[t] for r in ranked) in (0.0, 1.0)


def test_sample_candidates_ring_at_the_working_distance(boxes):
    scene, result = boxes
    C = sample_candidates(scene, result, num=8)
    assert C.shape == (8, 4, 4)
    cams = np.array([v.camera_center for v in scene.views])
    lo, hi = result.object_points.points.min(0), result.object_points.points.max(0)
    centre = (lo + hi) / 2
    d = np.linalg.norm(C[:, :3, 3] - centre, axis=1)
    assert np.allclose(d, np.median(np.linalg.norm(cams - centre, axis=1)))
    # every candidate looks at the centre, the first from the first view's azimuth
    ray = centre - C[:, :3, 3]
    assert np.allclose(np.einsum("ij,ij->i", C[:, :3, 2], ray / d[:, None]), 1.0)
    flat = lambda p: (p - centre)[:2] / np.linalg.norm((p - centre)[:2])  # noqa: E731  (the table is z = 0)
    assert np.allclose(flat(C[0, :3, 3]), flat(cams[0]), atol=1e-2)
    # the same elevation as the cameras (the table normal is "up")
    el = lambda p: np.degrees(np.arcsin((p - centre)[2] / np.linalg.norm(p - centre)))  # noqa: E731
    assert np.allclose([el(c) for c in C[:, :3, 3]], np.mean([el(c) for c in cams]), atol=0.5)
    two = sample_candidates(scene, result, num=3, elevations=[10, 70], rng=1)
    assert two.shape == (6, 4, 4) and np.allclose([el(c) for c in two[:3, :3, 3]], 10, atol=0.5)


# ----------------------------------------------------------------------------- hand-computed
def test_closeness_hand_values():
    assert closeness([0.3, 0.6, 0.15, 0.45], 0.3, True, 2.0).round(4).tolist() == [1.0, 0.0, 0.0, round(1 - np.log(1.5) / np.log(2), 4)]
    assert closeness([np.nan, 0.0, -1.0], 0.3, True, 2.0).tolist() == [0.0, 0.0, 0.0]
    assert closeness([0.3], float("inf"), True, 2.0).tolist() == [0.0]
    with pytest.raises(ValueError, match="band: expected a number > 1"):
        closeness([0.3], 0.3, True, 1.0)


def test_ranking_of_an_object_seen_once(one_box_one_view):
    """One box seen by one view: ``under_seen`` has one target of weight (2 - 1) / 2 = 0.5.

    Candidates: (0) the view itself: novelty 0 -> 0; (1) the view turned by 15
    degrees about the vertical through the box: the angle at the box between
    the two cameras is theta (less than 15 degrees: the cameras look down), all
    of the seen surface stays in sight (a one-pixel z-buffer) -> 0.5 * 1 * theta / 30; (2) looking
    away -> 0; (3) turned by 45 degrees: theta > 30, novelty 1 -> 0.5.
    Ranking: 3, 1, then 0 and 2 (tie: lower index).
    """
    scene, result = one_box_one_view
    (t,) = under_seen_targets(scene, result)
    assert t.kind == "object" and t.weight == 0.5
    T0 = np.asarray(scene.views[0].cam_to_world)
    centre = t.center
    away = T0.copy()
    away[:3, :3] = T0[:3, :3] @ np.diag([-1.0, 1.0, -1.0])  # turned 180 degrees about its own y axis
    cands = np.stack([T0, _rotate_about(T0, centre, 15.0), away, _rotate_about(T0, centre, 45.0)])
    ranked = suggest_views(scene, result, cands, weights={"ambiguity": 0.0, "under_seen": 1.0, "table": 0.0}, zcell=1)
    assert [r.index for r in ranked] == [3, 1, 0, 2]
    raw = {r.index: r.raw["under_seen"] for r in ranked}
    assert raw[0] == 0.0 and raw[2] == 0.0
    a, b = T0[:3, 3] - centre, cands[1][:3, 3] - centre
    theta = np.degrees(np.arccos(a @ b / np.linalg.norm(a) / np.linalg.norm(b)))
    assert 10 < theta < 15
    assert raw[1] == pytest.approx(0.5 * theta / 30, abs=0.01) and raw[3] == pytest.approx(0.5, abs=0.01)
    assert {r.index: r.terms["under_seen"] for r in ranked}[1] == pytest.approx(theta / 30, abs=0.02)


def test_table_term_prefers_the_unseen_side(boxes):
    """From the far side of the table the cameras see the table behind the boxes; looking away sees nothing."""
    scene, result = boxes
    cells, area = unseen_table_cells(scene, result)
    assert len(cells) > 0 and area > 0
    centre = result.object_points.points.mean(0)
    T0 = np.asarray(scene.views[1].cam_to_world)
    far = _rotate_about(T0, centre, 180.0)
    up = np.eye(4)
    up[:3, :3] = look_at([0, 0, 1], [0, 0, 2], up=(0, 1, 0))[:3, :3]  # above the table, looking up
    up[:3, 3] = [0, 0, 1.0]
    ranked = suggest_views(scene, result, np.stack([T0, far, up]), weights={"ambiguity": 0.0, "under_seen": 0.0, "table": 1.0})
    raw = {r.index: r.raw["table"] for r in ranked}
    assert ranked[0].index == 1 and raw[2] == 0.0
    assert raw[1] > 5 * raw[0]  # the view the cameras already had sees (almost) nothing new


def test_equal_scores_rank_by_the_angle_to_the_nearest_camera(boxes):
    """All weights 0: every score is 0, so the ranking is by spread (largest first), then index."""
    scene, result = boxes
    centre = (result.object_points.points.min(0) + result.object_points.points.max(0)) / 2  # the scene centre
    T1 = np.asarray(scene.views[1].cam_to_world)  # the middle camera of the arc (-30, 0, +30 degrees)
    cands = np.stack([T1, _rotate_about(T1, centre, 90.0), _rotate_about(T1, centre, 180.0), T1])
    ranked = suggest_views(scene, result, cands, weights=dict.fromkeys(TERMS, 0.0))
    assert all(r.score == 0.0 for r in ranked) and [r.index for r in ranked] == [2, 1, 0, 3]
    spread = {r.index: r.spread for r in ranked}
    assert spread[0] == pytest.approx(0.0, abs=1e-3) and spread[3] == spread[0]
    b = cands[2][:3, 3] - centre  # the far side: the angle to the nearest camera (an end of the arc)
    angles = [np.degrees(np.arccos(a @ b / np.linalg.norm(a) / np.linalg.norm(b))) for a in (v.camera_center - centre for v in scene.views)]
    assert spread[2] == pytest.approx(min(angles), abs=1e-6) and min(angles) < angles[1]


def test_ambiguity_of_an_edge_at_its_threshold_and_of_a_conflict(boxes):
    scene, result = boxes
    g = result.graphs[0].copy()
    tau = result.info["stages"][0]["adders"]["pixel_match"]["tau"]
    g.edge_attr["ratio"] = np.full(g.num_edges, 4.0 * tau)  # far above: nothing ambiguous
    r2 = dataclasses.replace(result, graphs=[g])  # the mask graph alone: its pixel_match edges
    base = {t.objects: t.weight for t in ambiguity_targets(scene, r2, band=2.0) if t.kind == "edge"}
    assert base == {}
    e = 0
    obj = g.node_attr["object"]
    k = int(obj[g.edge_index[0, e]])
    g.edge_attr["ratio"][e] = tau * 2**0.5  # half-way to the band: closeness 0.5
    got = [t for t in ambiguity_targets(scene, r2, band=2.0) if t.kind == "edge"]
    assert [(t.objects, round(t.weight, 6)) for t in got] == [((k, k), 0.5)]
    assert got[0].points.shape[1] == 3 and len(got[0].points) > 0
    # a cannot-link inside one object is a conflict of weight 1
    g.edge_attr["sign"] = np.ones(g.num_edges)
    g.edge_attr["sign"][e] = -1.0
    got = {(t.kind, t.objects): t.weight for t in ambiguity_targets(scene, r2, band=2.0)}
    assert got.get(("conflict", (k, k))) == 1.0


def test_under_seen_counts_views(boxes):
    scene, result = boxes
    assert under_seen_targets(scene, result) == []  # both boxes in all 3 views
    one = scene.select([0])
    r1 = segment(one, [result.labels[0]], {})
    got = under_seen_targets(one, r1)
    assert [t.weight for t in got] == [0.5] * r1.num_objects and r1.num_objects == 2


# ----------------------------------------------------------------------------- edge cases
def test_bad_input(boxes):
    scene, result = boxes
    with pytest.raises(ValueError, match="weights: unknown term 'tabel'; choose from ambiguity, under_seen, table"):
        suggest_views(scene, result, weights={"tabel": 1.0})
    with pytest.raises(ValueError, match=r"weights\['table'\]: expected a finite number >= 0 \(got -1\)"):
        suggest_views(scene, result, weights={"table": -1})
    with pytest.raises(ValueError, match=r"candidates: expected cam_to_world poses \[C, 4, 4\] \(got \[3, 4\]\)"):
        suggest_views(scene, result, np.zeros((3, 4)))
    bad = np.stack([np.eye(4), np.diag([2.0, 1, 1, 1])])
    with pytest.raises(ValueError, match=r"candidates\[1\]: not a rigid transform"):
        suggest_views(scene, result, bad)
    with pytest.raises(ValueError, match="scene and result differ in views"):
        suggest_views(scene.select([0, 1]), result)
    no_pose = Scene([v.replace(cam_to_world=None) for v in scene.views], scene.objects, scene.name)
    with pytest.raises(SceneError, match="000: cam_to_world: next-best-view needs K and cam_to_world"):
        suggest_views(no_pose, result)
    with pytest.raises(ValueError, match="num: expected an integer >= 1 .got 0."):
        sample_candidates(scene, result, num=0)
    with pytest.raises(ValueError, match=r"elevations: expected degrees in \(-90, 90\) \(got 90\)"):
        sample_candidates(scene, result, elevations=[90])


def test_one_pose_no_objects_and_no_plane(boxes):
    scene, result = boxes
    one = suggest_views(scene, result, np.asarray(scene.views[0].cam_to_world))  # a single [4, 4] pose
    assert len(one) == 1 and one[0].index == 0
    empty = segment(scene, [np.zeros(v.shape, np.int32) for v in scene.views], {})
    assert empty.num_objects == 0
    ranked = suggest_views(scene, empty, num_candidates=6)  # centre from the optical axes
    assert len(ranked) == 6 and all(r.raw["ambiguity"] == 0 and r.raw["under_seen"] == 0 for r in ranked)
    no_plane = dataclasses.replace(result, info={**result.info, "background": {"plane": None}})
    assert unseen_table_cells(scene, no_plane)[0].shape == (0, 3)
    assert all(r.raw["table"] == 0 for r in suggest_views(scene, no_plane, num_candidates=4))


def test_inputs_are_not_modified_and_the_class_agrees(boxes):
    scene, result = boxes
    before = [g.edge_attr["ratio"].copy() for g in result.graphs if "ratio" in g.edge_attr]
    pts = [v.points.copy() for v in scene.views]
    a = suggest_views(scene, result, num_candidates=6, weights={"table": 0.5})
    b = NextBestView(weights={"table": 0.5}, num_candidates=6)(scene, result)
    assert [(r.index, r.score) for r in a] == [(r.index, r.score) for r in b]
    assert all(np.array_equal(x, g.edge_attr["ratio"], equal_nan=True) for x, g in zip(before, [g for g in result.graphs if "ratio" in g.edge_attr]))
    assert all(np.array_equal(p, v.points, equal_nan=True) for p, v in zip(pts, scene.views))
