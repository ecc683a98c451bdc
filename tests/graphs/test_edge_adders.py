import numpy as np
import pytest

from graphseg.graphs import (
    Chamfer3D,
    CorrespondenceGraph,
    Evidence,
    FeatureSimilarity,
    PixelMatch,
    chamfer_edges,
    directed_chamfer,
    node_mean_features,
    node_point_sets,
    pair_counts,
    pixel_match,
    remove_outliers,
)
from graphseg.scene import Matches


def pixel_match_edges(*args, **kw):
    # every option is a required keyword; what a test leaves out comes from PixelMatch.Options
    return pixel_match.pixel_match_edges(*args, **{**PixelMatch.Options().model_dump(), **kw})


def test_pair_counts_dense_and_sparse_agree():
    rng = np.random.default_rng(0)
    a, b = rng.integers(0, 50, 1000), rng.integers(0, 50, 1000)
    u1, v1, c1 = pair_counts(a, b, 50)
    u2, v2, c2 = pair_counts(a, b, 100_000)  # forces the sort path (values < 50 anyway)
    assert np.array_equal(u1, u2) and np.array_equal(v1, v2) and np.array_equal(c1, c2)
    assert c1.sum() == 1000
    z = pair_counts(np.zeros(0, int), np.zeros(0, int), 10**6)
    assert all(x.size == 0 for x in z)


def two_view_labels():
    # view 0: masks 0 (left half) and 1 (right half); view 1: masks 2 and 3, same layout
    l0 = np.zeros((4, 8), np.int64)
    l0[:, 4:] = 1
    l1 = l0 + 2
    return [l0, l1]


def test_pixel_match_hand_computed_ratio_and_threshold():
    labels = two_view_labels()
    # 8 matches left->left, 2 matches right->right, 1 left->right
    xy = np.array([[0, 0]] * 8 + [[5, 0]] * 2 + [[1, 1]], float)
    xy2 = np.array([[0, 1]] * 8 + [[6, 1]] * 2 + [[7, 3]], float)
    m = {(0, 1): Matches(xy, xy2, np.ones(11))}
    areas = np.array([16, 16, 16, 16])
    es = pixel_match_edges(labels, m, 4, areas=areas, tau=0.1, min_matches=1)
    got = {(int(u), int(v)): r for u, v, r in zip(*es.edge_index, es.edge_attr["ratio"])}
    assert got == {(0, 2): 0.5, (1, 3): 0.125}
    assert es.edge_attr["count"].tolist() == [8, 2]
    # percentile threshold: 78th percentile of [1/16, 2/16, 8/16]
    es = pixel_match_edges(labels, m, 4, areas=areas, min_matches=1)
    assert es.info["tau"] == pytest.approx(np.percentile([1 / 16, 2 / 16, 8 / 16], 78))
    assert es.edge_index.T.tolist() == [[0, 2]]
    # official normalisation: hits of mask 0 = 9, mask 2 = 8 -> 8 / 8
    es = pixel_match_edges(labels, m, 4, areas=areas, tau=0.0, normalization="hits", min_matches=1)
    got = {(int(u), int(v)): r for u, v, r in zip(*es.edge_index, es.edge_attr["ratio"])}
    assert got[(0, 2)] == 1.0 and got[(0, 3)] == pytest.approx(1 / 3)
    # per view pair: same numbers here (one view pair); a second identical pair doubles the
    # global hits but leaves the per-pair ratio alone
    m2 = {(0, 1): m[(0, 1)], (1, 0): Matches(xy2, xy, np.ones(11))}
    g = pixel_match_edges(labels, m2, 4, areas=areas, tau=0.0, normalization="hits", min_matches=1)
    p = pixel_match_edges(labels, m2, 4, areas=areas, tau=0.0, normalization="pair_hits", min_matches=1)
    assert g.edge_attr["ratio"][0] == pytest.approx(1.0) and p.edge_attr["ratio"][0] == pytest.approx(1.0)
    assert g.edge_attr["count"][0] == 16
    with pytest.raises(ValueError, match="normalization"):
        pixel_match_edges(labels, m, 4, areas=areas, normalization="x")


