import numpy as np
import pytest

from graphseg.graphs import (
    CorrespondenceGraph,
    GraphValidationError,
    MaskNode,
    SuperNode,
    as_edge_index,
    coarsen,
    mask_node_table,
)

from .conftest import make_graph


def test_mask_node_table_shapes_and_values():
    lab = np.array([[1, 1, 0], [0, 3, 3], [0, 0, 3]])
    pts = np.zeros((3, 3, 3), np.float32)
    pts[..., 0] = np.arange(3)[None, :]
    pts[1, 1] = np.nan
    t = mask_node_table([lab], [pts])
    assert t["view"].tolist() == [0, 0]
    assert t["mask_id"].tolist() == [0, 2]
    assert t["area"].tolist() == [2, 3]
    assert t["bbox"].tolist() == [[0, 0, 1, 0], [1, 1, 2, 2]]
    np.testing.assert_allclose(t["centroid"], [[0.5, 0], [5 / 3, 4 / 3]])
    assert t["num_points"].tolist() == [2, 2]
    np.testing.assert_allclose(t["centroid_3d"][1], [2, 0, 0])
    np.testing.assert_allclose(t["bbox_3d"][0], [0, 0, 0, 1, 0, 0])


def test_mask_node_table_empty_view():
    t = mask_node_table([np.zeros((2, 2), int)])
    assert t["bbox"].shape == (0, 4) and t["area"].shape == (0,)


def test_from_masks_and_node_rows(toy_graph):
    g = toy_graph
    g.validate()
    node = g.node(0)
    assert isinstance(node, MaskNode)
    assert node.area == int(g.node_attr["area"][0]) and len(node.bbox) == 4 and len(node.bbox_3d) == 6
    assert len(list(g.nodes())) == g.num_nodes
    with pytest.raises(IndexError):
        g.node(g.num_nodes)


def test_node_labels_roundtrip(toy_graph):
    labs = toy_graph.node_labels()
    for v, (lab, nl) in enumerate(zip(toy_graph.masks, labs)):
        assert nl.shape == lab.shape
        assert (nl[lab == 0] == -1).all()
        nodes = nl[lab > 0]
        assert (toy_graph.node_attr["view"][nodes] == v).all()
        assert (toy_graph.node_attr["mask_id"][nodes] + 1 == lab[lab > 0]).all()


def test_add_edges_fills_missing_columns_and_does_not_mutate(toy_graph):
    e0 = toy_graph.num_edges
    g2 = toy_graph.add_edges([[0], [1]], {"similarity": [0.9], "criterion": ["dino"]})
    assert toy_graph.num_edges == e0 and "similarity" not in toy_graph.edge_attr
    assert g2.num_edges == e0 + 1
    assert np.isnan(g2.edge_attr["similarity"][:e0]).all()
    assert g2.edge_attr["count"][-1] == -1
    g2.add_edges([[1], [2]], in_place=True)
    assert g2.num_edges == e0 + 2 and g2.edge_attr["criterion"][-1] == ""


def test_super_node_rows(toy_graph):
    s = coarsen(toy_graph, np.zeros(toy_graph.num_nodes, int))
    node = s.node(0)
    assert isinstance(node, SuperNode)
    assert node.member_count == toy_graph.num_nodes
    assert node.area == int(toy_graph.node_attr["area"].sum())


# ---- every validation error ------------------------------------------------------------------

def test_error_edge_index_shape():
    with pytest.raises(GraphValidationError, match=r"expected edge_index of shape \[2, E\] \(got \[3, 10\]\)"):
        CorrespondenceGraph(20, edge_index=np.zeros((3, 10), int))
    with pytest.raises(GraphValidationError, match=r"\(got \[5\]\)"):
        as_edge_index(np.arange(5))


def test_error_edge_index_dtype_and_range():
    with pytest.raises(GraphValidationError, match="integer dtype"):
        as_edge_index(np.array([[0.5], [1]]))
    g = CorrespondenceGraph(2, edge_index=[[0], [1]])
    g.edge_index = np.array([[0], [7]])
    with pytest.raises(GraphValidationError, match=r"in \[0, num_nodes=2\) \(got 7\)"):
        g.validate()
    g.edge_index = np.array([[0], [-1]])
    with pytest.raises(GraphValidationError, match=r"\(got -1\)"):
        g.validate()
    g.edge_index = np.array([[0], [1]], dtype=np.int32)
    with pytest.raises(GraphValidationError, match="dtype int64"):
        g.validate()


