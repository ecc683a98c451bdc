"""View consensus (MaskClustering's criterion) from pixel matches.

For every node ``a`` and every view ``k``, the *container* of ``a`` in ``k``
is the node of view ``k`` that receives most of ``a``'s matches into ``k``
(when at least ``min_matches`` of them land on a node); in its own view a
node is its own container. Two nodes *agree* in a view where both have a
container and it is the same one. Their consensus is the fraction of views,
among those where both have a container, in which they agree. An
under-segmented mask covering two objects in one view then still scores low
against the second object, because every other view keeps them apart.

Examples
--------
>>> import numpy as np
>>> C = np.array([[0, 2], [0, 2], [1, 2]])    # nodes x views: container ids (-1 = none)
>>> ei, cons, obs = consensus_pairs(C, min_views=2, threshold=0.9)
>>> ei.tolist(), cons.tolist()
([[0], [1]], [1.0])
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from .criterion import Criterion
from .evidence import EdgeSet, Evidence
from .graph import CorrespondenceGraph
from .pixel_match import lookup_pixels, pair_counts

__all__ = ["containers", "consensus_pairs", "view_consensus_edges", "ViewConsensus"]


def containers(
    node_labels: Sequence[np.ndarray],
    matches: Mapping[tuple[int, int], Any],
    num_nodes: int,
    *,
    min_matches: int,
    min_share: float,
) -> np.ndarray:
    """Container of every node in every view, from pixel matches.

    Parameters
    ----------
    node_labels : list of int ``[H, W]`` (-1 = none), one per view
    matches : mapping ``(i, j) -> Matches`` (``xy_i``, ``xy_j`` pixel arrays)
    num_nodes : int
    min_matches : int
        A node needs this many matches into view ``k`` landing on nodes.
    min_share : float
        The container must receive this share of them.

    Returns
    -------
    numpy.ndarray
        int64 ``[N, V]``: container node id, ``-1`` where none. Column
        ``view(a)`` holds ``a`` itself.

    Notes
    -----
    O(total matches + N V).

    Examples
    --------
    >>> from graphseg.scene import Matches
    >>> labs = [np.array([[0, 1]]), np.array([[2, 2]])]
    >>> m = {(0, 1): Matches([[0, 0], [1, 0]], [[0, 0], [1, 0]], [1.0, 1.0])}
    >>> containers(labs, m, 3, min_matches=1, min_share=0.5).tolist()   # node 2 splits 1:1 over 0 and 1; ties go to the lower id
    [[0, 2], [1, 2], [0, 2]]
    """
    n_views = len(node_labels)
    out = np.full((num_nodes, n_views), -1, np.int64)
    for v, lab in enumerate(node_labels):
        ids = np.unique(lab[lab >= 0])
        out[ids, v] = ids
    hist: dict[int, list[tuple[np.ndarray, np.ndarray]]] = {}
    for (i, j), m in matches.items():
        if len(m) == 0:
            continue
        a, in_a = lookup_pixels(node_labels[i], m.xy_i)
        b, in_b = lookup_pixels(node_labels[j], m.xy_j)
        ok = in_a & in_b & (a >= 0) & (b >= 0)
        for src, dst, view in ((a[ok], b[ok], j), (b[ok], a[ok], i)):
            hist.setdefault(view, []).append((src.astype(np.int64), dst.astype(np.int64)))
    for view, parts in hist.items():
        src = np.concatenate([p[0] for p in parts])
        dst = np.concatenate([p[1] for p in parts])
        s, d, cnt = pair_counts(src, dst, max(num_nodes, 1))
        tot = np.bincount(s, weights=cnt, minlength=num_nodes)
        order = np.lexsort((-cnt, s))
        first = np.ones(order.size, bool)
        first[1:] = s[order][1:] != s[order][:-1]
        best = order[first]
        good = (tot[s[best]] >= min_matches) & (cnt[best] >= min_share * tot[s[best]])
        rows = s[best][good]
        keep = out[rows, view] < 0  # a node's own view stays itself
        out[rows[keep], view] = d[best][good][keep]
    return out


def consensus_pairs(container: np.ndarray, *, min_views: int, threshold: float, below: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Node pairs whose consensus reaches ``threshold`` over at least ``min_views`` views.

    Parameters
    ----------
    container : int ``[N, V]`` from :func:`containers`
    min_views : int
        Views in which both nodes need a container.
    threshold : float
        Consensus a pair needs (at least, or with ``below`` at most).
    below : bool
        Return the pairs whose consensus is at most ``threshold`` instead.

    Returns
    -------
    edge_index : int64 ``[2, P]`` (``u < v``), consensus float64 ``[P]``, observers int64 ``[P]``

    Notes
    -----
    O(N^2 V) time, O(N^2) memory per view column (dense; mask graphs have a
    few hundred to a few thousand nodes).
    """
    c = np.asarray(container, np.int64)
    n = c.shape[0]
    obs = np.zeros((n, n), np.int32)
    agree = np.zeros((n, n), np.int32)
    for k in range(c.shape[1]):
        col = c[:, k]
        seen = col >= 0
        obs += seen[:, None] & seen[None, :]
        agree += (col[:, None] == col[None, :]) & seen[:, None]
    u, v = np.triu_indices(n, 1)
    o, a = obs[u, v], agree[u, v]
    cons = np.where(o > 0, a / np.maximum(o, 1), 0.0)
    keep = (o >= min_views) & ((cons <= threshold) if below else (cons >= threshold))
    return np.stack([u[keep], v[keep]]).astype(np.int64), cons[keep], o[keep].astype(np.int64)