def test_pixel_match_consistency_uses_each_images_own_pixel():
    labels = two_view_labels()
    p0 = np.zeros((4, 8, 3), np.float32)
    p1 = np.zeros((4, 8, 3), np.float32)
    p1[:, 4:] = 5.0  # right half of view 1 is far away in 3D from everything in view 0
    xy = np.array([[0, 0]] * 9 + [[5, 0]], float)
    xy2 = np.array([[0, 0]] * 9 + [[5, 0]], float)
    m = {(0, 1): Matches(xy, xy2, np.ones(10))}
    es = pixel_match_edges(labels, m, 4, areas=np.full(4, 16), tau=0.0, min_matches=1, points=[p0, p1], consistency_percentile=90)
    assert es.edge_index.T.tolist() == [[0, 2]]  # the inconsistent right->right match was dropped
    with pytest.raises(ValueError, match="needs world points"):
        pixel_match_edges(labels, m, 4, areas=np.full(4, 16), consistency_percentile=90)


def test_min_matches_keeps_stray_pairs_out_of_the_percentile():
    labels = two_view_labels()
    xy = np.array([[0, 0]] * 8 + [[5, 0]] * 2 + [[1, 1]], float)
    xy2 = np.array([[0, 1]] * 8 + [[6, 1]] * 2 + [[7, 3]], float)
    m = {(0, 1): Matches(xy, xy2, np.ones(11))}
    es = pixel_match_edges(labels, m, 4, areas=np.full(4, 16), min_matches=2, percentile=0)
    # the single stray match (0 -> 3) is ignored; the threshold is the minimum of [2/16, 8/16]
    assert es.info["eligible"] == 2 and es.info["tau"] == pytest.approx(2 / 16)
    assert es.edge_index.T.tolist() == [[0, 2], [1, 3]]


def test_pixel_match_out_of_image_and_empty():
    labels = two_view_labels()
    m = {(0, 1): Matches([[100, 100]], [[0, 0]], [1.0]), (1, 0): Matches(np.zeros((0, 2)), np.zeros((0, 2)), [])}
    es = pixel_match_edges(labels, m, 4, areas=np.full(4, 16))
    assert es.num_edges == 0 and es.info["tau"] == np.inf


def test_pixel_match_large_input_is_vectorised():
    rng = np.random.default_rng(0)
    labels = [rng.integers(-1, 100, (480, 640)) + 100 * v for v in range(2)]
    labels = [np.where(lab < 100 * v, -1, lab) for v, lab in enumerate(labels)]
    n = 200
    m = {(0, 1): Matches(rng.uniform(0, 639, (500_000, 2)), rng.uniform(0, 479, (500_000, 2)), np.ones(500_000))}
    import time

    t = time.perf_counter()
    es = pixel_match_edges(labels, m, n, areas=np.full(n, 3000))
    assert time.perf_counter() - t < 5.0  # a Python loop over 500k matches would take far longer
    assert es.num_edges > 0


def test_node_point_sets_voxel_and_stride():
    lab = np.array([[0, 0, 1, -1]])
    pts = np.array([[[0, 0, 0], [0.001, 0, 0], [1, 1, 1], [2, 2, 2]]], np.float32)
    ps = node_point_sets([lab], [pts], 2)
    assert ps.ptr.tolist() == [0, 2, 3] and ps.points.shape == (3, 3)
    ps = node_point_sets([lab], [pts], 2, voxel_size=0.01, colors=[np.full((1, 4, 3), 7, np.uint8)])
    assert ps.ptr.tolist() == [0, 1, 2]
    np.testing.assert_allclose(ps[0], [[0.0005, 0, 0]])
    assert ps.colors.tolist() == [[7, 7, 7], [7, 7, 7]]
    ps = node_point_sets([lab], [pts], 2, stride=2)
    assert ps.ptr.tolist() == [0, 1, 2]
    assert node_point_sets([lab], [None], 2).points.shape == (0, 3)


def test_directed_chamfer_hand_computed():
    x = np.array([[0.0, 0, 0], [0, 0, 2]])
    y = np.array([[0.0, 0, 1]])
    assert directed_chamfer(x, y) == pytest.approx(1.0)
    assert directed_chamfer(y, x) == pytest.approx(1.0)
    assert directed_chamfer(np.zeros((0, 3)), y) == np.inf
    assert directed_chamfer(x, y, upper=0.01) == np.inf  # early exit


def grid_object(center, n=6, spacing=0.004):
    g = np.stack(np.meshgrid(*[np.arange(n) * spacing] * 3, indexing="ij"), -1).reshape(-1, 3)
    return g + np.asarray(center)


