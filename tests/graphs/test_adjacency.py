import numpy as np
import pytest

from graphseg.graphs import CorrespondenceGraph, Evidence, adjacency, edge_adders, repulsion
from graphseg.graphs.adjacency import SmoothAdjacency
from graphseg.graphs.repulsion import DepthRepulsion


# The pure functions take the criterion's Options (the one home of the defaults); the tests name
# only what they vary. model_construct skips the Options' own checks, so that the functions' are tested.
def _split(options_class, kw, extra=("rgb", "normals", "drop_unknown")):
    given = {k: v for k, v in kw.items() if k not in extra}
    return options_class.model_construct(**{**options_class().model_dump(), **given}), {k: v for k, v in kw.items() if k in extra}


def smooth_adjacency_links(*args, **kw):
    opts, rest = _split(SmoothAdjacency.Options, kw)
    return adjacency.smooth_adjacency_links(*args, opts, **rest)


def depth_jump_cannot_links(*args, **kw):
    opts, rest = _split(DepthRepulsion.Options, kw)
    return repulsion.depth_jump_cannot_links(*args, opts, **rest)


def boundary_separation(*args, **kw):
    opts, rest = _split(DepthRepulsion.Options, kw)
    return repulsion.boundary_separation(*args, opts, **rest)


def grid(h, w, z):
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float64) * 0.002  # 2 mm pixels
    return np.stack([xs, ys, z], -1).astype(np.float32)


