import numpy as np
import pytest

from graphseg.graphs import CorrespondenceGraph, Evidence, edge_adders, repulsion
from graphseg.graphs.repulsion import DepthRepulsion

# The pure functions take DepthRepulsion.Options (the one home of the defaults); the tests name only
# what they vary. model_construct skips the Options' own checks, so that the functions' are tested.
_DEFAULTS = DepthRepulsion.Options().model_dump()


def _options(kw):
    return DepthRepulsion.Options.model_construct(**{**_DEFAULTS, **{k: v for k, v in kw.items() if k != "normals"}}), {k: v for k, v in kw.items() if k == "normals"}


def depth_jump_cannot_links(*args, **kw):
    opts, rest = _options(kw)
    return repulsion.depth_jump_cannot_links(*args, opts, **rest)


def boundary_separation(*args, **kw):
    opts, rest = _options(kw)
    return repulsion.boundary_separation(*args, opts, **rest)


def boundary_jumps(*args, **kw):
    return repulsion.boundary_jumps(*args, **{"reach": _DEFAULTS["reach"], **kw})


def grid(h, w, z):
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float64) * 0.002  # 2 mm pixels
    return np.stack([xs, ys, z], -1).astype(np.float32)


def test_boundary_jumps_shape_and_values():
    lab = np.array([[0, 0, 1, 1]])
    pts = grid(1, 4, np.array([[0.0, 0.0, 0.1, 0.1]]))
    lo, hi, d, c, k = boundary_jumps(lab, pts, 2, reach=2)
    assert lo.shape == hi.shape == d.shape == c.shape == k.shape == (3,)  # offsets 1 (one pair) and 2 (two pairs)
    assert set(lo.tolist()) == {0} and set(hi.tolist()) == {1}
    assert np.all(d > 0.09) and np.all(np.isnan(c)) and np.all(np.isnan(k))
    colors = np.array([[[0.0, 0.0], [3.0, 4.0], [6.0, 8.0], [6.0, 8.0]]])
    k = boundary_jumps(lab, pts, 2, reach=2, colors=colors)[4]
    assert sorted(k.tolist()) == [5.0, 5.0, 10.0]  # pixels (1, 2), (0, 2), (1, 3)


def test_boundary_jumps_bad_points():
    with pytest.raises(ValueError, match=r"points of shape \[1, 2, 3\]"):
        boundary_jumps(np.zeros((1, 2), int), np.zeros((2, 2, 3)), 1)
    with pytest.raises(ValueError, match=r"colors of shape \[1, 2, C\] \(got \[2, 2, 3\]\)"):
        boundary_jumps(np.zeros((1, 2), int), np.zeros((1, 2, 3)), 1, colors=np.zeros((2, 2, 3)))


def test_step_is_cannot_link_flat_is_not():
    lab = np.zeros((20, 20), np.int64)
    lab[:, 10:] = 1
    z = np.zeros((20, 20))
    assert depth_jump_cannot_links([lab], [grid(20, 20, z)], 2).num_edges == 0
    z[:, 10:] = 0.05
    es = depth_jump_cannot_links([lab], [grid(20, 20, z)], 2)
    assert es.edge_index.tolist() == [[0], [1]] and es.edge_attr["sign"].tolist() == [-1.0]


def test_concave_crease_is_cannot_link_ridge_is_not():
    # camera looks down +z (OpenCV); a valley (\/) is concave, a ridge (/\) convex
    lab = np.zeros((40, 40), np.int64)
    lab[:, 20:] = 1
    x = (np.arange(40) - 19.5) * 0.002
    valley = np.broadcast_to(0.5 - 0.5 * np.abs(x), (40, 40))
    ridge = np.broadcast_to(0.5 + 0.5 * np.abs(x), (40, 40))
    def links(z):
        return depth_jump_cannot_links([lab], [grid(40, 40, z)], 2, concave=0.1, reach=4).num_edges
    assert links(valley) == 1
    assert links(ridge) == 0
    assert depth_jump_cannot_links([lab], [grid(40, 40, valley)], 2, reach=4).num_edges == 0  # no jump without the concave test