def view_consensus_edges(
    node_labels: Sequence[np.ndarray],
    matches: Mapping[tuple[int, int], Any],
    num_nodes: int,
    *,
    threshold: float,
    min_views: int,
    min_matches: int,
    min_share: float,
    attract: bool,
    repel_below: float | None,
) -> EdgeSet:
    """Edges between nodes whose view consensus reaches ``threshold``.

    With ``repel_below``, pairs whose consensus is at most that value (over at
    least ``min_views`` views) also get cannot-link edges (``sign = -1``,
    ``weight = 1 - consensus``); ``attract=False`` keeps only those. Every
    option is a required keyword: the defaults live in :class:`ViewConsensus.Options`
    (``min_matches`` and ``min_share`` go to :func:`containers`, ``min_views``
    and ``threshold`` to :func:`consensus_pairs`).

    Returns
    -------
    EdgeSet
        Columns ``criterion`` ("view_consensus"), ``weight`` (= consensus),
        ``observers`` (views where both have a container), ``sign`` (+1, or -1
        for cannot-links).
    """
    c = containers(node_labels, matches, num_nodes, min_matches=min_matches, min_share=min_share)
    ei, cons, obs = consensus_pairs(c, min_views=min_views, threshold=threshold) if attract else (np.zeros((2, 0), np.int64), np.zeros(0), np.zeros(0, np.int64))
    sign = np.ones(ei.shape[1])
    if repel_below is not None:
        rei, rcons, robs = consensus_pairs(c, min_views=min_views, threshold=repel_below, below=True)
        ei = np.concatenate([ei, rei], axis=1)
        cons, obs = np.concatenate([cons, 1.0 - rcons]), np.concatenate([obs, robs])
        sign = np.concatenate([sign, -np.ones(rei.shape[1])])
    return EdgeSet(
        ei,
        {"criterion": np.full(ei.shape[1], "view_consensus"), "weight": cons, "observers": obs, "sign": sign},
        info={"threshold": threshold, "cannot_links": int((sign < 0).sum())},
    )


class ViewConsensus(Criterion):
    """The ``view_consensus`` criterion: :func:`view_consensus_edges` as an edge adder.

    Examples
    --------
    >>> from graphseg.scene import Matches
    >>> g = CorrespondenceGraph.from_masks([np.array([[1, 2]]), np.array([[1, 1]])])
    >>> ev = Evidence.for_graph(g, matches={(0, 1): Matches([[0, 0], [1, 0]], [[0, 0], [1, 0]], [1.0, 1.0])})
    >>> ViewConsensus(min_matches=1, min_views=1, threshold=1.0)(g, ev).edge_index.tolist()   # node 2 covers 0 and 1
    [[0], [2]]
    """

    name = "view_consensus"
    requires = frozenset({"node_labels", "matches"})
    reduce = {"weight": "max", "observers": "max"}
    tags = {"dimension": "2d"}

    class Options(BaseModel):
        model_config = ConfigDict(extra="forbid")
        threshold: float = Field(0.9, ge=0, le=1)
        min_views: int = Field(2, ge=1)
        min_matches: int = Field(5, ge=1)
        min_share: float = Field(0.5, ge=0, le=1)
        attract: bool = True
        repel_below: float | None = Field(None, ge=0, le=1)


    def __call__(self, graph: CorrespondenceGraph, evidence: Evidence) -> EdgeSet:
        return view_consensus_edges(evidence.node_labels, evidence.matches, graph.num_nodes, **self.options.model_dump())
