"""Stable object ids: match the objects of two updates, and say why they merged or split.

Objects are sets of base masks, and base masks keep their uid for the life
of a store. :func:`assign_ids` matches the objects of an update to those of
the last one by the masks they share: an object keeps the id of the old
object it shares the most masks with (ties: the smaller id), so an object
keeps its id when a view is added. What changed is a list of events:

* ``merge``: one new object holds masks of several old ones; it keeps the id
  of the one it shares the most masks with, the others retire;
* ``split``: the masks of one old object now lie in several objects; the one
  with most of them keeps the id, the others get new ids;
* ``new``: an object with no mask of an old object (a new id);
* ``dropped``: an old object none of whose masks is in an object any more
  (the minimum-support rule made it background).

:func:`deciding_edges` names the edges behind a merge (in the new graphs) or a
split (in the old graphs): a spanning forest of the edges inside the object,
strongest first and stage by stage, and in it the paths that join the parts.

Examples
--------
>>> old_uid, old_pid = np.array([10, 11, 12]), np.array([1, 2, 2])
>>> new_uid, new_obj = np.array([10, 11, 12, 20]), np.array([1, 1, 1, 2])
>>> pid, events, nxt = assign_ids(old_uid, old_pid, new_uid, new_obj, 3)
>>> pid.tolist(), [(e["event"], e["id"]) for e in events], nxt
([0, 2, 3], [('merge', 2), ('new', 3)], 4)
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..graphs import CorrespondenceGraph
from .incremental import MASK_BITS

__all__ = ["assign_ids", "deciding_edges", "describe_edge", "operation_edges", "MAX_MEMBERS"]

#: Masks listed per edge end in an explanation (the rest are counted).
MAX_MEMBERS = 8


def assign_ids(
    old_uid: np.ndarray,
    old_pid: np.ndarray,
    new_uid: np.ndarray,
    new_obj: np.ndarray,
    next_pid: int,
    num_objects: int | None = None,
) -> tuple[np.ndarray, list[dict[str, Any]], int]:
    """Persistent ids for the objects of an update.

    Parameters
    ----------
    old_uid, old_pid : int64 ``[M0]``
        Every base mask of the last update and its persistent object id (0 = none).
    new_uid, new_obj : int64 ``[M1]``
        Every base mask of this update and its object (``1..K``, 0 = none).
    next_pid : int
        The first id never given out.
    num_objects : int, optional
        Objects of this update, when some hold no base mask (the 3D split,
        ``config.split``, can give a part none): such an object gets a new id.
        Default: the largest of ``new_obj``.

    Returns
    -------
    pid : int64 ``[K + 1]``
        ``pid[k]``: the persistent id of object ``k`` (``pid[0] = 0``).
    events : list of dict
        ``{"event": "merge", "id", "ids"}``, ``{"event": "split", "id", "into"}``,
        ``{"event": "new", "id"}``, ``{"event": "dropped", "id"}``; ``ids`` and
        ``into`` are sorted persistent ids (``ids`` include ``id``).
    next_pid : int

    Notes
    -----
    O((M0 + M1) log M0 + P log P) for P overlapping (old, new) pairs.
    """
    old_uid = np.asarray(old_uid, np.int64)
    old_pid = np.asarray(old_pid, np.int64)
    new_uid = np.asarray(new_uid, np.int64)
    new_obj = np.asarray(new_obj, np.int64)
    k = max(int(new_obj.max()) if new_obj.size else 0, int(num_objects or 0))
    order = np.argsort(old_uid, kind="stable")
    pos = np.clip(np.searchsorted(old_uid[order], new_uid), 0, max(old_uid.size - 1, 0))
    had = old_uid.size > 0
    prev = np.zeros(new_uid.size, np.int64)
    if had:
        hit = old_uid[order][pos] == new_uid
        prev[hit] = old_pid[order][pos[hit]]
    both = (prev > 0) & (new_obj > 0)
    pairs: dict[tuple[int, int], int] = {}
    for a, b in zip(prev[both].tolist(), new_obj[both].tolist()):
        pairs[(a, b)] = pairs.get((a, b), 0) + 1
    pid = np.zeros(k + 1, np.int64)
    taken: set[int] = set()
    for (a, b), _ in sorted(pairs.items(), key=lambda item: (-item[1], item[0][0], item[0][1])):
        if pid[b] == 0 and a not in taken:
            pid[b] = a
            taken.add(a)
    events: list[dict[str, Any]] = []
    olds_of: dict[int, set[int]] = {}
    news_of: dict[int, set[int]] = {}
    for a, b in pairs:
        olds_of.setdefault(b, set()).add(a)
        news_of.setdefault(a, set()).add(b)
    nxt = int(next_pid)
    for b in range(1, k + 1):
        if pid[b] == 0:
            pid[b] = nxt
            nxt += 1
    for b in range(1, k + 1):
        olds = olds_of.get(b, set())
        if len(olds) > 1:
            events.append({"event": "merge", "id": int(pid[b]), "ids": sorted(olds)})
    for a in sorted(news_of):
        if len(news_of[a]) > 1:
            events.append({"event": "split", "id": a, "into": sorted(int(pid[b]) for b in news_of[a])})
    for b in range(1, k + 1):
        if not olds_of.get(b):
            events.append({"event": "new", "id": int(pid[b])})
    alive = set(int(p) for p in old_pid[old_pid > 0].tolist())
    for a in sorted(alive - set(news_of)):
        events.append({"event": "dropped", "id": a})
    return pid, events, nxt


def describe_edge(graph: CorrespondenceGraph, e: int, view_names: Sequence[str]) -> dict[str, Any]:
    """One edge of a stage graph as JSON: stage, criterion, evidence and the masks at both ends.

    Examples
    --------
    >>> g = CorrespondenceGraph.from_masks([np.array([[1, 2]]), np.array([[1, 0]])])
    >>> g = g.add_edges([[0], [2]], {"criterion": ["pixel_match"], "weight": [0.5], "count": [7], "stage": [0]})
    >>> describe_edge(g, 0, ["a", "b"])
    {'stage': 0, 'criterion': 'pixel_match', 'weight': 0.5, 'count': 7, 'u': [['a', 0]], 'v': [['b', 0]]}
    """
    out: dict[str, Any] = {}
    for col in ("stage", "criterion", "weight", "count", "ratio", "distance", "sign", "evidence", "evidence_name"):
        if col in graph.edge_attr:
            val = np.asarray(graph.edge_attr[col])[e]
            if isinstance(val, np.str_) or isinstance(val, str):
                if str(val):
                    out[col] = str(val)
            elif np.issubdtype(type(val), np.integer) and int(val) >= 0:
                out[col] = int(val)
            elif np.issubdtype(type(val), np.floating) and np.isfinite(val):
                out[col] = float(val)
    mem = graph.members
    for end, node in (("u", graph.edge_index[0, e]), ("v", graph.edge_index[1, e])):
        sel = np.flatnonzero(mem["node"] == node)
        out[end] = [[str(view_names[int(mem["view"][i])]), int(mem["mask_id"][i])] for i in sel[:MAX_MEMBERS]]
        if sel.size > MAX_MEMBERS:
            out[f"{end}_more"] = int(sel.size - MAX_MEMBERS)
    return out


def operation_edges(objects_graph: CorrespondenceGraph | None, stage: int) -> list[CorrespondenceGraph]:
    """The joins of the graph operations (``Result.objects_graph``) as one more graph for :func:`deciding_edges`.

    Its nodes are the objects graph's fragments, each standing for the base
    mask it is part of (``source_mask``); its edges are the live edges a graph
    operation added (``criterion`` not a contraction ``stageS``), with
    ``stage`` set to ``stage``. Empty list without an objects graph.

    Examples
    --------
    >>> g = CorrespondenceGraph.from_masks([np.array([[1, 2]])])
    >>> g.node_attr["source_mask"] = np.array([0, 1])
    >>> g = g.add_edges([[0], [1]], {"criterion": ["merge"], "cut_by": [""], "evidence": [0.03], "evidence_name": ["ncut"]})
    >>> [h.edge_attr["stage"].tolist() for h in operation_edges(g, 2)]
    [[2]]
    """
    if objects_graph is None or "source_mask" not in objects_graph.node_attr:
        return []
    crit = np.asarray(objects_graph.edge_attr.get("criterion", np.zeros(0, str))).astype(str)
    live = np.asarray(objects_graph.edge_attr.get("cut_by", np.full(crit.size, ""))).astype(str) == ""
    keep = np.flatnonzero(live & ~np.char.startswith(crit, "stage"))
    n = objects_graph.num_nodes
    members = {"view": objects_graph.node_attr["view"], "mask_id": objects_graph.node_attr["source_mask"], "node": np.arange(n)}
    attrs = {k: np.asarray(objects_graph.edge_attr[k])[keep] for k in ("criterion", "evidence", "evidence_name") if k in objects_graph.edge_attr}
    attrs["stage"] = np.full(keep.size, stage, np.int64)
    return [CorrespondenceGraph(n, objects_graph.edge_index[:, keep], attrs, members=members, level="super")]


def deciding_edges(
    graphs: Sequence[CorrespondenceGraph],
    view_uids: np.ndarray,
    group_of: dict[int, int],
    targets: Sequence[int],
    view_names: Sequence[str],
) -> list[dict[str, Any]] | None:
    """The edges that join the groups ``targets`` inside one object.

    Parameters
    ----------
    graphs : list of CorrespondenceGraph
        The stage graphs (``Result.graphs``) whose edges are searched.
    view_uids : int64 ``[V]``
        Uid of every view index of the graphs.
    group_of : dict
        Base mask uid -> group (an old object's id for a merge, a new one's
        for a split) for the masks of the object; other masks are ignored.
    targets : list of int
        The groups to join (at least two).
    view_names : list of str

    Returns
    -------
    list of dict or None
        :func:`describe_edge` of every edge on the paths from ``targets[0]``
        to the other targets in a spanning forest of the attractive edges
        (stage by stage, strongest first); None when some target is not
        joined by edges (the support rules joined it).

    Notes
    -----
    O(E log E) over the edges of all stages, plus a breadth-first search.
    """
    import networkx as nx

    parent: dict[Any, Any] = {}

    def find(x: Any) -> Any:
        parent.setdefault(x, x)
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    forest = nx.Graph()
    forest.add_nodes_from(targets)
    for s, g in enumerate(graphs):
        mem = g.members
        uid = (np.asarray(view_uids, np.int64)[mem["view"]] << MASK_BITS) | mem["mask_id"]
        rep: dict[int, Any] = {}
        for node, u in zip(mem["node"].tolist(), uid.tolist()):
            if u in group_of:
                key = ("g", group_of[u])
                if node in rep:  # masks already joined by an earlier stage: one set
                    a, b = find(rep[node]), find(key)
                    if a != b:
                        parent[a] = b
                else:
                    rep[node] = key
        if not g.num_edges:
            continue
        sign = np.asarray(g.edge_attr.get("sign", np.ones(g.num_edges)), np.float64)
        stage = np.asarray(g.edge_attr.get("stage", np.full(g.num_edges, s)), np.int64)
        weight = np.nan_to_num(np.asarray(g.edge_attr.get("weight", np.ones(g.num_edges)), np.float64), nan=0.0)
        cand = np.flatnonzero(~(sign < 0) & (stage == s))
        for e in cand[np.argsort(-weight[cand], kind="stable")]:
            u, v = int(g.edge_index[0, e]), int(g.edge_index[1, e])
            if u not in rep or v not in rep:
                continue
            a, b = find(rep[u]), find(rep[v])
            if a == b:
                continue
            parent[a] = b
            ga, gb = rep[u][1], rep[v][1]
            forest.add_edge(ga, gb, edge=(s, int(e)))
    out: list[dict[str, Any]] = []
    seen: set[tuple[int, int]] = set()
    for t in targets[1:]:
        try:
            path = nx.shortest_path(forest, targets[0], t)
        except nx.NetworkXNoPath:
            return None
        for a, b in zip(path[:-1], path[1:]):
            s, e = forest.edges[a, b]["edge"]
            if (s, e) not in seen:
                seen.add((s, e))
                out.append(describe_edge(graphs[s], e, view_names))
    return out
