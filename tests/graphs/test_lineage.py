"""The objects graph (graphseg.graphs.lineage): fragments, recorded steps, painting."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from graphseg.graphs.lineage import Lineage, live_components, paint_objects


def _start(masks, objects):
    """A lineage whose base masks are every mask id present, in view then id order."""
    view, mask_id = [], []
    for v, m in enumerate(masks):
        ids = np.unique(m[m > 0]) - 1
        view += [v] * ids.size
        mask_id += ids.tolist()
    return Lineage(masks, np.array(view), np.array(mask_id), np.asarray(objects), step="stage1")


def test_shapes_and_columns():
    masks = [np.array([[1, 1, 2], [0, 2, 2]]), np.array([[1, 0, 0], [1, 1, 0]])]
    lin = _start(masks, [1, 2, 1])
    lin.record("split", [np.array([[1, 3, 2], [0, 2, 2]]), np.array([[1, 0, 0], [1, 1, 0]])])
    g = lin.graph()
    assert g.num_nodes == lin.num_fragments == 4  # mask 0 of view 0 was cut in two
    assert [m.shape for m in g.masks] == [(2, 3), (2, 3)]
    for col in ("view", "mask_id", "area", "source_mask", "after_stage1", "after_split", "object", "background"):
        assert g.node_attr[col].shape == (4,), col
    for col in ("criterion", "cut_by", "evidence", "evidence_name"):
        assert g.edge_attr[col].shape == (g.num_edges,), col
    assert g.meta["steps"] == ["stage1", "split"]
    assert g.node_attr["area"].sum() == 8  # every masked pixel in one fragment


def test_hand_computed_join_with_evidence_and_background():
    # view 0: masks 1, 2, 3 side by side; objects 1, 2, 3 after the contraction
    masks = [np.array([[1, 1, 2, 2, 3, 3]])]
    lin = _start(masks, [1, 2, 3])
    lin.record("merge", [np.array([[1, 1, 1, 1, 2, 2]])], evidence={frozenset((1, 2)): 0.05}, evidence_name="ncut")
    lin.record("support_final", [np.array([[1, 1, 1, 1, 0, 0]])], reason="support")
    g = lin.graph()
    assert g.node_attr["object"].tolist() == [1, 1, 0]
    assert g.node_attr["background"].tolist() == ["", "", "support"]
    assert g.node_attr["after_merge"].tolist() == [1, 1, 2]
    assert g.edge_index.tolist() == [[0], [1]]  # one edge: the merge joined mask 0's and mask 1's objects
    assert g.edge_attr["criterion"].tolist() == ["merge"] and g.edge_attr["cut_by"].tolist() == [""]
    assert g.edge_attr["evidence"].tolist() == [0.05] and g.edge_attr["evidence_name"].tolist() == ["ncut"]
    assert [p.tolist() for p in paint_objects(g)] == [[[1, 1, 1, 1, 0, 0]]]


def test_a_cut_edge_stays_with_the_step_that_cut_it():
    masks = [np.array([[1, 1, 1, 1]])]
    lin = _start(masks, [1])
    lin.record("split", [np.array([[1, 1, 2, 2]])])
    g = lin.graph()
    assert g.num_nodes == 2 and g.node_attr["source_mask"].tolist() == [0, 0]
    assert g.node_attr["after_stage1"].tolist() == [1, 1] and g.node_attr["object"].tolist() == [1, 2]
    assert list(zip(g.edge_attr["criterion"].tolist(), g.edge_attr["cut_by"].tolist())) == [("stage1", "split")]
    assert sorted(live_components(g).tolist()) == [0, 1]


def test_edge_cases():
    empty = Lineage([np.zeros((2, 2), np.int32)], np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64), step="masks")
    empty.record("support", [np.zeros((2, 2), np.int32)])
    g = empty.graph()
    assert g.num_nodes == 0 and g.num_edges == 0 and paint_objects(g)[0].tolist() == [[0, 0], [0, 0]]
    lin = _start([np.array([[1, 0]])], [1])
    lin.record("grow", [np.array([[1, 1]])])  # a pixel outside every mask is not read
    assert lin.graph().num_nodes == 1
    with pytest.raises(ValueError, match="expected labels for 1 views"):
        lin.record("x", [])
    with pytest.raises(ValueError, match=r"expected labels of shape \[1, 2\]"):
        lin.record("x", [np.zeros((2, 2), np.int32)])
    with pytest.raises(ValueError, match="one length"):
        Lineage([np.array([[1]])], np.array([0]), np.array([0, 1]), np.array([1]), step="s")


def test_paint_refuses_a_component_with_two_objects():
    lin = _start([np.array([[1, 2]])], [1, 1])
    g = lin.graph()
    g.node_attr["object"] = np.array([1, 2])
    with pytest.raises(ValueError, match="holds objects"):
        paint_objects(g)


@st.composite
def _histories(draw):
    h, w = draw(st.integers(1, 5)), draw(st.integers(1, 6))
    views = draw(st.integers(1, 3))
    masks = [np.array(draw(st.lists(st.integers(0, 4), min_size=h * w, max_size=h * w)), np.int32).reshape(h, w) for _ in range(views)]
    steps = draw(st.lists(st.lists(st.integers(0, 3), min_size=views * h * w, max_size=views * h * w), min_size=0, max_size=4))
    return masks, [[np.array(s[v * h * w : (v + 1) * h * w], np.int32).reshape(h, w) for v in range(views)] for s in steps]


@settings(max_examples=150, deadline=None)
@given(_histories())
def test_live_components_painted_give_the_last_labels(history):
    """Property: after any sequence of steps, every live component holds one object, and painting
    the graph gives the last step's labels on every masked pixel (0 elsewhere)."""
    masks, steps = history
    base = _start(masks, np.ones(sum(np.unique(m[m > 0]).size for m in masks), np.int64))
    for k, labels in enumerate(steps):
        base.record(f"step{k}", labels)
    g = base.graph()
    painted = paint_objects(g)
    last = steps[-1] if steps else [np.where(m > 0, 1, 0) for m in masks]
    for m, p, lab in zip(masks, painted, last):
        assert np.array_equal(p, np.where(m > 0, lab, 0))
    comp = live_components(g)
    fg = g.node_attr["object"] > 0
    assert len(set(comp[fg].tolist())) == len(set(g.node_attr["object"][fg].tolist()))
    assert ((g.node_attr["background"] != "") == ~fg).all()
