import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from graphseg.graphs import contractors
from graphseg.graphs.contract import canonical_cluster
from graphseg.graphs.signed import (
    ConstrainedUnionFindContraction,
    CoreAttachContraction,
    GreedyAdditiveContraction,
    constrained_union_find,
    core_attach_contraction,
    edge_strength,
    greedy_additive_contraction,
    split_signed,
)


def components(ei, n):
    ei = np.asarray(ei, np.int64).reshape(2, -1)
    adj = coo_matrix((np.ones(ei.shape[1]), (ei[0], ei[1])), shape=(n, n))
    return canonical_cluster(connected_components(adj, directed=False)[1])


graphs = st.integers(1, 12).flatmap(
    lambda n: st.tuples(
        st.just(n),
        st.lists(st.tuples(st.integers(0, n - 1), st.integers(0, n - 1)), max_size=30),
        st.lists(st.tuples(st.integers(0, n - 1), st.integers(0, n - 1)), max_size=6),
        st.lists(st.floats(0, 1), min_size=30, max_size=30),
    )
)


def as_ei(pairs):
    return np.array(pairs, np.int64).T.reshape(2, -1)


def test_shape_and_dtype():
    c = constrained_union_find(np.array([[0], [1]]), 4)
    assert c.shape == (4,) and c.dtype == np.int64


def test_strongest_edge_wins_against_cannot_link():
    # 0-1 (0.2), 1-2 (0.9), cannot-link 0-2: 1 goes with 2, the weaker 0-1 is refused
    c = constrained_union_find(np.array([[0, 1], [1, 2]]), 3, weight=[0.2, 0.9], cannot_link=[[0], [2]])
    assert c.tolist() == [0, 1, 1]


def test_constraint_moves_with_merged_clusters():
    # 0-1 joined first; cannot-link 1-3; then 2-3; then 0-2 would join 1 and 3: refused
    c = constrained_union_find(np.array([[0, 2, 0], [1, 3, 2]]), 4, weight=[3, 2, 1], cannot_link=[[1], [3]])
    assert c[0] == c[1] and c[2] == c[3] and c[0] != c[2]


def test_bad_weight_shape():
    with pytest.raises(ValueError, match=r"weight of shape \[1\]"):
        constrained_union_find(np.array([[0], [1]]), 2, weight=[1.0, 2.0])


@settings(max_examples=60, deadline=None)
@given(graphs)
def test_never_joins_a_cannot_link_pair(data):
    n, edges, cl, w = data
    ei = as_ei(edges)
    c = constrained_union_find(ei, n, weight=w[: ei.shape[1]], cannot_link=as_ei(cl))
    for a, b in cl:
        if a != b:
            assert c[a] != c[b]


@settings(max_examples=60, deadline=None)
@given(graphs)
def test_without_cannot_links_equals_components(data):
    n, edges, _, w = data
    ei = as_ei(edges)
    assert constrained_union_find(ei, n, weight=w[: ei.shape[1]]).tolist() == components(ei, n).tolist()


@settings(max_examples=60, deadline=None)
@given(graphs, st.lists(st.booleans(), min_size=12, max_size=12))
def test_core_attach_never_bridges_two_core_groups(data, core_bits):
    n, edges, _, w = data
    ei = as_ei(edges)
    core = np.array(core_bits[:n])
    c = core_attach_contraction(ei, n, core=core, weight=w[: ei.shape[1]])
    both = core[ei[0]] & core[ei[1]] if ei.size else np.zeros(0, bool)
    groups = components(ei[:, both], n)
    for k in np.unique(c):
        assert np.unique(groups[(c == k) & core]).size <= 1
    # refines plain components
    cc = components(ei, n)
    for k in np.unique(c):
        assert np.unique(cc[c == k]).size == 1


def test_core_attach_all_core_is_components():
    ei = np.array([[0, 2], [1, 3]])
    assert core_attach_contraction(ei, 4, core=np.ones(4, bool)).tolist() == [0, 0, 1, 1]


