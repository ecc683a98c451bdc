import numpy as np
import pytest

from graphseg.method.refine import project_to_view, refine_labels

K = np.array([[10.0, 0, 2], [0, 10, 2], [0, 0, 1]])


def plane(z=1.0, shape=(5, 5)):
    """World points of a fronto-parallel plane seen by an identity camera with K."""
    h, w = shape
    ys, xs = np.mgrid[0:h, 0:w]
    pm = np.zeros((h, w, 3))
    pm[..., 0], pm[..., 1], pm[..., 2] = (xs - 2) / 10 * z, (ys - 2) / 10 * z, z
    return pm


def test_project_to_view_shapes_and_visibility():
    pm = plane()
    pts = np.array([[0.0, 0, 1], [0, 0, 2], [0, 0, -1], [5, 0, 1]])  # on the plane, behind it, behind the camera, outside
    seen, v, u = project_to_view(pts, K, np.eye(4), pm)
    assert seen.shape == v.shape == u.shape == (4,)
    assert seen.tolist() == [True, False, False, False] and (int(v[0]), int(u[0])) == (2, 2)
    pm[2, 2] = np.nan  # an invalid pixel sees nothing
    assert not project_to_view(pts[:1], K, np.eye(4), pm)[0][0]


def test_a_mask_straddling_two_objects_is_split_by_the_other_views():
    pm = plane()
    straddle = np.ones((5, 5), int)  # view 0: one mask over both objects
    truth = np.ones((5, 5), int)
    truth[:, 3:] = 2  # views 1 and 2 separate them
    out, info = refine_labels([straddle, truth, truth], [pm] * 3, [(K, np.eye(4))] * 3)
    assert out[0].tolist() == truth.tolist() and info["changed"] == 10 and info["per_view"] == [10, 0, 0]
    assert straddle.max() == 1  # input untouched


def test_min_views_and_self_weight():
    pm = plane()
    a, b = np.full((5, 5), 1), np.full((5, 5), 2)
    # one other view disagrees: below min_views 2, nothing changes
    out, info = refine_labels([a, b], [pm] * 2, [(K, np.eye(4))] * 2)
    assert info["changed"] == 0 and out[0].tolist() == a.tolist()
    # with min_views 1 the vote ties the own label (1 vs 1): no change; self_weight 0.5 loses
    assert refine_labels([a, b], [pm] * 2, [(K, np.eye(4))] * 2, min_views=1)[1]["changed"] == 0
    assert refine_labels([a, b], [pm] * 2, [(K, np.eye(4))] * 2, min_views=1, self_weight=0.5)[1]["changed"] == 50


def test_confidence_weights_the_votes():
    pm = plane()
    a, b = np.full((5, 5), 1), np.full((5, 5), 2)
    low = [None, np.full((5, 5), 0.4), np.full((5, 5), 0.4)]
    # two votes of 0.4 (0.8) do not outweigh the own label (1.0); at full confidence (2.0) they do
    assert refine_labels([a, b, b], [pm] * 3, [(K, np.eye(4))] * 3, confidence=low)[1]["changed"] == 0
    assert refine_labels([a, b, b], [pm] * 3, [(K, np.eye(4))] * 3, confidence=low)[0][0].max() == 1
    assert refine_labels([a, b, b], [pm] * 3, [(K, np.eye(4))] * 3)[0][0].min() == 2


def test_edge_cases():
    pm = plane()
    a = np.full((5, 5), 1)
    assert refine_labels([a], [pm], [(K, np.eye(4))])[1]["changed"] == 0  # one view
    assert refine_labels([a, a * 2], [pm] * 2, [(None, None), (K, np.eye(4))])[1]["changed"] == 0  # no camera
    z = np.zeros((5, 5), int)
    out, info = refine_labels([z, z], [pm] * 2, [(K, np.eye(4))] * 2)
    assert info == {"changed": 0, "per_view": [0, 0]} and out[0] is not z
    with pytest.raises(ValueError, match="same views"):
        refine_labels([a], [pm, pm], [(K, np.eye(4))])
    with pytest.raises(ValueError, match="min_views"):
        refine_labels([a], [pm], [(K, np.eye(4))], min_views=0)


def test_segment_runs_refinement_when_enabled():
    from graphseg.config import Config
    from graphseg.method import segment
    from graphseg.testing.scenes import two_boxes_scene

    scene, masks, matches = two_boxes_scene(parts=2, views=3)
    off = segment(scene, masks, matches, Config())
    on = segment(scene, masks, matches, Config(refine={"enabled": True}))
    assert off.info["refine"] is None and "refine" not in off.info["timings"]
    assert on.info["refine"]["changed"] >= 0 and "refine" in on.info["timings"]
    assert all(a.shape == b.shape for a, b in zip(on.labels, off.labels))
