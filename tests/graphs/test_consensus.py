import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from graphseg.graphs import CorrespondenceGraph, Evidence, consensus, edge_adders, overlap
from graphseg.graphs.consensus import ViewConsensus
from graphseg.graphs.overlap import BidirectionalOverlap
from graphseg.scene import Matches

# The pure functions take every option as a required keyword; the tests leave out what they do
# not vary, which then comes from the criterion's Options (the one home of the defaults).
_CONSENSUS = ViewConsensus.Options().model_dump()


def containers(*args, **kw):
    return consensus.containers(*args, **{**{k: _CONSENSUS[k] for k in ("min_matches", "min_share")}, **kw})


def consensus_pairs(*args, **kw):
    return consensus.consensus_pairs(*args, **{**{k: _CONSENSUS[k] for k in ("min_views", "threshold")}, **kw})


def view_consensus_edges(*args, **kw):
    return consensus.view_consensus_edges(*args, **{**_CONSENSUS, **kw})


def bidirectional_overlap_edges(*args, **kw):
    return overlap.bidirectional_overlap_edges(*args, **{**BidirectionalOverlap.Options().model_dump(), **kw})


def identity_matches(shape, pairs):
    ys, xs = np.mgrid[0 : shape[0], 0 : shape[1]]
    xy = np.stack([xs.ravel(), ys.ravel()], 1).astype(np.float32)
    return {p: Matches(xy, xy, np.ones(len(xy))) for p in pairs}


def test_containers_shape_and_values():
    # view 0: one mask over two objects (node 0); views 1, 2: the two objects apart
    labs = [np.array([[0, 0, 0, 0]]), np.array([[1, 1, 2, 2]]), np.array([[3, 3, 4, 4]])]
    c = containers(labs, identity_matches((1, 4), [(0, 1), (0, 2), (1, 2)]), 5, min_matches=1)
    assert c.shape == (5, 3)
    assert c[1].tolist() == [0, 1, 3] and c[2].tolist() == [0, 2, 4]
    assert c[0, 0] == 0 and c[0, 1] in (1, 2)


def test_undersegmented_mask_does_not_join_the_second_object():
    labs = [np.array([[0, 0, 0, 0]]), np.array([[1, 1, 2, 2]]), np.array([[3, 3, 4, 4]])]
    es = view_consensus_edges(labs, identity_matches((1, 4), [(0, 1), (0, 2), (1, 2)]), 5, min_matches=1, threshold=0.9)
    pairs = {tuple(p) for p in es.edge_index.T.tolist()}
    assert (1, 3) in pairs and (2, 4) in pairs  # each object across views 1 and 2
    assert (1, 2) not in pairs and (3, 4) not in pairs


def test_consensus_pairs_below_and_empty():
    c = np.array([[0, 5], [1, 5], [1, 6]])
    ei, cons, obs = consensus_pairs(c, min_views=2, threshold=0.0, below=True)
    assert ei.tolist() == [[0], [2]] and cons.tolist() == [0.0] and obs.tolist() == [2]
    ei, cons, obs = consensus_pairs(np.zeros((0, 2), np.int64))
    assert ei.shape == (2, 0)


def test_repel_below_gives_cannot_links():
    labs = [np.array([[0, 0, 1, 1]]), np.array([[2, 2, 3, 3]])]
    es = view_consensus_edges(labs, identity_matches((1, 4), [(0, 1)]), 4, min_matches=1, attract=False, repel_below=0.0, min_views=2)
    assert es.num_edges > 0 and np.all(es.edge_attr["sign"] < 0)


def test_view_consensus_adder():
    g = CorrespondenceGraph.from_masks([np.array([[1, 1]]), np.array([[1, 1]])])
    adder = edge_adders.resolve("view_consensus", min_matches=1)
    assert isinstance(adder, ViewConsensus)
    assert adder(g, Evidence.for_graph(g, matches=identity_matches((1, 2), [(0, 1)]))).edge_index.tolist() == [[0], [1]]
    with pytest.raises(ValueError):
        ViewConsensus(threshold=2.0)


def test_bidirectional_overlap_refuses_a_swallowed_mask():
    # view 0: big mask 0 (3 px) and small 1 (1 px); view 1: one mask 2 (4 px)
    labs = [np.array([[0, 0, 0, 1]]), np.array([[2, 2, 2, 2]])]
    m = identity_matches((1, 4), [(0, 1)])
    es = bidirectional_overlap_edges(labs, m, 3, threshold=0.5, min_matches=1)
    assert es.edge_index.tolist() == [[0], [2]]  # 3/4 both ways; 1 -> 2 is 1/4 from 2's side
    assert es.edge_attr["weight"].tolist() == [0.75]
    assert bidirectional_overlap_edges(labs, {}, 3).num_edges == 0
    assert isinstance(edge_adders.resolve("bidirectional_overlap"), BidirectionalOverlap)


