"""``quotient_graph`` for networkx by graphseg's block reduction.

networkx's ``quotient_graph`` tests every pair of blocks for an edge (O(B^2) pairs,
each a product over their nodes). Here the partition becomes a cluster vector
(node -> block) and one pass over ``edge_index`` does the rest, as
:func:`graphseg.graphs.coarsen` does for a contraction: edges inside a block count
towards its ``nedges``, edges across blocks are keyed by the block pair
``lo * B + hi``, deduplicated with ``np.unique`` and their weights summed with
``np.add.at``. The result is the networkx graph networkx would build: nodes are
the blocks as frozensets (integers with ``relabel=True``), node data ``graph``
(a subgraph view), ``nnodes``, ``nedges``, ``density``, and edge data ``weight``.

Supported: undirected simple graphs, a partition given as a collection of blocks
or a dict of blocks, the default ``edge_relation``, any ``node_data`` /
``edge_data`` callable (called once per block / block pair). :func:`unsupported`
names the reason for anything else, and the backend's ``can_run`` returns it, so
networkx runs its own implementation there.

Examples
--------
>>> import networkx as nx
>>> G = nx.path_graph(6)
>>> Q = quotient_graph(G, [{0, 1}, {2, 3}, {4, 5}], relabel=True)
>>> sorted(Q.edges(data="weight")), Q.nodes[0]["nedges"], Q.nodes[0]["density"]
([(0, 1, 1), (1, 2, 1)], 1, 1.0)
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from itertools import chain, repeat
from typing import Any

import numpy as np

from .graph import as_backend_graph

__all__ = ["quotient_graph", "unsupported"]


def unsupported(
    G: Any,
    partition: Any,
    edge_relation: Callable[..., bool] | None = None,
    node_data: Callable[..., dict] | None = None,
    edge_data: Callable[..., dict] | None = None,
    weight: Hashable | None = "weight",
    relabel: bool = False,
    create_using: Any = None,
    **backend_kwargs: Any,
) -> str | None:
    """Why the graphseg ``quotient_graph`` cannot run these arguments, or None when it can.

    Takes ``quotient_graph``'s arguments as networkx received them.

    Examples
    --------
    >>> import networkx as nx
    >>> unsupported(nx.DiGraph([(0, 1)]), [{0}, {1}])
    'directed graphs: the quotient of a digraph sums both directions into each edge weight; networkx runs it'
    >>> unsupported(nx.path_graph(2), [{0}, {1}]) is None
    True
    """
    if backend_kwargs:
        return f"unknown keyword arguments {sorted(backend_kwargs)}"
    if G.is_directed():
        return "directed graphs: the quotient of a digraph sums both directions into each edge weight; networkx runs it"
    if G.is_multigraph():
        return "multigraphs: their quotient keeps one edge per original edge with its data; networkx runs it"
    if callable(partition):
        return "an equivalence relation as partition needs O(N^2) calls of it; networkx runs it"
    if edge_relation is not None:
        return "a custom edge_relation is a Python call per pair of blocks; networkx runs it"
    if callable(weight):
        return "a callable weight is not an edge attribute name"
    if create_using is not None:
        import networkx as nx

        H = nx.empty_graph(0, create_using)
        if H.is_directed() or H.is_multigraph():
            return f"create_using gives a {type(H).__name__}; only undirected simple graphs are built"
    return None


def _density(n: int, m: int) -> float | int:
    """``networkx.density`` of an undirected graph with ``n`` nodes and ``m`` edges."""
    if m == 0 or n <= 1:
        return 0
    d = m / (n * (n - 1))
    return d * 2


def quotient_graph(
    G: Any,
    partition: Any,
    edge_relation: Callable[..., bool] | None = None,
    node_data: Callable[..., dict] | None = None,
    edge_data: Callable[..., dict] | None = None,
    weight: Hashable | None = "weight",
    relabel: bool = False,
    create_using: Any = None,
) -> Any:
    """The quotient graph of ``G`` under a partition of its nodes (networkx's semantics).

    Parameters
    ----------
    G : EdgeIndexGraph or networkx.Graph
        Undirected and simple. Converted with its ``weight`` column when it is
        a networkx graph.
    partition : list of sets, or dict of sets
        Blocks of nodes. Blocks that cover only part of ``G`` restrict ``G`` to
        the covered nodes (networkx's rule).
    edge_relation : None
        Only the default (blocks joined by at least one edge).
    node_data : callable, optional
        ``f(block) -> dict``; default ``graph`` (subgraph view), ``nnodes``,
        ``nedges``, ``density``.
    edge_data : callable, optional
        ``f(block, block) -> dict``; default ``{"weight": sum of the weights
        of the edges joining the blocks}`` (a missing weight counts 1).
    weight : hashable or None
        Edge attribute summed by the default ``edge_data``.
    relabel : bool
        Number the blocks ``0..B-1`` in partition order.
    create_using : networkx graph constructor, optional
        Undirected and simple; default the class of ``G``.

    Returns
    -------
    networkx.Graph

    Raises
    ------
    networkx.NetworkXException
        If a node lies in no block, in two blocks, or is not in ``G``.
    NotImplementedError
        For arguments :func:`unsupported` rejects.

    Notes
    -----
    O(N + E log E) array work, plus a Python step per block and per edge of
    the quotient to build the networkx result. The default node data holds a
    subgraph view of ``G`` per block (networkx builds the same). Float weights
    are summed in edge order, so they may differ from networkx's sum in the
    last bit.

    Examples
    --------
    >>> import networkx as nx
    >>> G = nx.Graph([(0, 1, {"weight": 2}), (1, 2, {"weight": 3}), (0, 2, {"weight": 4})])
    >>> Q = quotient_graph(G, {"a": [0], "b": [1, 2]})
    >>> list(Q.edges(data="weight"))
    [(frozenset({0}), frozenset({1, 2}), 6)]
    """
    import networkx as nx

    reason = unsupported(G, partition, edge_relation, node_data, edge_data, weight, relabel, create_using)
    if reason is not None:
        raise NotImplementedError(f"graphseg quotient_graph does not handle {reason}")
    g = as_backend_graph(G, edge_attrs=None if weight is None else {weight: 1})
    n = g.num_nodes
    blocks = list(partition.values()) if isinstance(partition, dict) else list(partition)
    k = len(blocks)
    sizes = np.fromiter(map(len, blocks), np.int64, k)
    total = int(sizes.sum())
    # C-level: label -> position, -1 for a label that is not a node of G.
    pos = np.fromiter(map(g.index.get, chain.from_iterable(blocks), repeat(-1)), np.int64, total)
    if (pos < 0).any() or (total and np.bincount(pos, minlength=n).max() > 1):
        raise nx.NetworkXException("each node must be in exactly one part of `partition`")
    block = np.full(n, -1, np.int64)
    block[pos] = np.repeat(np.arange(k, dtype=np.int64), sizes)
    restricted = total < n  # networkx restricts G to the covered nodes

    bu, bv = block[g.edge_index[0]], block[g.edge_index[1]]
    inside = (bu >= 0) & (bv >= 0)
    same = inside & (bu == bv)
    nedges = np.bincount(bu[same], minlength=k).tolist()
    cross = inside & (bu != bv)
    lo = np.minimum(bu[cross], bv[cross])
    hi = np.maximum(bu[cross], bv[cross])
    pairs, which = np.unique(lo * max(k, 1) + hi, return_inverse=True)  # sorted = networkx's combinations order
    pair_lo, pair_hi = np.divmod(pairs, max(k, 1))

    frozen = [frozenset(b) for b in blocks]
    if create_using is None:
        H = type(g.source)() if g.source is not None else nx.Graph()
    else:
        H = nx.empty_graph(0, create_using)

    if node_data is None:
        base = g.source if g.source is not None else g.to_networkx()
        if restricted:
            base = base.subgraph(set(chain.from_iterable(frozen)))
        sizes_list = sizes.tolist()

        def default_node_data(i: int) -> dict[str, Any]:
            return {
                "graph": base.subgraph(frozen[i]),
                "nnodes": sizes_list[i],
                "nedges": nedges[i],
                "density": _density(sizes_list[i], nedges[i]),
            }

        H.add_nodes_from((b, default_node_data(i)) for i, b in enumerate(frozen))
    else:
        H.add_nodes_from((b, node_data(b)) for b in frozen)

    if edge_data is None:
        if weight is not None and weight in g.edge_attr:
            w = g.edge_attr[weight][cross]
        else:  # no weight column: every edge counts 1, as a missing attribute does in networkx
            w = np.ones(int(cross.sum()), np.int64)
        # int64 / float64 sums; an object column starts from Python's int 0 and adds with
        # Python's + in edge order, as networkx's sum() does.
        sums = np.zeros(pairs.size, dtype=w.dtype if w.dtype.kind in "iO" else np.float64)
        np.add.at(sums, which, w)
        H.add_edges_from(
            (frozen[a], frozen[b], {"weight": s})
            for a, b, s in zip(pair_lo.tolist(), pair_hi.tolist(), sums.tolist())
        )
    else:
        H.add_edges_from(
            (frozen[a], frozen[b], edge_data(frozen[a], frozen[b]))
            for a, b in zip(pair_lo.tolist(), pair_hi.tolist())
        )

    if relabel:
        H = nx.relabel_nodes(H, {b: i for i, b in enumerate(frozen)})
    return H
