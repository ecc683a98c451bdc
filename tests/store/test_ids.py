"""Stable object ids and the edges that decided a merge or a split."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from graphseg.graphs import CorrespondenceGraph, coarsen
from graphseg.store.ids import assign_ids, deciding_edges
from graphseg.store.incremental import MASK_BITS


def test_first_add_numbers_objects_in_order():
    pid, events, nxt = assign_ids(np.zeros(0), np.zeros(0), np.array([5, 6, 7]), np.array([2, 1, 0]), 1)
    assert pid.tolist() == [0, 1, 2] and nxt == 3
    assert events == [{"event": "new", "id": 1}, {"event": "new", "id": 2}]


def test_ids_survive_when_a_view_adds_masks():
    old_uid, old_pid = np.array([1, 2, 3, 4]), np.array([7, 7, 3, 0])
    new_uid, new_obj = np.array([1, 2, 3, 4, 9, 10]), np.array([2, 2, 1, 0, 2, 3])  # renumbered compactly, one new object
    pid, events, nxt = assign_ids(old_uid, old_pid, new_uid, new_obj, 8)
    assert pid.tolist() == [0, 3, 7, 8] and nxt == 9
    assert events == [{"event": "new", "id": 8}]


def test_merge_split_and_dropped():
    old_uid, old_pid = np.array([1, 2, 3, 4, 5, 6]), np.array([1, 1, 2, 3, 3, 4])
    # 1 and 2 merge (1 shares more masks), 3 splits (mask 5 leaves), 4 drops to the background
    new_uid, new_obj = np.array([1, 2, 3, 4, 5, 6]), np.array([1, 1, 1, 2, 3, 0])
    pid, events, nxt = assign_ids(old_uid, old_pid, new_uid, new_obj, 5)
    assert pid.tolist() == [0, 1, 3, 5] and nxt == 6
    assert {"event": "merge", "id": 1, "ids": [1, 2]} in events
    assert {"event": "split", "id": 3, "into": [3, 5]} in events
    assert {"event": "dropped", "id": 4} in events
    assert {"event": "dropped", "id": 2} not in events  # merged, not dropped


def test_an_object_without_masks_gets_a_new_id():
    # the 3D split can leave a part with no mask of its own: objects 1..3, masks only on 1 and 2
    pid, events, nxt = assign_ids(np.array([1, 2]), np.array([4, 6]), np.array([1, 2]), np.array([1, 2]), 7, num_objects=3)
    assert pid.tolist() == [0, 4, 6, 7] and nxt == 8 and events == [{"event": "new", "id": 7}]
    assert assign_ids(np.array([1]), np.array([4]), np.array([1]), np.array([1]), 5, num_objects=0)[0].tolist() == [0, 4]


def test_a_tie_keeps_the_smaller_id():
    pid, events, _ = assign_ids(np.array([1, 2]), np.array([4, 2]), np.array([1, 2]), np.array([1, 1]), 5)
    assert pid.tolist() == [0, 2] and events == [{"event": "merge", "id": 2, "ids": [2, 4]}]


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(0, 4), min_size=1, max_size=30), st.integers(0, 5), st.randoms(use_true_random=False))
def test_a_refinement_free_add_keeps_every_id(old_obj, extra, rnd):
    # the old masks keep their grouping (ids renamed compactly), new masks form new objects:
    # every old object keeps its id and the only events are "new"
    old_uid = np.arange(len(old_obj)) + 100
    old_pid = np.array([0 if o == 0 else 10 + o for o in old_obj])
    present = sorted({o for o in old_obj if o})
    perm = list(range(1, len(present) + 1))
    rnd.shuffle(perm)
    compact = {o: perm[i] for i, o in enumerate(present)}
    new_obj = [compact.get(o, 0) for o in old_obj] + [len(present) + 1 + k for k in range(extra)]
    new_uid = np.r_[old_uid, np.arange(extra) + 500]
    pid, events, nxt = assign_ids(old_uid, old_pid, new_uid, np.array(new_obj), 20)
    for o in present:
        assert pid[compact[o]] == 10 + o
    assert [e["event"] for e in events] == ["new"] * extra
    assert nxt == 20 + extra
    assert len(set(pid[1:].tolist())) == len(pid) - 1


def _graphs():
    """Two views: masks 0, 1 in view 0 and 2, 3 in view 1; edges 0-2 (0.9), 2-1 (0.5), 1-3 (0.2)."""
    g = CorrespondenceGraph.from_masks([np.array([[1, 2]]), np.array([[1, 2]])])
    g = g.add_edges([[0, 2, 1], [2, 1, 3]], {"criterion": ["pixel_match"] * 3, "weight": [0.9, 0.5, 0.2], "stage": [0, 0, 0]})
    return [g]


def test_deciding_edges_are_the_path_between_the_merged_objects():
    uids = np.array([0, 1])
    key = lambda v, m: (v << MASK_BITS) | m  # noqa: E731
    # old objects: A = {view0 mask0}, B = {view1 mask1}; the other two masks are new
    group = {key(0, 0): 1, key(1, 1): 2, key(0, 1): -1, key(1, 0): -2}
    edges = deciding_edges(_graphs(), uids, group, [1, 2], ["a", "b"])
    assert [(e["u"], e["v"], e["weight"]) for e in edges] == [([["a", 0]], [["b", 0]], 0.9), ([["b", 0]], [["a", 1]], 0.5), ([["a", 1]], [["b", 1]], 0.2)]
    # masks of A and B that no edge joins: the support rules joined them
    assert deciding_edges(_graphs(), uids, {key(0, 0): 1, key(1, 1): 2}, [1, 2], ["a", "b"]) is None


def test_deciding_edges_cross_stages():
    g0 = _graphs()[0]
    g0 = CorrespondenceGraph(g0.num_nodes, g0.edge_index[:, :1], {k: v[:1] for k, v in g0.edge_attr.items()}, g0.node_attr, g0.masks)
    g1 = coarsen(g0, np.array([0, 1, 0, 2]))  # stage 0 joined masks 0 and 2
    g1 = g1.add_edges([[0], [2]], {"criterion": ["chamfer_3d"], "weight": [0.7], "stage": [1], "distance": [1e-5]})
    key = lambda v, m: (v << MASK_BITS) | m  # noqa: E731
    group = {key(0, 0): 1, key(1, 0): 1, key(1, 1): 2, key(0, 1): 3}
    edges = deciding_edges([g0, g1], np.array([0, 1]), group, [1, 2], ["a", "b"])
    assert len(edges) == 1 and edges[0]["stage"] == 1 and edges[0]["criterion"] == "chamfer_3d"
    assert sorted(map(tuple, edges[0]["u"])) == [("a", 0), ("b", 0)] and edges[0]["v"] == [["b", 1]] and edges[0]["distance"] == 1e-5