def test_bidirectional_overlap_keeps_the_best_view_pair_in_first_seen_order():
    # nodes 0, 1 in view 0; 2 in view 1; 3 in view 2
    labs = [np.array([[0, 0, 1, 1]]), np.array([[2, 2, 2, -1]]), np.array([[3, 3, 3, 3]])]
    m = identity_matches((1, 4), [(0, 1), (0, 2)])
    es = bidirectional_overlap_edges(labs, m, 4, threshold=0.0, min_matches=1)
    # pair (0, 1): 0-2 = 2/3, 1-2 = 1/3; pair (0, 2): 0-3 = 2/4, 1-3 = 2/4
    assert es.edge_index.tolist() == [[0, 1, 0, 1], [2, 2, 3, 3]]
    np.testing.assert_allclose(es.edge_attr["weight"], [2 / 3, 1 / 3, 0.5, 0.5])
    assert es.edge_attr["count"].tolist() == [2, 1, 2, 2]
    assert es.edge_attr["weight"].dtype == np.float64 and es.edge_index.dtype == np.int64


def test_bidirectional_overlap_takes_the_best_of_two_view_pairs_and_the_first_on_ties():
    # one node pair (0 in view 0, 1 in view 1) matched in both directions
    labs = [np.array([[0, 0, 0, 0]]), np.array([[1, 1, -1, -1]])]
    xy = np.array([[0, 0], [1, 0], [2, 0], [3, 0]], np.float32)
    worse = Matches(xy, xy, np.ones(4))  # (0, 1): 2 of node 0's 4 matches reach node 1 -> 2 / 4
    better = Matches(xy[:2], xy[:2], np.ones(2))  # (1, 0): 2 / 2
    for order in ({(0, 1): worse, (1, 0): better}, {(1, 0): better, (0, 1): worse}):
        es = bidirectional_overlap_edges(labs, order, 2, threshold=0.0, min_matches=1)
        assert es.edge_index.tolist() == [[0], [1]]
        assert es.edge_attr["weight"].tolist() == [1.0] and es.edge_attr["count"].tolist() == [2]
    es = bidirectional_overlap_edges(labs, {(0, 1): worse}, 2, threshold=0.0, min_matches=1)
    assert es.edge_attr["weight"].tolist() == [0.5] and es.edge_attr["count"].tolist() == [2]
    one = Matches(xy[:1], xy[:1], np.ones(1))  # (1, 0): 1 / 1, a tie with `better` at 1.0
    assert bidirectional_overlap_edges(labs, {(0, 1): better, (1, 0): one}, 2, threshold=0.0, min_matches=1).edge_attr["count"].tolist() == [2]
    assert bidirectional_overlap_edges(labs, {(1, 0): one, (0, 1): better}, 2, threshold=0.0, min_matches=1).edge_attr["count"].tolist() == [1]
    # view pairs below min_matches do not count, even when their overlap is higher
    assert bidirectional_overlap_edges(labs, {(0, 1): worse, (1, 0): one}, 2, threshold=0.0, min_matches=2).edge_attr["weight"].tolist() == [0.5]


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 10_000), st.floats(0.0, 1.0), st.integers(1, 3))
def test_bidirectional_overlap_matches_a_brute_force_reference(seed, threshold, min_matches):
    from graphseg.graphs.pixel_match import lookup_pixels

    rng = np.random.default_rng(seed)
    n_views, h, w = 3, 4, 5
    labs, off = [], 0
    for _ in range(n_views):
        k = int(rng.integers(1, 4))
        lab = rng.integers(-1, k, (h, w))
        labs.append(np.where(lab >= 0, lab + off, -1))
        off += k
    matches = {}
    for i in range(n_views):
        for j in range(n_views):
            if i != j and rng.random() < 0.6:
                xy = np.stack([rng.integers(0, w, 12), rng.integers(0, h, 12)], 1).astype(np.float32)
                xy2 = np.stack([rng.integers(0, w, 12), rng.integers(0, h, 12)], 1).astype(np.float32)
                matches[(i, j)] = Matches(xy, xy2, np.ones(12))
    best = {}  # the definition, one view pair and one node pair at a time
    for (i, j), m in matches.items():
        a, _ = lookup_pixels(labs[i], m.xy_i)
        b, _ = lookup_pixels(labs[j], m.xy_j)
        both = (a >= 0) & (b >= 0)
        here = {}
        for u in np.unique(a[both]):
            for v in np.unique(b[both]):
                c = int(np.sum((a == u) & (b == v)))
                if c >= min_matches:
                    here[(int(min(u, v)), int(max(u, v)))] = (c / max(int(np.sum(a == u)), int(np.sum(b == v))), c)
        for key in sorted(here):  # within a view pair, node pairs in key order
            if key not in best or here[key][0] > best[key][0]:  # dicts keep first-insertion order
                best[key] = here[key]
    es = bidirectional_overlap_edges(labs, matches, off, threshold=threshold, min_matches=min_matches)
    got = list(zip(map(tuple, es.edge_index.T.tolist()), es.edge_attr["weight"].tolist(), es.edge_attr["count"].tolist()))
    want = [(k, o, c) for k, (o, c) in best.items() if o >= threshold]
    assert [g[0] for g in got] == [w[0] for w in want]  # same edges, in first-seen order
    for g, w in zip(got, want):
        assert g[1] == pytest.approx(w[1]) and g[2] == w[2]