def test_same_view_rule():
    lab = np.array([[0, -1, -1, 1]] * 12)  # two masks that do not touch
    pts = grid(12, 4, np.zeros((12, 4)))
    assert depth_jump_cannot_links([lab], [pts], 2, reach=1).num_edges == 0
    assert depth_jump_cannot_links([lab], [pts], 2, reach=1, same_view=True).edge_index.tolist() == [[0], [1]]


def test_adder_registered_and_options_validated():
    g = CorrespondenceGraph.from_masks([np.array([[1, 1, 2, 2]])])
    pts = grid(1, 4, np.array([[0, 0, 0.3, 0.3]]))
    adder = edge_adders.resolve("depth_repulsion", min_pairs=1)
    assert isinstance(adder, DepthRepulsion)
    assert adder(g, Evidence.for_graph(g, points=[pts])).num_edges == 1
    with pytest.raises(ValueError):
        DepthRepulsion(jump=-1.0)
    with pytest.raises(ValueError, match="world points"):
        adder(g, Evidence.for_graph(g))


def test_given_normals_give_the_same_links_and_are_checked():
    from graphseg.geometry import point_normals

    lab = np.zeros((40, 40), np.int64)
    lab[:, 20:] = 1
    x = (np.arange(40) - 19.5) * 0.002
    pts = grid(40, 40, np.broadcast_to(0.5 - 0.5 * np.abs(x), (40, 40)))  # a valley: concave
    own = boundary_separation([lab], [pts], 2, jump=None, concave=0.1, reach=4, normal_step=2)
    given = boundary_separation([lab], [pts], 2, jump=None, concave=0.1, reach=4, normal_step=2, normals=[point_normals(pts, 2)])
    assert all(np.array_equal(a, b) for a, b in zip(own, given)) and own[2][0] >= 0.9  # rows at the border have no normals
    # a flat normal map given for the valley: no crease is seen (the given normals are used, not recomputed)
    flat = np.broadcast_to(np.float32([0, 0, 1]), pts.shape)
    assert boundary_separation([lab], [pts], 2, jump=None, concave=0.1, reach=4, normal_step=2, normals=[flat])[2].tolist() == [0.0]
    with pytest.raises(ValueError, match=r"expected normals\[0\] of shape \[40, 40, 3\] \(got \[4, 4, 3\]\)"):
        boundary_separation([lab], [pts], 2, jump=None, concave=0.1, normals=[np.zeros((4, 4, 3))])
    with pytest.raises(ValueError, match=r"one normal map per view \(1\) \(got 2\)"):
        boundary_separation([lab], [pts], 2, jump=None, concave=0.1, normals=[flat, flat])


def test_criteria_share_the_evidence_normals(monkeypatch):
    import graphseg.graphs.evidence as evidence_mod
    import graphseg.graphs.repulsion as repulsion_mod

    calls = []
    real = evidence_mod.point_normals
    monkeypatch.setattr(evidence_mod, "point_normals", lambda p, step: calls.append(step) or real(p, step))

    def recompute(*args, **kwargs):
        raise AssertionError("normals recomputed instead of taken from the evidence")

    monkeypatch.setattr(repulsion_mod, "point_normals", recompute)
    lab = np.zeros((40, 40), np.int64)
    lab[:, 20:] = 1
    x = (np.arange(40) - 19.5) * 0.002
    pts = grid(40, 40, np.broadcast_to(0.5 - 0.5 * np.abs(x), (40, 40)))
    g = CorrespondenceGraph.from_masks([lab + 1])
    ev = Evidence.for_graph(g, points=[pts])
    rep = edge_adders.resolve("depth_repulsion", jump=None, concave=0.1, reach=4, normal_step=2, min_pairs=1)
    first = rep(g, ev)
    again = rep(g, Evidence.for_graph(g, points=[pts], normal_cache=ev.normal_cache))  # the next stage's evidence
    assert first.edge_index.tolist() == again.edge_index.tolist() == [[0], [1]]
    assert calls == [2]  # computed once for both calls
    edge_adders.resolve("smooth_adjacency", normal_step=3, color=None)(g, ev)
    assert calls == [2, 3]
