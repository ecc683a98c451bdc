import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from graphseg.graphs.coalesce import KEY_LIMIT, coalesce, combine_keys, group_by_key


def test_combine_keys_shape_and_order():
    a, b = np.array([2, 0, 1, 0]), np.array([0, 3, 1, 0])
    k = combine_keys([a, b], [3, 4])
    assert k.shape == (4,) and k.dtype == np.int64
    assert k.tolist() == [8, 3, 5, 0]  # hand-computed: a * 4 + b


def test_combine_keys_overflow_falls_back_to_exact_ranks():
    big = 2**40
    assert big * big >= KEY_LIMIT
    a = np.array([big - 1, 0, big - 1, 5])
    b = np.array([0, big - 1, 0, 5])
    k = combine_keys([a, b], [big, big])
    assert k.tolist() == [2, 0, 2, 1]  # dense ranks in lexicographic row order


def test_combine_keys_validates():
    with pytest.raises(ValueError, match="one size per column"):
        combine_keys([np.array([1])], [2, 3])
    with pytest.raises(ValueError, match="equal length"):
        combine_keys([np.array([1]), np.array([1, 2])], [2, 3])


def test_group_by_key_empty_and_dense_equals_sorted():
    g = group_by_key(np.zeros(0, np.int64))
    assert g.num_groups == 0 and g.groups.shape == (0,)
    key = np.array([5, 1, 5, 9, 1, 1])
    a, b = group_by_key(key), group_by_key(key, num_keys=10)
    for f in ("keys", "groups", "first", "counts"):
        assert getattr(a, f).tolist() == getattr(b, f).tolist()
    assert a.keys.tolist() == [1, 5, 9] and a.counts.tolist() == [3, 2, 1] and a.first.tolist() == [1, 0, 3]


def test_coalesce_reductions_and_merge_by():
    ei = np.array([[0, 1, 1, 2, 3], [1, 0, 0, 2, 1]])
    attr = {"w": np.array([1.0, 3.0, 2.0, 9.0, 4.0]), "c": np.array(["a", "a", "b", "a", "a"])}
    out_ei, out, g = coalesce(ei, attr, 4, reduce={"w": "sum"}, merge_by=("c",))
    assert out_ei.tolist() == [[0, 0, 1], [1, 1, 3]]  # self-loop (2, 2) dropped; "b" kept apart
    assert out["w"].tolist() == [4.0, 2.0, 4.0] and out["c"].tolist() == ["a", "b", "a"]
    assert out["multiplicity"].tolist() == [2, 1, 1]
    _, out2, _ = coalesce(ei, attr, 4, reduce={"w": "max"})
    assert out2["w"].tolist() == [3.0, 4.0]


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 7), st.integers(0, 7)), max_size=40))
def test_coalesce_matches_a_python_set(pairs):
    ei = np.array(pairs, np.int64).reshape(-1, 2).T
    out_ei, out, _ = coalesce(ei, {}, 8)
    want = sorted({(min(u, v), max(u, v)) for u, v in pairs if u != v})
    assert list(map(tuple, out_ei.T.tolist())) == want
    assert int(out["multiplicity"].sum()) == sum(u != v for u, v in pairs)


@pytest.mark.parametrize("high", [1, 300, 1 << 16, 1 << 24, (1 << 24) + 3, 1 << 32, 1 << 40])
def test_group_by_key_radix_paths_equal_stable_sort(high):
    # keys below 2**32 take the radix path; every path must give the stable-sort grouping
    from graphseg.graphs.coalesce import _argsort_keys

    k = np.random.default_rng(high % 97).integers(0, high, 5000)
    assert np.array_equal(_argsort_keys(k, True), np.argsort(k, kind="stable"))
    g = group_by_key(k)
    keys, first, inv, counts = np.unique(k, return_index=True, return_inverse=True, return_counts=True)
    assert g.keys.tolist() == keys.tolist() and g.first.tolist() == first.tolist()
    assert g.groups.tolist() == inv.tolist() and g.counts.tolist() == counts.tolist()
    assert _argsort_keys(np.zeros(0, np.int64), True).shape == (0,)