def test_core_attach_bad_core_shape():
    with pytest.raises(ValueError, match=r"core of shape \[3\]"):
        core_attach_contraction(np.zeros((2, 0), np.int64), 3, core=[True])


def test_edge_strength_ranks_per_criterion():
    s = edge_strength({"weight": np.array([5.0, 1.0, 0.1, 0.3]), "criterion": np.array(["a", "a", "b", "b"])}, 4)
    assert s.tolist() == [1.0, 0.5, 0.5, 1.0]
    assert edge_strength({}, 2).tolist() == [1.0, 1.0]


def test_split_signed_nan_is_attractive():
    pos, neg = split_signed(np.array([[0, 0], [1, 2]]), {"sign": np.array([np.nan, -1.0])})
    assert pos.tolist() == [True, False] and neg.tolist() == [False, True]


def test_registered_and_called_with_edge_attr():
    c = contractors.resolve("constrained")
    assert isinstance(c, ConstrainedUnionFindContraction) and c.uses_edge_attr
    assert isinstance(contractors.resolve("core_attach"), CoreAttachContraction)
    ei = np.array([[0, 1, 0], [1, 2, 2]])
    out = c(ei, 3, edge_attr={"weight": np.array([0.9, 0.1, 1.0]), "sign": np.array([1.0, 1.0, -1.0]), "criterion": np.array(["p", "p", "r"])})
    assert out.tolist() == [0, 0, 1]


def test_gaec_shape_and_hand_computed():
    # path 0-1-2-3 with a cannot-link 0-3: 0-1 (0.9) and 2-3 (0.8) join; {0,1}-{2,3} sums 0.2 + (-inf)
    ei = np.array([[0, 1, 2], [1, 2, 3]])
    c = greedy_additive_contraction(ei, 5, weight=[0.9, 0.2, 0.8], cannot_link=[[0], [3]])
    assert c.dtype == np.int64 and c.shape == (5,)
    assert c.tolist() == [0, 0, 1, 1, 2]  # {0,1} and {2,3} close first; joining them would violate 0-3


def test_gaec_sums_evidence_over_a_cluster():
    # node 2 has one strong edge to 0 and two weaker edges to the {3, 4} group; 0 and 3 may not join
    ei = np.array([[2, 2, 2, 3], [0, 3, 4, 4]])
    w = [0.9, 0.6, 0.6, 1.0]
    cl = [[0], [3]]
    c = greedy_additive_contraction(ei, 5, weight=w, cannot_link=cl)
    assert c[2] == c[3] == c[4] and c[0] != c[2]  # 0.6 + 0.6 > 0.9 once {3, 4} is one cluster
    u = constrained_union_find(ei, 5, weight=w, cannot_link=cl)
    assert u[2] == u[0] and u[2] != u[3]  # edge by edge, the single strong edge wins


def test_gaec_parallel_edges_add_up_and_self_loops_are_ignored():
    # 0-1 twice (0.5 + 0.5 = 1.0) beats the single 1-2 (0.9); 0 and 2 may not join; the self-loop 2-2 is ignored
    ei = np.array([[0, 0, 1, 2], [1, 1, 2, 2]])
    c = greedy_additive_contraction(ei, 3, weight=[0.5, 0.5, 0.9, 5.0], cannot_link=[[0], [2]])
    assert c.tolist() == [0, 0, 1]
    assert greedy_additive_contraction(ei, 3, weight=[0.4, 0.4, 0.9, 5.0], cannot_link=[[0], [2]]).tolist() == [0, 1, 1]
    assert greedy_additive_contraction(np.zeros((2, 0), np.int64), 0).tolist() == []


