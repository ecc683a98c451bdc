import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from graphseg.graphs import (
    CorrespondenceGraph,
    GraphValidationError,
    coarsen,
    group_reduce,
    union_find_contraction,
)


def test_coarsen_hand_computed():
    g = CorrespondenceGraph(
        4,
        edge_index=[[0, 1, 0, 2, 0], [1, 2, 2, 3, 3]],
        edge_attr={
            "criterion": np.array(["pixel_match", "pixel_match", "pixel_match", "chamfer_3d", "pixel_match"]),
            "weight": [0.9, 0.1, 0.3, 0.5, 0.7],
            "count": [5, 1, 2, -1, 4],
            "stage": [0, 0, 0, 1, 0],
        },
        node_attr={
            "view": [0, 1, 0, 1],
            "mask_id": [0, 0, 1, 1],
            "area": [10, 30, 20, 40],
            "centroid": [[0.0, 0], [10, 0], [0, 10], [10, 10]],
            "bbox": [[0, 0, 1, 1], [5, 5, 6, 6], [2, 0, 3, 9], [0, 0, 9, 9]],
        },
    )
    cluster = np.array([0, 1, 1, 2])  # {0}, {1, 2}, {3}
    s = coarsen(g, cluster)
    s.validate()
    assert s.level == "super" and s.num_nodes == 3
    assert s.node_attr["member_count"].tolist() == [1, 2, 1]
    assert s.node_attr["area"].tolist() == [10, 50, 40]
    np.testing.assert_allclose(s.node_attr["centroid"][1], [(10 * 30 + 0) / 50, (0 + 10 * 20) / 50])
    assert s.node_attr["bbox"][1].tolist() == [2, 0, 6, 9]
    assert "view" not in s.node_attr and "mask_id" not in s.node_attr
    # edge 1-2 is now a self-loop; 0-1 and 0-2 merge (pixel_match); 2-3 chamfer; 0-3 pixel
    pairs = {(int(u), int(v), c): i for i, (u, v, c) in enumerate(zip(*s.edge_index, s.edge_attr["criterion"]))}
    assert set(pairs) == {(0, 1, "pixel_match"), (1, 2, "chamfer_3d"), (0, 2, "pixel_match")}
    m = pairs[(0, 1, "pixel_match")]
    assert s.edge_attr["weight"][m] == 0.9 and s.edge_attr["count"][m] == 7
    assert s.edge_attr["multiplicity"][m] == 2
    assert s.members["node"].tolist() == [0, 1, 1, 2]
    assert s.members["view"].tolist() == [0, 1, 0, 1]


def test_coarsen_twice_composes_members():
    g = CorrespondenceGraph(4, edge_index=[[0, 2], [1, 3]], node_attr={"area": [1, 1, 1, 1], "view": [0, 0, 1, 1], "mask_id": [0, 1, 0, 1]})
    s = coarsen(g, np.array([0, 0, 1, 1]))
    t = coarsen(s, np.array([0, 0]))
    assert t.members["node"].tolist() == [0, 0, 0, 0]
    assert t.node_attr["member_count"].tolist() == [4]


def test_coarsen_errors():
    g = CorrespondenceGraph(3)
    with pytest.raises(GraphValidationError, match=r"expected cluster of shape \[3\] \(got \[2\]\)"):
        coarsen(g, np.array([0, 1]))
    with pytest.raises(GraphValidationError, match="integer dtype"):
        coarsen(g, np.array([0.0, 1, 1]))
    with pytest.raises(GraphValidationError, match=">= 0"):
        coarsen(g, np.array([0, -1, 1]))


def test_coarsen_empty_graph():
    s = coarsen(CorrespondenceGraph(0), np.zeros(0, np.int64))
    assert s.num_nodes == 0 and s.num_edges == 0


def test_group_reduce_kinds():
    vals = np.array([3.0, 1.0, np.nan, 4.0])
    grp = np.array([0, 0, 1, 1])
    assert group_reduce(vals, grp, 2, "min").tolist() == [1.0, 4.0]
    assert group_reduce(vals, grp, 2, "first").tolist()[0] == 3.0
    np.testing.assert_allclose(group_reduce(np.array([1.0, 3.0]), np.array([0, 0]), 1, ("wmean", "w"), weights=np.array([1, 3])), [2.5])
    with pytest.raises(GraphValidationError, match="unknown reduction"):
        group_reduce(vals, grp, 2, "median")
    with pytest.raises(GraphValidationError, match="cannot reduce"):
        group_reduce(np.array(["a", "b"]), np.array([0, 0]), 1, "sum")


@settings(max_examples=200, deadline=None)
@given(st.integers(1, 40), st.lists(st.tuples(st.integers(0, 39), st.integers(0, 39)), max_size=80))
def test_coarsen_by_components_leaves_no_edges(n, edges):
    ei = np.array([(u % n, v % n) for u, v in edges], np.int64).T.reshape(2, -1)
    g = CorrespondenceGraph(n, ei, {"weight": np.ones(ei.shape[1])}, {"area": np.ones(n, np.int64)})
    s = coarsen(g, union_find_contraction(ei, n))
    assert s.num_edges == 0
    assert s.node_attr["area"].sum() == n
