import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from graphseg.graphs.chamfer import (
    SPACING_FACTOR,
    PointSets,
    chamfer_edges,
    point_spacing,
    spacing_aware_chamfer_edges,
)
from graphseg.published import TAU_3D_OFFICIAL


def _sets(*arrays):
    ptr = np.r_[0, np.cumsum([len(a) for a in arrays])].astype(np.int64)
    return PointSets(np.concatenate(arrays).astype(np.float64), ptr)


def test_point_spacing_shape_and_values():
    line = np.c_[np.arange(5) * 0.02, np.zeros(5), np.zeros(5)]
    s = point_spacing(_sets(line, line[:1], np.zeros((0, 3))))
    assert s.shape == (3,)
    assert s[0] == pytest.approx(0.02)
    assert np.isnan(s[1]) and np.isnan(s[2])


def test_sparse_samplings_of_one_surface_join_far_ones_do_not():
    rng = np.random.default_rng(0)
    plane = lambda n: np.c_[rng.uniform(0, 0.1, (n, 2)), np.zeros(n)]  # noqa: E731
    a, b = plane(30), plane(30)  # spacing of about 1 cm
    far = plane(30) + [0.5, 0, 0]
    sets = _sets(a, b, far)
    assert chamfer_edges(sets, TAU_3D_OFFICIAL, prune=True).num_edges == 0  # the fixed threshold misses the sparse pair
    es = spacing_aware_chamfer_edges(sets, TAU_3D_OFFICIAL, factor=SPACING_FACTOR, prune=True)
    assert es.edge_index.tolist() == [[0], [1]]
    assert es.edge_attr["tau"][0] > TAU_3D_OFFICIAL


def test_bad_arguments():
    with pytest.raises(ValueError, match="tau > 0"):
        spacing_aware_chamfer_edges(_sets(np.zeros((2, 3))), 0.0, factor=SPACING_FACTOR, prune=True)
    with pytest.raises(TypeError, match="factor"):
        spacing_aware_chamfer_edges(_sets(np.zeros((2, 3))), 1e-4, prune=True)  # every option is required


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 10_000), st.integers(2, 6))
def test_dense_sets_give_exactly_the_fixed_test(seed, k):
    """Point spacing far below sqrt(tau): the spacing-aware test equals chamfer_edges."""
    rng = np.random.default_rng(seed)
    arrays = [rng.uniform(0, 0.01, (40, 3)) + rng.uniform(0, 0.05, 3) for _ in range(k)]
    sets = _sets(*arrays)
    tau = 1e-3  # spacing (a few mm)^2 << tau
    a = chamfer_edges(sets, tau, prune=True).edge_index
    b = spacing_aware_chamfer_edges(sets, tau, factor=SPACING_FACTOR, prune=True).edge_index
    assert sorted(map(tuple, a.T.tolist())) == sorted(map(tuple, b.T.tolist()))