def gaec_reference(ei, n, w, cl):
    """Brute force: recompute every cluster pair's summed weight, join the largest positive one."""
    lab = list(range(n))
    forbid = {(min(a, b), max(a, b)) for a, b in cl if a != b}
    while True:
        sums = {}
        for (a, b), x in zip(ei.T.tolist(), w):
            ca, cb = lab[a], lab[b]
            if ca != cb:
                key = (min(ca, cb), max(ca, cb))
                sums[key] = sums.get(key, 0.0) + x
        for a, b in forbid:
            ca, cb = lab[a], lab[b]
            if ca != cb:
                sums[(min(ca, cb), max(ca, cb))] = -np.inf
        best = max(((x, k) for k, x in sums.items() if x > 0), default=None, key=lambda t: t[0])
        if best is None:
            return canonical_cluster(np.array(lab, np.int64))
        ca, cb = best[1]
        lab = [ca if c == cb else c for c in lab]


@settings(max_examples=80, deadline=None)
@given(graphs)
def test_gaec_equals_brute_force_when_sums_are_distinct(data):
    n, edges, cl, _ = data
    ei = as_ei(edges)
    # distinct powers of two: every sum of a subset of edges is unique, so the greedy order has no ties
    w = 2.0 ** -np.arange(1, ei.shape[1] + 1)
    got = greedy_additive_contraction(ei, n, weight=w, cannot_link=as_ei(cl))
    assert got.tolist() == gaec_reference(ei, n, w.tolist(), cl).tolist()


def test_gaec_bad_weights():
    with pytest.raises(ValueError, match=r"weight of shape \[1\]"):
        greedy_additive_contraction(np.array([[0], [1]]), 2, weight=[1.0, 2.0])
    with pytest.raises(ValueError, match="positive"):
        greedy_additive_contraction(np.array([[0], [1]]), 2, weight=[0.0])
    assert greedy_additive_contraction(np.zeros((2, 0), np.int64), 3).tolist() == [0, 1, 2]


@settings(max_examples=60, deadline=None)
@given(graphs)
def test_gaec_never_joins_a_cannot_link_pair_and_refines_components(data):
    n, edges, cl, w = data
    ei = as_ei(edges)
    c = greedy_additive_contraction(ei, n, weight=np.asarray(w[: ei.shape[1]]) + 0.01, cannot_link=as_ei(cl))
    for a, b in cl:
        if a != b:
            assert c[a] != c[b]
    cc = components(ei, n)
    for k in np.unique(c):
        assert np.unique(cc[c == k]).size == 1


@settings(max_examples=60, deadline=None)
@given(graphs)
def test_gaec_without_cannot_links_equals_components(data):
    n, edges, _, w = data
    ei = as_ei(edges)
    assert greedy_additive_contraction(ei, n, weight=np.asarray(w[: ei.shape[1]]) + 0.01).tolist() == components(ei, n).tolist()


def test_gaec_registered():
    c = contractors.resolve("gaec")
    assert isinstance(c, GreedyAdditiveContraction) and c.uses_edge_attr
    ei = np.array([[0, 1, 0], [1, 2, 2]])
    assert c(ei, 3, edge_attr={"sign": np.array([1.0, 1.0, -1.0])}).tolist() == [0, 0, 1]


def test_gaec_weighted_cannot_links_hand_computed():
    # 0-1 (0.9), 1-2 (0.8), 0-2 (0.3); cannot-link 0-2. Hard: 2 stays out. Soft 0.5: {0,1} then {0,1}-2 sums
    # 0.8 + 0.3 - 0.5 = 0.6 > 0, so all join; soft 1.5: 1.1 - 1.5 < 0, so 2 stays out.
    ei = np.array([[0, 1, 0], [1, 2, 2]])
    w = [0.9, 0.8, 0.3]
    assert greedy_additive_contraction(ei, 3, weight=w, cannot_link=[[0], [2]]).tolist() == [0, 0, 1]
    assert greedy_additive_contraction(ei, 3, weight=w, cannot_link=[[0], [2]], repulsion=0.5).tolist() == [0, 0, 0]
    assert greedy_additive_contraction(ei, 3, weight=w, cannot_link=[[0], [2]], repulsion=1.5).tolist() == [0, 0, 1]
    # every cannot-link counts: one of 0.6 leaves 1.1 - 0.6 > 0; two (0-2 and 1-2) leave 1.1 - 1.2 < 0
    assert greedy_additive_contraction(ei, 3, weight=w, cannot_link=[[0], [2]], repulsion=0.6).tolist() == [0, 0, 0]
    assert greedy_additive_contraction(ei, 3, weight=w, cannot_link=[[0, 1], [2, 2]], repulsion=0.6).tolist() == [0, 0, 1]
    for bad in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="repulsion"):
            greedy_additive_contraction(ei, 3, weight=w, repulsion=bad)