def test_chamfer_edges_pruned_equals_brute_force():
    rng = np.random.default_rng(0)
    from graphseg.graphs.chamfer import PointSets

    objs = [grid_object(rng.uniform(0, 0.3, 3)) for _ in range(25)]
    pts = np.concatenate(objs)
    ptr = np.r_[0, np.cumsum([len(o) for o in objs])]
    sets = PointSets(pts, ptr)
    a = chamfer_edges(sets, 5e-4, prune=True)
    b = chamfer_edges(sets, 5e-4, prune=False)
    assert a.edge_index.T.tolist() == b.edge_index.T.tolist()
    assert a.info["candidates"] <= b.info["candidates"]
    # brute force reference
    from scipy.spatial.distance import cdist

    ref = set()
    for i in range(25):
        for j in range(i + 1, 25):
            d = cdist(objs[i], objs[j], "sqeuclidean")
            if min(d.min(1).mean(), d.min(0).mean()) <= 5e-4:
                ref.add((i, j))
    assert {tuple(e) for e in a.edge_index.T.tolist()} == ref


def test_chamfer_adder_and_outliers():
    lab = np.array([[0, 0, 1, 1, 2]])
    pts = np.array([[[0, 0, 0], [0.002, 0, 0], [0.004, 0, 0], [0.006, 0, 0], [1, 1, 1]]], np.float32)
    g = CorrespondenceGraph(3, node_attr={"area": [2, 2, 1]})
    es = Chamfer3D(voxel_size=None, stride=1)(g, Evidence([lab], points=[pts]))
    assert es.edge_index.T.tolist() == [[0, 1]]
    assert es.edge_attr["criterion"].tolist() == ["chamfer_3d"]
    with pytest.raises(ValueError, match="needs world points"):
        Chamfer3D()(g, Evidence([lab]))


def test_remove_outliers_statistical_and_dbscan():
    from graphseg.graphs.chamfer import PointSets

    rng = np.random.default_rng(0)
    blob = rng.normal(0, 0.005, (200, 3))
    pts = np.concatenate([blob, [[1.0, 1, 1]]])
    sets = PointSets(pts, np.array([0, 201]))
    o = Chamfer3D.Options()
    defaults = {"k": o.outlier_k, "std_ratio": o.outlier_std_ratio, "eps": o.dbscan_eps, "min_samples": o.dbscan_min_samples}
    assert len(remove_outliers(sets, "statistical", **defaults).points) <= 200
    out = remove_outliers(sets, "dbscan", **{**defaults, "eps": 0.01, "min_samples": 3})
    assert not np.any(np.all(out.points == 1.0, axis=1))
    assert remove_outliers(sets, None, **defaults) is sets
    with pytest.raises(ValueError, match="unknown outlier method"):
        remove_outliers(sets, "magic", **defaults)


def test_dbscan_drops_a_detached_patch_that_would_bridge_objects():
    """A node (a block) holding a small detached patch of points where another object
    (a marker fragment) lies: the fragment's directed Chamfer to the block is ~0 and
    joins them. DBSCAN (robust preset: eps 2 cm, 15 samples) keeps the block's main
    body, the patch goes, and so does the edge (YCB-Video 0002, oracle parts k = 4)."""
    from graphseg.config import Config

    g0, g1 = np.mgrid[0:20, 0:20] * 0.005  # 10 x 10 cm block face, 5 mm grid (the voxel size)
    block = np.stack([g0.ravel(), g1.ravel(), np.zeros(400)], 1)
    speck = np.array([0.2, 0.05, 0.0]) + np.random.default_rng(0).normal(0, 0.002, (12, 3))  # 10 cm from the face
    marker = np.array([0.2, 0.05, 0.0]) + np.random.default_rng(1).normal(0, 0.002, (10, 3))
    pts = np.concatenate([block, speck, marker]).astype(np.float32)[None]
    lab = np.array([[0] * 412 + [1] * 10])
    g = CorrespondenceGraph(2, node_attr={"area": [412, 10]})
    opts = {**Config.preset("robust").criterion_options("chamfer_3d"), "voxel_size": None, "stride": 1}
    assert Chamfer3D(**{**opts, "outliers": None})(g, Evidence([lab], points=[pts])).edge_index.T.tolist() == [[0, 1]]
    assert Chamfer3D(**opts)(g, Evidence([lab], points=[pts])).num_edges == 0
    kept = Chamfer3D(**opts).point_sets(g, Evidence([lab], points=[pts]))
    np.testing.assert_array_equal(kept[0], pts[0, :400])  # the block's face, without the patch
    assert kept.sizes().tolist() == [400, 10]  # a node under min_samples points is left alone