def test_error_edge_attr_length():
    g = CorrespondenceGraph(2, edge_index=[[0], [1]], edge_attr={"weight": [1.0, 2.0]})
    with pytest.raises(GraphValidationError, match=r"edge_attr\['weight'\] of length E=1 \(got 2\)"):
        g.validate()
    with pytest.raises(GraphValidationError, match=r"length E=1"):
        CorrespondenceGraph(2).add_edges([[0], [1]], {"weight": [1.0, 2.0]})


def test_error_criterion_dtype():
    g = CorrespondenceGraph(2, edge_index=[[0], [1]], edge_attr={"criterion": [3]})
    with pytest.raises(GraphValidationError, match="criterion'\\] of str dtype"):
        g.validate()


def test_error_node_attr_length_and_shape():
    with pytest.raises(GraphValidationError, match=r"node_attr\['area'\] of length num_nodes=3 \(got 2\)"):
        CorrespondenceGraph(3, node_attr={"area": [1, 2]}).validate()
    with pytest.raises(GraphValidationError, match=r"node_attr\['bbox'\] of shape \[N, 4\] \(got \[2, 3\]\)"):
        CorrespondenceGraph(2, node_attr={"bbox": np.zeros((2, 3))}).validate()


def test_error_num_nodes_level_masks_members():
    with pytest.raises(GraphValidationError, match="num_nodes >= 0"):
        CorrespondenceGraph(-1).validate()
    with pytest.raises(GraphValidationError, match="level"):
        CorrespondenceGraph(1, level="object").validate()
    with pytest.raises(GraphValidationError, match=r"masks\[0\] as an integer label image"):
        CorrespondenceGraph(1, masks=[np.zeros((2, 2), float)]).validate()
    bad = {"view": [0], "mask_id": [0], "node": [4]}
    with pytest.raises(GraphValidationError, match=r"members\['node'\]"):
        CorrespondenceGraph(2, members=bad).validate()
    with pytest.raises(GraphValidationError, match=r"members\['view'\] of shape \[1\]"):
        CorrespondenceGraph(2, members={"view": [0, 1], "mask_id": [0], "node": [0]}).validate()
    with pytest.raises(GraphValidationError, match="stores no masks"):
        CorrespondenceGraph(1).node_labels()


def test_contract_method_uses_registry():
    g = make_graph()
    a = g.contract("star", rng=0)
    b = g.contract("union_find")
    assert np.array_equal(a, b)


def test_mask_node_table_nonfinite_points_and_large_labels():
    lab = np.array([[1, 1, 0], [70000, 70000, 2]])  # a label >= 2**16 takes the sorting path
    pts = np.zeros((2, 3, 3), np.float32)
    pts[0, 1] = [np.nan, 0, 0]
    pts[1, 0] = [2, 2, 2]
    t = mask_node_table([lab], [pts])
    assert t["mask_id"].tolist() == [0, 1, 69999] and t["area"].tolist() == [2, 1, 2]
    assert t["num_points"].tolist() == [1, 1, 2]
    assert t["centroid_3d"].tolist()[2] == [1, 1, 1] and t["bbox_3d"].tolist()[2] == [0, 0, 0, 2, 2, 2]
    small = mask_node_table([np.where(lab == 70000, 3, lab)], [pts])  # same masks, radix path
    for k in ("area", "bbox", "centroid", "num_points", "centroid_3d", "bbox_3d"):
        assert np.array_equal(small[k], t[k])


@pytest.mark.parametrize("name", ["star", "union_find", "scipy", "constrained", "core_attach", "gaec"])
def test_contract_never_merges_across_a_repulsive_edge(name):
    # 0-1 attract, 1-2 repulsive (sign -1): every contractor keeps 2 apart, as segment() does
    g = CorrespondenceGraph(3, edge_index=np.array([[0, 1], [1, 2]]), edge_attr={"sign": np.array([1.0, -1.0]), "weight": np.array([0.9, 0.9])})
    g.node_attr["area"] = np.array([100, 100, 100])
    c = g.contract(name, rng=0)
    assert c[0] == c[1] != c[2]