def halves(h=20, w=20):
    lab = np.zeros((h, w), np.int64)
    lab[:, w // 2 :] = 1
    return lab


def test_boundary_separation_shape_and_counts():
    lab = halves(4, 6)
    pairs, count, sep = boundary_separation([lab], [grid(4, 6, np.zeros((4, 6)))], 2, reach=2, concave=None)
    assert pairs.shape == (2, 1) and count.shape == sep.shape == (1,)
    # reach 2 along rows: offset 1 -> 1 pair per row, offset 2 -> 2 pairs per row; 4 rows
    assert pairs.tolist() == [[0], [1]] and count.tolist() == [12] and sep.tolist() == [0.0]


def test_boundary_separation_no_contact():
    lab = np.array([[0, -1, -1, -1, 1]])
    pairs, count, sep = boundary_separation([lab], [grid(1, 5, np.zeros((1, 5)))], 2, reach=2)
    assert pairs.shape == (2, 0) and count.size == 0 and sep.size == 0
    assert boundary_separation([], [], 0)[0].shape == (2, 0)


def test_flat_surface_joins_step_and_crease_do_not():
    lab = halves(40, 40)
    flat = np.full((40, 40), 0.5)
    assert smooth_adjacency_links([lab], [grid(40, 40, flat)], 2, reach=4).edge_index.tolist() == [[0], [1]]
    step = flat.copy()
    step[:, 20:] += 0.05
    assert smooth_adjacency_links([lab], [grid(40, 40, step)], 2, reach=4).num_edges == 0
    x = (np.arange(40) - 19.5) * 0.002
    valley = np.broadcast_to(0.5 - 0.5 * np.abs(x), (40, 40))  # concave crease toward the camera
    assert smooth_adjacency_links([lab], [grid(40, 40, valley)], 2, reach=4, concave=0.1).num_edges == 0
    # the same pair is exactly what depth_repulsion forbids
    assert depth_jump_cannot_links([lab], [grid(40, 40, valley)], 2, reach=4, concave=0.1).num_edges == 1


def test_colour_edge_is_a_separation():
    lab = halves(30, 30)
    pts = grid(30, 30, np.full((30, 30), 0.5))
    rgb = np.zeros((30, 30, 3), np.uint8)
    rgb[:] = (200, 180, 40)  # yellow
    same = smooth_adjacency_links([lab], [pts], 2, rgb=[rgb], color=10.0)
    rgb[:, 15:] = (40, 60, 200)  # blue right half
    edge = smooth_adjacency_links([lab], [pts], 2, rgb=[rgb], color=10.0)
    shade = rgb.copy()
    shade[:, 15:] = (180, 162, 36)  # 10% darker: lightness is left out (a*b* move by 6 < 10)
    shaded = smooth_adjacency_links([lab], [pts], 2, rgb=[shade], color=10.0)
    assert same.num_edges == 1 and edge.num_edges == 0 and shaded.num_edges == 1


def test_min_pairs_and_weight():
    lab = halves(10, 10)
    pts = grid(10, 10, np.full((10, 10), 0.5))
    es = smooth_adjacency_links([lab], [pts], 2, reach=1, min_pairs=10, concave=None)
    assert es.edge_attr["count"].tolist() == [10] and es.edge_attr["weight"].tolist() == [1.0]
    assert smooth_adjacency_links([lab], [pts], 2, reach=1, min_pairs=11, concave=None).num_edges == 0
    # with the concave test, pairs without normals (normal_step 3 px from the border) are left out
    assert smooth_adjacency_links([lab], [pts], 2, reach=1, min_pairs=1).edge_attr["count"].tolist() == [4]


def test_invalid_points_are_ignored():
    lab = halves(10, 10)
    pts = grid(10, 10, np.full((10, 10), 0.5))
    pts[:, 4:6] = np.nan  # the seam has no depth
    assert smooth_adjacency_links([lab], [pts], 2, reach=1, min_pairs=1).num_edges == 0
    assert smooth_adjacency_links([lab], [None], 2).num_edges == 0


def test_adder_registered_and_options_validated():
    g = CorrespondenceGraph.from_masks([np.array([[1, 1, 2, 2]])])
    pts = grid(1, 4, np.zeros((1, 4)))
    adder = edge_adders.resolve("smooth_adjacency", min_pairs=1, color=None, concave=None)
    assert isinstance(adder, SmoothAdjacency)
    assert "rgb" in SmoothAdjacency.requires and "points" in SmoothAdjacency.requires
    assert adder(g, Evidence.for_graph(g, points=[pts])).num_edges == 1
    with pytest.raises(ValueError):
        SmoothAdjacency(max_separated=1.5)
    with pytest.raises(ValueError, match="world points"):
        adder(g, Evidence.for_graph(g))
    with pytest.raises(ValueError, match="rgb"):
        SmoothAdjacency(min_pairs=1, color=10.0)(g, Evidence.for_graph(g, points=[pts]))
    assert SmoothAdjacency(min_pairs=1, color=None, concave=None)(g, Evidence.for_graph(g, points=[pts])).num_edges == 1
    with pytest.raises(ValueError, match="all None"):
        SmoothAdjacency(jump=None, concave=None, color=None)
    with pytest.raises(ValueError, match="no separation test"):
        smooth_adjacency_links([np.array([[0, 1]])], [pts[:, :2]], 2, jump=None, concave=None)


def test_depth_repulsion_concave_only():
    """jump=None: only concave creases separate; a plain step does not."""
    lab = halves(40, 40)
    step = np.full((40, 40), 0.5)
    step[:, 20:] += 0.05
    assert depth_jump_cannot_links([lab], [grid(40, 40, step)], 2, reach=4).num_edges == 1
    assert depth_jump_cannot_links([lab], [grid(40, 40, step)], 2, reach=4, jump=None, concave=0.1).num_edges == 0
    with pytest.raises(ValueError, match="both None"):
        depth_jump_cannot_links([lab], [grid(40, 40, step)], 2, jump=None)
    with pytest.raises(ValueError, match="both None"):
        DepthRepulsion(jump=None)


def test_crease_next_to_a_depth_hole_is_no_evidence():
    """Normals are unknown near invalid depth: those boundary pairs are left out, not counted as smooth."""
    lab = halves(40, 40)
    x = (np.arange(40) - 19.5) * 0.002
    valley = np.broadcast_to(0.5 - 0.5 * np.abs(x), (40, 40)).copy()
    pts = grid(40, 40, valley)
    assert smooth_adjacency_links([lab], [pts], 2, reach=4, concave=0.1).num_edges == 0
    holed = pts.copy()
    holed[:, 15:17] = np.nan  # holes 3-4 px from the seam; the seam pixels keep their depth
    holed[:, 23:25] = np.nan
    assert smooth_adjacency_links([lab], [holed], 2, reach=1, concave=0.1, min_pairs=1).num_edges == 0


def test_views_are_pooled_and_rgb_is_checked():
    lab = halves(20, 20)
    pts = grid(20, 20, np.full((20, 20), 0.5))
    one = smooth_adjacency_links([lab], [pts], 2, reach=1, concave=None, min_pairs=1)
    two = smooth_adjacency_links([lab, lab], [pts, pts], 2, reach=1, concave=None, min_pairs=1)
    skipped = smooth_adjacency_links([lab, lab], [pts, None], 2, reach=1, concave=None, min_pairs=1)
    assert two.edge_attr["count"].tolist() == [2 * one.edge_attr["count"][0]] and skipped.edge_attr["count"].tolist() == one.edge_attr["count"].tolist()
    rgb = np.zeros((20, 20, 3), np.uint8)
    with pytest.raises(ValueError, match=r"expected rgb\[0\] of shape \[20, 20, 3\] and dtype uint8 \(got \[5, 6, 3\] uint8\)"):
        smooth_adjacency_links([lab], [pts], 2, rgb=[np.zeros((5, 6, 3), np.uint8)])
    with pytest.raises(ValueError, match="dtype uint8"):
        smooth_adjacency_links([lab], [pts], 2, rgb=[rgb.astype(np.float32)])
    with pytest.raises(ValueError, match="one rgb image per view"):
        smooth_adjacency_links([lab, lab], [pts, pts], 2, rgb=[rgb])