def test_feature_similarity():
    lab = [np.array([[0, 0, 1, 1]]), np.array([[2, 2, -1, -1]])]
    feats = [np.array([[[1.0, 0], [1, 0], [0, 1], [0, 1]]]), np.array([[[1.0, 0.1], [1, 0.1], [0, 0], [0, 0]]])]
    nf = node_mean_features(lab, feats, 3)
    np.testing.assert_allclose(nf, [[1, 0], [0, 1], [1, 0.1]])
    g = CorrespondenceGraph(3, node_attr={"view": np.array([0, 0, 1])})
    es = FeatureSimilarity(threshold=0.9)(g, Evidence(lab, features=feats))
    assert es.edge_index.T.tolist() == [[0, 2]]
    es = FeatureSimilarity(threshold=0.9)(g, Evidence(lab, features=nf))
    assert es.num_edges == 1
    with pytest.raises(ValueError, match="needs features"):
        FeatureSimilarity()(g, Evidence(lab))
    with pytest.raises(ValueError, match=r"expected node features of shape \[3, D\]"):
        FeatureSimilarity()(g, Evidence(lab, features=np.ones((2, 2))))


def test_pixel_match_adder_class():
    labels = two_view_labels()
    g = CorrespondenceGraph(4, node_attr={"area": np.full(4, 16)})
    m = {(0, 1): Matches([[0, 0]], [[0, 0]], [1.0])}
    es = PixelMatch(tau=0.01, min_matches=1)(g, Evidence(labels, matches=m))
    assert es.edge_index.T.tolist() == [[0, 2]]


def test_node_point_sets_drops_nonfinite_and_keeps_dtype_rules():
    lab = np.array([[0, 0, 1, 1]])
    pts = np.array([[[0, 0, 0], [np.inf, 0, 0], [1, np.nan, 1], [1, 1, 1]]], np.float64)
    ps = node_point_sets([lab], [pts], 2)
    assert ps.ptr.tolist() == [0, 1, 2] and ps.points.dtype == np.float64
    assert ps.points.tolist() == [[0, 0, 0], [1, 1, 1]]
    # float64 and float32 input give the same sets (points are gathered as float32)
    ref = node_point_sets([lab], [pts.astype(np.float32)], 2, voxel_size=0.5)
    got = node_point_sets([lab], [pts], 2, voxel_size=0.5)
    assert np.array_equal(ref.points, got.points) and np.array_equal(ref.ptr, got.ptr)


def test_batched_directed_centroid_prefilter_is_exact():
    # the centroid-to-box bound only drops pairs the per-point bound would drop
    from graphseg.graphs.chamfer import PointSets, _batched_directed

    rng = np.random.default_rng(3)
    objs = [grid_object(rng.uniform(0, 0.08, 3), n=4) for _ in range(30)]
    sets = PointSets(np.concatenate(objs), np.r_[0, np.cumsum([len(o) for o in objs])])
    src, dst = np.triu_indices(30, 1)
    lo = np.stack([o.min(0) for o in objs])
    hi = np.stack([o.max(0) for o in objs])
    cen = np.stack([o.mean(0) for o in objs])
    for tau in (1e-5, 5e-4, 1e-3):
        plain = _batched_directed(sets, src, dst, tau)
        fast = _batched_directed(sets, src, dst, tau, centroids=cen, boxes=(lo, hi))
        assert np.array_equal(plain <= tau, fast <= tau)
        assert np.array_equal(plain[plain <= tau], fast[fast <= tau])
    assert _batched_directed(sets, src[:0], dst[:0], 5e-4, centroids=cen, boxes=(lo, hi)).shape == (0,)