@settings(max_examples=60, deadline=None)
@given(graphs)
def test_gaec_with_huge_repulsion_equals_hard_cannot_links(data):
    n, edges, cl, w = data
    ei = as_ei(edges)
    ww = np.asarray(w[: ei.shape[1]]) + 0.01
    hard = greedy_additive_contraction(ei, n, weight=ww, cannot_link=as_ei(cl))
    soft = greedy_additive_contraction(ei, n, weight=ww, cannot_link=as_ei(cl), repulsion=1e9)
    assert soft.tolist() == hard.tolist()


@settings(max_examples=80, deadline=None)
@given(graphs, st.lists(st.booleans(), min_size=12, max_size=12))
def test_gaec_fragments_never_bridge_two_core_clusters(data, core_bits):
    n, edges, cl, w = data
    ei = as_ei(edges)
    ww = np.asarray(w[: ei.shape[1]]) + 0.01
    core = np.array(core_bits[:n])
    c = greedy_additive_contraction(ei, n, weight=ww, cannot_link=as_ei(cl), core=core)
    both = core[ei[0]] & core[ei[1]] if ei.size else np.zeros(0, bool)
    first = greedy_additive_contraction(ei[:, both], n, weight=ww[both], cannot_link=as_ei(cl))
    for k in np.unique(c):
        assert np.unique(first[(c == k) & core]).size <= 1  # at most one core cluster per final cluster
    for a, b in cl:
        if a != b:
            assert c[a] != c[b]
    cc = components(ei, n)
    for k in np.unique(c):
        assert np.unique(cc[c == k]).size == 1
    if core.all():
        assert c.tolist() == greedy_additive_contraction(ei, n, weight=ww, cannot_link=as_ei(cl)).tolist()


def test_gaec_fragment_joins_its_strongest_cluster_and_fragments_group():
    # cores 0 and 3; fragment 1 has 0.4 to core 0 and 0.9 to core 3: it joins 3, not both.
    # fragments 4 and 5 touch no core: they join each other.
    ei = np.array([[0, 1, 4], [1, 3, 5]])
    core = [True, False, False, True, False, False]
    got = greedy_additive_contraction(ei, 6, weight=[0.4, 0.9, 0.5], core=core)
    assert got[1] == got[3] != got[0] and got[4] == got[5] and got[2] not in (got[0], got[3], got[4])
    with pytest.raises(ValueError, match=r"core of shape \[6\]"):
        greedy_additive_contraction(ei, 6, core=[True])


def test_gaec_contractor_options():
    c = GreedyAdditiveContraction(fragment_area=10)
    ei = np.array([[0, 1], [1, 2]])
    attr = {"weight": np.array([0.4, 0.9])}
    assert c(ei, 3, edge_attr=attr, node_attr={"area": np.array([50, 3, 50])}).tolist() == [0, 1, 1]
    with pytest.raises(ValueError, match="'area'"):
        c(ei, 3, edge_attr=attr)
    with pytest.raises(ValueError, match="fragment_area"):
        GreedyAdditiveContraction(fragment_area=0)
    from pydantic import ValidationError

    from graphseg.config import Config

    with pytest.raises(ValidationError, match="repulsoin"):  # a misspelt option fails where the config is read
        Config.model_validate({"contractor": {"gaec": {"repulsoin": 2.0}}})

    built = Config.model_validate({"contractor": {"gaec": {"repulsion": 2.0, "fragment_area": 300}}}).contractor.build()
    assert (built.repulsion, built.fragment_area) == (2.0, 300)
