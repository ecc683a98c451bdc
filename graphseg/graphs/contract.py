"""Contractors: edge_index -> cluster vector (node -> component id).

Every contractor returns canonical ids ``0..k-1`` numbered in order of first
appearance over the nodes, so two partitions compare with ``==``. Building the
contracted graph is the job of :func:`graphseg.graphs.coarsen`, shared by all.

Examples
--------
>>> import numpy as np
>>> ei = np.array([[0, 3], [1, 4]])
>>> randomized_star_contraction(ei, 5, rng=0).tolist()
[0, 0, 1, 2, 2]
>>> union_find_contraction(ei, 5).tolist()
[0, 0, 1, 2, 2]
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import BaseModel

from .coalesce import canonical_cluster, combine_keys
from .contractor import BaseContractor
from .graph import as_edge_index

# canonical_cluster (now in coalesce) stays importable from here
__all__ = [
    "canonical_cluster",
    "randomized_star_contraction",
    "union_find_contraction",
    "scipy_contraction",
    "StarContraction",
    "UnionFindContraction",
    "ScipyContraction",
]


def _dedupe(a: np.ndarray, b: np.ndarray, m: int) -> tuple[np.ndarray, np.ndarray]:
    """Drop duplicate undirected edges when a dense pass over m*m pairs is cheap."""
    if m * m > 8 * a.size + 4096:
        return a, b
    lo = np.minimum(a, b).astype(np.int64)
    hi = np.maximum(a, b).astype(np.int64)
    seen = np.zeros(m * m, bool)  # m * m is bounded above: a bitmap is the cheapest set
    seen[combine_keys([lo, hi], [m, m])] = True
    keys = np.flatnonzero(seen)
    lo, hi = np.divmod(keys, m)
    return lo.astype(a.dtype), hi.astype(a.dtype)


def randomized_star_contraction(
    edge_index: Any,
    num_nodes: int,
    *,
    rng: Any = None,
    return_rounds: bool = False,
) -> Any:
    """Connected components by randomized star contraction (the paper's contractor).

    In each round every current vertex draws a random label (a random
    permutation, so labels are distinct). A vertex whose label is the minimum of
    its closed neighbourhood is a star centre; every other vertex hooks to the
    neighbour with the minimum label. Hook chains strictly decrease in label, so
    pointer jumping sends every vertex to a centre. Centres become the new
    vertices, edges are relabelled and self-loops dropped, and the rounds repeat
    until no edge remains.

    Parameters
    ----------
    edge_index : array_like of int, shape ``[2, E]``
        Undirected edges; self-loops and duplicates are allowed.
    num_nodes : int
        Number of nodes ``N``.
    rng : None, int or numpy.random.Generator, keyword-only
        Seed or generator for the labels (``np.random.default_rng(rng)``).
    return_rounds : bool, keyword-only
        Also return the number of contraction rounds (a diagnostic; about
        ``O(log N)`` with high probability).

    Returns
    -------
    cluster : numpy.ndarray
        int64 ``[N]``, canonical component ids.
    rounds : int
        Only with ``return_rounds=True``.

    Notes
    -----
    Fully vectorized: the Python loops run over rounds and pointer-jump steps
    only. Each round costs O(N' + E') for the current vertex and edge counts,
    and the minimum over neighbourhoods is a ``np.minimum.at`` scatter.

    Examples
    --------
    >>> ei = np.array([[0, 1, 2], [1, 2, 0]])
    >>> cluster, rounds = randomized_star_contraction(ei, 4, rng=1, return_rounds=True)
    >>> cluster.tolist(), rounds
    ([0, 0, 0, 1], 1)
    """
    n = int(num_nodes)
    ei = as_edge_index(edge_index, n)
    gen = np.random.default_rng(rng)
    idt = np.int32 if n < 2**31 - 1 else np.int64
    a = ei[0].astype(idt)
    b = ei[1].astype(idt)
    keep = a != b
    a, b = a[keep], b[keep]
    comp = np.arange(n, dtype=idt)  # original node -> current vertex
    m = n
    rounds = 0
    while a.size:
        rounds += 1
        a, b = _dedupe(a, b, m)
        label = gen.permutation(m).astype(idt)
        best = label.copy()
        np.minimum.at(best, a, label[b])
        np.minimum.at(best, b, label[a])
        vertex_of_label = np.empty(m, dtype=idt)
        vertex_of_label[label] = np.arange(m, dtype=idt)
        hook = vertex_of_label[best]  # centres hook to themselves
        while True:  # pointer jumping: O(log chain length) steps
            nxt = hook[hook]
            if np.array_equal(nxt, hook):
                break
            hook = nxt
        is_centre = hook == np.arange(m, dtype=idt)
        new_id = (np.cumsum(is_centre, dtype=np.int64) - 1).astype(idt)
        relabel = new_id[hook]
        comp = relabel[comp]
        a, b = relabel[a], relabel[b]
        keep = a != b
        a, b = a[keep], b[keep]
        m = int(is_centre.sum())
    cluster = canonical_cluster(comp)
    return (cluster, rounds) if return_rounds else cluster


def union_find_contraction(edge_index: Any, num_nodes: int) -> np.ndarray:
    """Connected components by union-find: the simple, obviously correct reference.

    Parameters
    ----------
    edge_index : array_like of int, shape ``[2, E]``
    num_nodes : int

    Returns
    -------
    numpy.ndarray
        int64 ``[N]``, canonical component ids.

    Notes
    -----
    Union by rank with path compression (halving): O((N + E) alpha(N)). Pure
    Python over edges, so slower than the vectorized contractors.

    Examples
    --------
    >>> union_find_contraction([[0, 2], [2, 3]], 5).tolist()
    [0, 1, 0, 0, 2]
    """
    n = int(num_nodes)
    ei = as_edge_index(edge_index, n)
    parent = list(range(n))
    rank = [0] * n

    def find(x: int) -> int:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for u, v in zip(ei[0].tolist(), ei[1].tolist()):
        ru, rv = find(u), find(v)
        if ru == rv:
            continue
        if rank[ru] < rank[rv]:
            ru, rv = rv, ru
        parent[rv] = ru
        if rank[ru] == rank[rv]:
            rank[ru] += 1
    return canonical_cluster([find(x) for x in range(n)])


def scipy_contraction(edge_index: Any, num_nodes: int) -> np.ndarray:
    """Connected components through ``scipy.sparse.csgraph.connected_components``.

    Examples
    --------
    >>> scipy_contraction([[1], [2]], 3).tolist()
    [0, 1, 1]
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n = int(num_nodes)
    ei = as_edge_index(edge_index, n)
    adj = coo_matrix((np.ones(ei.shape[1], np.int8), (ei[0], ei[1])), shape=(n, n))
    _, labels = connected_components(adj, directed=False)
    return canonical_cluster(labels)


class StarContraction(BaseContractor):
    """Randomized star contraction as a contractor object (registered as ``star``).

    Parameters
    ----------
    options : StarContraction.Options, optional
        No options: randomness comes only from the call's ``rng``.

    Attributes
    ----------
    rounds_ : int or None
        Rounds used by the last call.

    Examples
    --------
    >>> c = StarContraction()
    >>> c([[0], [1]], 3, rng=0).tolist(), c.rounds_
    ([0, 0, 1], 1)
    """

    name = "star"

    def __init__(self, options: BaseModel | None = None, /, **kwargs: Any) -> None:
        super().__init__(options, **kwargs)
        self.rounds_: int | None = None

    def __call__(self, edge_index: Any, num_nodes: int, *, rng: Any = None) -> np.ndarray:
        cluster, self.rounds_ = randomized_star_contraction(edge_index, num_nodes, rng=rng, return_rounds=True)
        return cluster


class UnionFindContraction(BaseContractor):
    """Union-find contraction as a contractor object (``rng`` is ignored)."""

    name = "union_find"

    def __call__(self, edge_index: Any, num_nodes: int, *, rng: Any = None) -> np.ndarray:
        return union_find_contraction(edge_index, num_nodes)


class ScipyContraction(BaseContractor):
    """scipy csgraph connected components as a contractor object (``rng`` ignored)."""

    name = "scipy"

    def __call__(self, edge_index: Any, num_nodes: int, *, rng: Any = None) -> np.ndarray:
        return scipy_contraction(edge_index, num_nodes)
