"""The objects graph: mask fragments, and the steps that joined them into objects or cut them apart.

After the last contraction, steps that work on pixels (a 3D split, joins of
touching pieces, a snap of pixels back to their mask's object, the minimum
support) still decide which pixels form which object. :class:`Lineage`
records them as graph operations. Its nodes are **mask fragments**: a
composed mask cut wherever a step gave its pixels different objects, so every
step's objects are unions of whole fragments. After each step, the fragments'
object ids form one column (``after_<step>``), and :meth:`Lineage.graph`
turns the sequence into one graph whose edges say, per object, which step
joined its fragments (``criterion``, with the step's ``evidence`` where it
recorded one) and which step cut an edge apart (``cut_by``):

* a step that splits a node leaves the cut edges in the graph, with
  ``cut_by`` set to that step;
* a step that joins nodes adds an edge carrying its name and evidence;
* a step that marks a node background cuts its edges and sets the node's
  ``background`` column to the step's reason.

The live edges (``cut_by == ""``) have one component per object, and
painting every fragment that is not background with its component's object
gives the labels of the last step exactly (:func:`paint_objects`).

Examples
--------
>>> masks = [np.array([[1, 1, 2, 2]])]                      # two masks in one view
>>> lin = Lineage(masks, np.array([0, 0]), np.array([0, 1]), np.array([1, 1]), step="stage1")
>>> lin.record("split", [np.array([[1, 2, 2, 2]])])        # mask 0 is cut in two
>>> lin.record("support", [np.array([[0, 2, 2, 2]])], reason="support")
>>> g = lin.graph()
>>> g.num_nodes, g.node_attr["object"].tolist(), g.node_attr["background"].tolist()
(3, [0, 2, 2], ['support', '', ''])
>>> sorted(zip(g.edge_attr["criterion"].tolist(), g.edge_attr["cut_by"].tolist()))
[('stage1', ''), ('stage1', 'split')]
>>> [lab.tolist() for lab in paint_objects(g)]
[[[0, 2, 2, 2]]]
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from scipy import sparse
from scipy.sparse.csgraph import connected_components

from .graph import CorrespondenceGraph

__all__ = ["Lineage", "paint_objects", "live_components"]


class Lineage:
    """Mask fragments and the object each one belongs to after every step.

    Parameters
    ----------
    masks : sequence of int arrays ``[H, W]``
        Per view, ``mask_id + 1`` per pixel (0 = no mask): the composed masks.
    mask_view, mask_id : int arrays ``[M]``
        The base masks (the members of the contracted graph).
    objects : int array ``[M]``
        The object of every base mask after the contraction (``1..K``; 0 = none).
    step : str, keyword-only
        The name of that first step (for example ``"stage1"``).

    Notes
    -----
    :meth:`record` costs O(pixels) per step (one gather and one comparison per
    view); a step that gives one fragment's pixels different objects adds a
    sort of that view's masked pixels. Nothing is stored per pixel but one
    int32 fragment image per view.
    """

    def __init__(self, masks: Sequence[np.ndarray], mask_view: np.ndarray, mask_id: np.ndarray, objects: np.ndarray, *, step: str) -> None:
        mask_view = np.asarray(mask_view, np.int64)
        mask_id = np.asarray(mask_id, np.int64)
        objects = np.asarray(objects, np.int64)
        if not (mask_view.shape == mask_id.shape == objects.shape):
            raise ValueError(f"expected mask_view, mask_id and objects of one length (got {mask_view.shape}, {mask_id.shape}, {objects.shape})")
        self.fragments: list[np.ndarray] = []
        for v, m in enumerate(masks):
            m = np.asarray(m, np.int64)
            lut = np.full(int(m.max(initial=0)) + 2, -1, np.int64)
            sel = mask_view == v
            ok = mask_id[sel] + 1 < lut.size
            lut[mask_id[sel][ok] + 1] = np.flatnonzero(sel)[ok]
            self.fragments.append(lut[m].astype(np.int32))
        self.view = mask_view.copy()
        self.mask_id = mask_id.copy()
        self.steps: list[str] = [step]
        self.states: list[np.ndarray] = [objects.copy()]
        self.reasons: list[str] = [""]
        self.evidence: list[Mapping[frozenset[int], float]] = [{}]
        self.evidence_names: list[str] = [""]

    @property
    def num_fragments(self) -> int:
        """Number of fragments ``F``."""
        return int(self.view.size)

    def record(
        self,
        step: str,
        labels: Sequence[np.ndarray],
        *,
        reason: str = "",
        evidence: Mapping[frozenset[int], float] | None = None,
        evidence_name: str = "",
    ) -> None:
        """Record the objects after ``step``: per view, the object id of every pixel.

        Fragments whose pixels now carry different objects are cut into new
        fragments (each keeps its history). Pixels outside every mask are not
        read.

        Parameters
        ----------
        step : str
            The step's name (a column ``after_<step>`` and the ``criterion`` of
            the edges it adds).
        labels : sequence of int arrays ``[H, W]``
            Object id per pixel after the step (0 = none).
        reason : str, keyword-only
            Why a fragment that had an object has none after this step (the
            ``background`` column; default: ``step``).
        evidence : mapping, keyword-only
            ``frozenset({a, b}) -> value`` for objects ``a``, ``b`` (ids before
            the step) that the step joined: the value its edges carry.
        evidence_name : str, keyword-only
            What the value is (``"ncut"``, ``"shared"``, ...).
        """
        if len(labels) != len(self.fragments):
            raise ValueError(f"expected labels for {len(self.fragments)} views (got {len(labels)})")
        state = np.zeros(self.num_fragments, np.int64)
        for v, lab in enumerate(labels):
            state = self._read_view(v, np.asarray(lab), state)
        self.steps.append(step)
        self.states.append(state[: self.num_fragments])
        self.reasons.append(reason or step)
        self.evidence.append(dict(evidence or {}))
        self.evidence_names.append(evidence_name)

    def _read_view(self, v: int, lab: np.ndarray, state: np.ndarray) -> np.ndarray:
        frag = self.fragments[v]
        if lab.shape != frag.shape:
            raise ValueError(f"view {v}: expected labels of shape {list(frag.shape)} (got {list(lab.shape)})")
        inside = frag >= 0
        f = frag[inside].astype(np.int64)
        new = lab[inside].astype(np.int64)
        first = np.zeros(self.num_fragments, np.int64)
        first[f[::-1]] = new[::-1]  # the value at each fragment's first pixel
        if np.array_equal(first[f], new):
            sel = np.flatnonzero(self.view == v)
            state[sel] = first[sel]
            return state
        top = int(new.max(initial=0)) + 1
        if (new < 0).any():
            raise ValueError(f"view {v}: expected object ids >= 0 (got {int(new.min())})")
        pairs, inverse = np.unique(f * top + new, return_inverse=True)
        key = np.stack([pairs // top, pairs % top])
        parent = key[0]
        keep = np.r_[True, parent[1:] != parent[:-1]]  # the first pair of an old fragment keeps its id
        ids = np.where(keep, parent, 0)
        born = np.flatnonzero(~keep)
        ids[born] = self.num_fragments + np.arange(born.size)
        self._grow(parent[born])
        frag_new = np.full(frag.shape, -1, np.int32)
        frag_new[inside] = ids[np.asarray(inverse).reshape(-1)]
        self.fragments[v] = frag_new
        state = np.concatenate([state, np.zeros(born.size, np.int64)])
        state[ids] = key[1]
        return state

    def _grow(self, parents: np.ndarray) -> None:
        self.view = np.concatenate([self.view, self.view[parents]])
        self.mask_id = np.concatenate([self.mask_id, self.mask_id[parents]])
        self.states = [np.concatenate([s, s[parents]]) for s in self.states]

    def graph(self, *, meta: Mapping[str, Any] | None = None) -> CorrespondenceGraph:
        """The objects graph: one node per fragment, the steps as edges.

        Returns
        -------
        CorrespondenceGraph
            Mask-level, with ``masks`` the fragment images (``mask_id + 1``,
            fragments numbered per view). Node columns: ``view``,
            ``mask_id``, ``area``, ... (as :meth:`CorrespondenceGraph.from_masks`),
            ``source_mask`` (the composed mask the fragment is part of),
            ``object`` (after the last step; 0 = background), ``background``
            (the reason, or ""), and ``after_<step>`` per step. Edge columns:
            ``criterion`` (the step that joined the two fragments' parts),
            ``evidence`` and ``evidence_name`` (NaN / "" where the step
            recorded none) and ``cut_by`` (the step that cut the edge; "" =
            live). ``meta["steps"]`` lists the steps in order.
        """
        order = np.lexsort((np.arange(self.num_fragments), self.view))
        local = np.empty(self.num_fragments, np.int64)
        counts = np.bincount(self.view, minlength=len(self.fragments))
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        local[order] = np.arange(self.num_fragments) - starts[self.view[order]]
        images = []
        for frag in self.fragments:
            img = np.zeros(frag.shape, np.int32)
            inside = frag >= 0
            img[inside] = local[frag[inside]] + 1
            images.append(img)
        g = CorrespondenceGraph.from_masks(images, meta={**(meta or {}), "steps": list(self.steps)})
        node = np.empty(self.num_fragments, np.int64)  # fragment -> node (nodes by view, then local id)
        node[order] = np.arange(self.num_fragments)
        if g.num_nodes != self.num_fragments:
            raise AssertionError(f"{self.num_fragments} fragments but {g.num_nodes} nodes with pixels")
        area = g.node_attr["area"][node]
        columns = {"source_mask": self.mask_id}
        for s, state in zip(self.steps, self.states):
            columns[f"after_{s}"] = state
        columns["object"] = self.states[-1]
        columns["background"] = self._background()
        for k, col in columns.items():
            out = np.empty_like(col)
            out[node] = col
            g.node_attr[k] = out
        src, dst, attrs = self._edges(area)
        g.add_edges(np.stack([node[src], node[dst]]) if src.size else np.zeros((2, 0), np.int64), attrs, in_place=True)
        return g

    def _background(self) -> np.ndarray:
        reason = np.full(self.num_fragments, "", dtype=object)
        for k in range(1, len(self.states)):
            became = (self.states[k] == 0) & (self.states[k - 1] != 0)
            reason[became] = self.reasons[k]
            reason[self.states[k] != 0] = ""
        return reason.astype(str)

    def _edges(self, area: np.ndarray) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        F = self.num_fragments
        src: list[np.ndarray] = []
        dst: list[np.ndarray] = []
        crit: list[str] = []
        cut = np.zeros(0, dtype=object)
        evid: list[np.ndarray] = []
        evid_name: list[str] = []
        for k, state in enumerate(self.states):
            s_all = np.concatenate(src) if src else np.zeros(0, np.int64)
            d_all = np.concatenate(dst) if dst else np.zeros(0, np.int64)
            live = cut == ""
            broken = live & ((state[s_all] != state[d_all]) | (state[s_all] == 0))
            cut[broken] = self.steps[k]
            live = cut == ""
            comp = _components(F, s_all[live], d_all[live])
            a, b, values = _join_edges(state, comp, area, self.states[k - 1] if k else None, self.evidence[k])
            src.append(a)
            dst.append(b)
            crit.extend([self.steps[k]] * a.size)
            evid.append(values)
            evid_name.extend([self.evidence_names[k] if np.isfinite(values).any() else ""] * a.size)
            cut = np.concatenate([cut, np.full(a.size, "", dtype=object)])
        attrs = {
            "criterion": np.array(crit, dtype=str) if crit else np.zeros(0, "<U1"),
            "cut_by": cut.astype(str) if cut.size else np.zeros(0, "<U1"),
            "evidence": np.concatenate(evid) if evid else np.zeros(0),
            "evidence_name": np.array(evid_name, dtype=str) if evid_name else np.zeros(0, "<U1"),
        }
        return np.concatenate(src), np.concatenate(dst), attrs


def _components(n: int, src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    adj = sparse.coo_matrix((np.ones(src.size, np.int8), (src, dst)), shape=(n, n))
    return connected_components(adj, directed=False)[1].astype(np.int64)


def _join_edges(
    state: np.ndarray, comp: np.ndarray, area: np.ndarray, before: np.ndarray | None, evidence: Mapping[frozenset[int], float]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per object, star edges from its largest live component to its other components."""
    fg = np.flatnonzero(state > 0)
    if fg.size == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    # one representative per (object, component): its largest fragment
    order = fg[np.lexsort((-area[fg], comp[fg], state[fg]))]
    first = np.r_[True, (state[order][1:] != state[order][:-1]) | (comp[order][1:] != comp[order][:-1])]
    reps = order[first]
    size = np.add.reduceat(area[order], np.flatnonzero(first))
    obj = state[reps]
    # per object, the representative of its largest component is the centre of the star
    by = np.lexsort((-size, obj))
    reps, obj = reps[by], obj[by]
    head = np.r_[True, obj[1:] != obj[:-1]]
    centre = reps[np.flatnonzero(head)[np.cumsum(head) - 1]]
    a, b = centre[~head], reps[~head]
    values = np.full(a.size, np.nan)
    if before is not None and evidence:
        for i, (x, y) in enumerate(zip(before[a].tolist(), before[b].tolist())):
            values[i] = evidence.get(frozenset((x, y)), np.nan)
    return a, b, values


def live_components(graph: CorrespondenceGraph) -> np.ndarray:
    """Component of every node over the live edges (``cut_by == ""``) of an objects graph.

    Examples
    --------
    >>> g = CorrespondenceGraph(3, edge_index=[[0, 1], [1, 2]], edge_attr={"cut_by": np.array(["", "split"])})
    >>> live_components(g).tolist()
    [0, 0, 1]
    """
    live = np.asarray(graph.edge_attr.get("cut_by", np.full(graph.num_edges, ""))) == ""
    ei = graph.edge_index[:, live]
    return _components(graph.num_nodes, ei[0], ei[1])


def paint_objects(graph: CorrespondenceGraph) -> list[np.ndarray]:
    """The label images an objects graph explains: each live component painted with its object.

    Every live component must carry one ``object`` id and no ``background``
    node may carry one; a graph that breaks this raises ``ValueError``.

    Parameters
    ----------
    graph : CorrespondenceGraph
        From :meth:`Lineage.graph` (needs ``masks`` and the node columns
        ``object`` and ``background``).

    Returns
    -------
    list of int32 arrays ``[H, W]``
        Object id per pixel (0 = background or no mask).

    Notes
    -----
    One connected-components pass over the live edges, then O(pixels).
    """
    if graph.masks is None:
        raise ValueError("this graph stores no masks; painting needs them")
    comp = live_components(graph)
    obj = np.asarray(graph.node_attr["object"], np.int64)
    bg = np.asarray(graph.node_attr["background"]).astype(str) != ""
    if (obj[bg] != 0).any():
        raise ValueError("a background node carries an object id")
    fg = np.flatnonzero(~bg & (obj > 0))
    pairs = np.unique(np.stack([comp[fg], obj[fg]]), axis=1)  # (component, object), sorted by component
    two = np.flatnonzero(pairs[0, 1:] == pairs[0, :-1])
    if two.size:
        c = int(pairs[0, two[0]])
        raise ValueError(f"live component {c} holds objects {int(pairs[1, two[0]])} and {int(pairs[1, two[0] + 1])}")
    value = np.where(~bg, obj, 0)
    mem = graph.members
    out = []
    for v, m in enumerate(graph.masks):
        lut = np.zeros(int(np.asarray(m).max(initial=0)) + 1, np.int64)
        sel = mem["view"] == v
        lut[mem["mask_id"][sel] + 1] = value[mem["node"][sel]]
        out.append(lut[np.asarray(m, np.int64)].astype(np.int32))
    return out