def test_strongest_attachments_hand_computed():
    from graphseg.graphs.chamfer import strongest_attachments

    # node 0 (10 px) touches objects 1 (500) and 2 (400); 1 and 2 are peers; 3 (300) is a peer of 2
    ei = np.array([[0, 0, 1, 2], [1, 2, 2, 3]])
    keep = strongest_attachments(ei, np.array([0.9, 0.5, 0.2, 0.1]), np.array([10, 500, 400, 300]), 0.25)
    assert keep.tolist() == [True, False, True, True]  # 0 keeps only its stronger attachment
    keep = strongest_attachments(ei, np.array([0.5, 0.9, 0.2, 0.1]), np.array([10, 500, 400, 300]), 0.25)
    assert keep.tolist() == [False, True, True, True]
    tie = strongest_attachments(np.array([[0, 0], [1, 2]]), np.array([0.5, 0.5]), np.array([1, 9, 9]), 0.5)
    assert tie.tolist() == [True, False]  # ties: the first edge
    assert strongest_attachments(np.zeros((2, 0), np.int64), np.zeros(0), np.ones(3), 0.5).shape == (0,)
    with pytest.raises(ValueError, match=r"ratio in \(0, 1\]"):
        strongest_attachments(ei, np.ones(4), np.ones(4), 0.0)
    with pytest.raises(ValueError, match=r"weight of shape \[4\]"):
        strongest_attachments(ei, np.ones(3), np.ones(4), 0.5)


def _fragment_between_two_boxes():
    """Box faces A (x <= 0.095) and B (x >= 0.125), 3 cm apart; a fragment F in the gap whose
    directed Chamfer distance to either is 2.5e-4 (its columns lie 1 and 2 cm from each)."""
    ga, gb = np.mgrid[0:20, 0:20] * 0.005
    a = np.stack([ga.ravel(), gb.ravel(), np.zeros(400)], 1)
    b = a + [0.125, 0, 0]
    f = np.array([[x, y, 0.0] for x in (0.105, 0.115) for y in (0.04, 0.045, 0.05, 0.055)])
    pts = np.concatenate([a, b, f]).astype(np.float32)[None]
    lab = np.array([[0] * 400 + [1] * 400 + [2] * 8])
    return CorrespondenceGraph(3, node_attr={"area": [400, 400, 8]}), Evidence([lab], points=[pts])


def test_chamfer_fragment_ratio_keeps_a_fragment_from_bridging():
    """Before ``fragment_ratio`` the fragment had an edge to both boxes, and contraction merged them."""
    g, ev = _fragment_between_two_boxes()
    plain = Chamfer3D(tau=3e-4, voxel_size=None, stride=1)(g, ev)
    assert sorted(map(tuple, plain.edge_index.T.tolist())) == [(0, 2), (1, 2)]
    es = Chamfer3D(tau=3e-4, voxel_size=None, stride=1, fragment_ratio=0.25)(g, ev)
    assert es.num_edges == 1 and es.info["detached"] == 1 and 2 in es.edge_index


def test_chamfer_min_confidence_ignores_low_confidence_points():
    g, ev = _fragment_between_two_boxes()
    conf = np.ones(ev.node_labels[0].shape, np.float32)
    conf[0, 800:] = 0.2  # the fragment's points are unsure (a fill, not stereo)
    es = Chamfer3D(tau=3e-4, voxel_size=None, stride=1, min_confidence=0.5)(g, Evidence(ev.node_labels, points=ev.points, confidence=[conf]))
    assert es.num_edges == 0
    kept = Chamfer3D(tau=3e-4, voxel_size=None, stride=1, min_confidence=0.5)(g, Evidence(ev.node_labels, points=ev.points, confidence=[None]))
    assert kept.num_edges == 2  # a view without confidence keeps every point


def test_chamfer_spacing_factor_follows_the_point_spacing():
    """Two samplings of one plane, 2 cm apart on a 2 cm grid: the directed distance (1e-4) fails
    tau = 5e-5 but passes once the threshold scales with the spacing (1.5 x 2 cm: 9e-4)."""
    g0, g1 = np.mgrid[0:10, 0:10] * 0.02
    a = np.stack([g0.ravel(), g1.ravel(), np.zeros(100)], 1)
    pts = np.concatenate([a, a + [0.01, 0, 0]]).astype(np.float32)[None]
    lab = np.array([[0] * 100 + [1] * 100])
    g = CorrespondenceGraph(2, node_attr={"area": [100, 100]})
    ev = Evidence([lab], points=[pts])
    assert Chamfer3D(tau=5e-5, voxel_size=None, stride=1)(g, ev).num_edges == 0
    es = Chamfer3D(tau=5e-5, voxel_size=None, stride=1, spacing_factor=1.5)(g, ev)
    assert es.num_edges == 1 and es.edge_attr["tau"][0] == pytest.approx((1.5 * 0.02) ** 2)
