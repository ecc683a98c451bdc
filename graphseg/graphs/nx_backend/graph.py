"""The graph type of the graphseg networkx backend: ``edge_index`` plus the node list.

:class:`EdgeIndexGraph` is what networkx hands to the backend after conversion: an
undirected graph stored as an int64 ``edge_index`` ``[2, E]`` over node *positions*
``0..N-1``, with the original node labels kept in order (position ``i`` is the
``i``-th node of ``G``), so results map back to labels with one fancy index.

:func:`networkx_to_arrays` converts a networkx graph without a Python loop over
edges: degrees and neighbour labels are read with ``np.fromiter`` over networkx's
adjacency dicts (C-level iteration), and labels become positions either by
arithmetic (integer labels) or by one C-level dict lookup per adjacency entry.

Examples
--------
>>> import networkx as nx
>>> G = nx.Graph([("a", "b"), ("c", "c")])
>>> G.add_node("d")
>>> g = EdgeIndexGraph.from_networkx(G)
>>> g
EdgeIndexGraph(num_nodes=4, num_edges=2)
>>> g.edge_index.tolist(), list(g)
([[0, 2], [1, 2]], ['a', 'b', 'c', 'd'])
>>> sorted(g.to_networkx().edges())
[('a', 'b'), ('c', 'c')]
"""

from __future__ import annotations

from collections.abc import Hashable, Iterable, Iterator, Mapping
from itertools import chain
from operator import methodcaller
from typing import Any

import numpy as np

from ..graph import as_edge_index

__all__ = ["EdgeIndexGraph", "networkx_to_arrays", "as_backend_graph", "BACKEND_NAME"]

#: The name graphseg is registered under in the ``networkx.backends`` entry-point group.
BACKEND_NAME = "graphseg"


def _column(values: list[Any]) -> np.ndarray:
    """One attribute column: int64 / float64 when every value is a plain number, else objects.

    bool values become int64 (``sum`` of bools is an int in Python); anything
    else (numpy scalars, Fractions, strings, None) stays an object array, so a
    reduction over it behaves as Python's ``+`` does.
    """
    types = set(map(type, values))
    if types <= {int, bool}:
        try:
            return np.fromiter(values, np.int64, len(values))
        except OverflowError:
            pass
    elif types <= {int, float, bool}:
        return np.fromiter(values, np.float64, len(values))
    return np.fromiter(values, object, len(values))


def _int_labels(nodes: list[Any]) -> np.ndarray | None:
    """int64 labels when every node is a plain ``int`` that fits, else None."""
    if set(map(type, nodes)) != {int}:
        return None
    try:
        return np.fromiter(nodes, np.int64, len(nodes))
    except OverflowError:
        return None


def networkx_to_arrays(
    G: Any, *, edge_attrs: Mapping[Hashable, Any] | None = None
) -> tuple[np.ndarray, list[Any], dict[Hashable, np.ndarray]]:
    """Read an undirected networkx graph into ``edge_index``, node list and edge columns.

    Parameters
    ----------
    G : networkx.Graph or networkx.MultiGraph
        Undirected; views (``G.subgraph(...)``) work too.
    edge_attrs : mapping of attribute name -> default, optional
        Edge attributes to read into columns (a missing value takes the
        default). Not for multigraphs.

    Returns
    -------
    edge_index : numpy.ndarray
        int64 ``[2, E]`` over node positions; every undirected edge once, with
        ``edge_index[0] <= edge_index[1]``; self-loops kept. A multigraph's
        parallel edges become one edge (they do not change connectivity).
    nodes : list
        ``list(G)``: position -> label.
    edge_attr : dict of numpy.ndarray
        One ``[E]`` column per name of ``edge_attrs``.

    Raises
    ------
    NotImplementedError
        For a directed graph, or ``edge_attrs`` on a multigraph.

    Notes
    -----
    O(N + E) with no Python bytecode per edge: ``np.fromiter`` over
    ``itertools.chain`` of networkx's adjacency dicts. Integer labels map to
    positions by ``searchsorted`` (identity when the labels are ``0..N-1`` in
    order); other labels by a C-level ``dict`` lookup.

    Examples
    --------
    >>> import networkx as nx
    >>> ei, nodes, cols = networkx_to_arrays(nx.Graph([(5, 3, {"w": 2})]), edge_attrs={"w": 1})
    >>> ei.tolist(), nodes, cols["w"].tolist()
    ([[0], [1]], [5, 3], [2])
    """
    if G.is_directed():
        raise NotImplementedError(f"graphseg backend graphs are undirected (got a directed {type(G).__name__})")
    if edge_attrs and G.is_multigraph():
        raise NotImplementedError(f"graphseg backend reads no edge attributes of a multigraph (asked for {sorted(map(str, edge_attrs))})")
    adj = G._adj
    nodes = list(adj)
    n = len(nodes)
    deg = np.fromiter(map(len, adj.values()), np.int64, n)
    m = int(deg.sum())
    labels = _int_labels(nodes)
    if labels is not None:
        nbr = np.fromiter(chain.from_iterable(adj.values()), np.int64, m)
        if not np.array_equal(labels, np.arange(n)):
            sorter = np.argsort(labels, kind="stable")
            nbr = sorter[np.searchsorted(labels, nbr, sorter=sorter)]
    else:
        index = dict(zip(nodes, range(n)))
        nbr = np.fromiter(map(index.__getitem__, chain.from_iterable(adj.values())), np.int64, m)
    src = np.repeat(np.arange(n, dtype=np.int64), deg)
    keep = src <= nbr  # each undirected edge is listed from both ends; a self-loop once
    edge_index = np.stack([src[keep], nbr[keep]])
    cols: dict[Hashable, np.ndarray] = {}
    for name, default in (edge_attrs or {}).items():
        data = chain.from_iterable(map(methodcaller("values"), adj.values()))
        cols[name] = _column(list(map(methodcaller("get", name, default), data)))[keep]
    return edge_index, nodes, cols


class EdgeIndexGraph:
    """An undirected graph as graphseg arrays, the graph type of the networkx backend.

    networkx recognises it by ``__networkx_backend__ = "graphseg"``, so passing
    one to a networkx function that graphseg implements runs graphseg's version
    without converting again.

    Parameters
    ----------
    edge_index : array_like of int, shape ``[2, E]``
        Undirected edges over node positions ``0..num_nodes-1`` (any order;
        duplicates and self-loops allowed). Copied.
    num_nodes : int
        ``N``.
    nodes : sequence of hashable, optional
        Label of each position (default ``0..N-1``); distinct.
    edge_attr : mapping of name -> array_like ``[E]``, optional
        Edge columns (the backend reads ``weight`` for ``quotient_graph``).
    graph : mapping, optional
        Graph attributes.

    Attributes
    ----------
    edge_index : numpy.ndarray
        int64 ``[2, E]``, read-only.
    num_nodes : int
    nodes : tuple
        Position -> label.
    source : networkx.Graph or None
        The graph this one was converted from (used for subgraph views in
        ``quotient_graph``'s node data), else None.

    Examples
    --------
    >>> g = EdgeIndexGraph([[0, 1], [1, 2]], 4, nodes="wxyz")
    >>> len(g), g.number_of_edges(), "z" in g, g.is_directed()
    (4, 2, True, False)
    >>> EdgeIndexGraph([[0], [5]], 2)
    Traceback (most recent call last):
    ...
    graphseg.graphs.graph.GraphValidationError: expected edge_index entries in [0, num_nodes=2) (got 5)
    """

    __networkx_backend__ = BACKEND_NAME

    def __init__(
        self,
        edge_index: Any,
        num_nodes: int,
        *,
        nodes: Iterable[Hashable] | None = None,
        edge_attr: Mapping[Hashable, Any] | None = None,
        graph: Mapping[Any, Any] | None = None,
    ) -> None:
        n = int(num_nodes)
        if n < 0:
            raise ValueError(f"expected num_nodes >= 0 (got {n})")
        ei = np.array(as_edge_index(edge_index, n), dtype=np.int64, copy=True)
        labels = list(range(n)) if nodes is None else list(nodes)
        if len(labels) != n:
            raise ValueError(f"expected {n} node labels (got {len(labels)})")
        if len(set(labels)) != n:
            raise ValueError(f"expected distinct node labels ({n - len(set(labels))} repeated)")
        cols = {}
        for name, col in (edge_attr or {}).items():
            arr = np.array(col, copy=True)
            if arr.shape[:1] != (ei.shape[1],):
                raise ValueError(f"edge_attr[{name!r}]: expected length {ei.shape[1]} (got shape {list(arr.shape)})")
            cols[name] = arr
        self._set(ei, labels, cols, dict(graph or {}), None)

    def _set(self, edge_index: np.ndarray, nodes: list[Any], edge_attr: dict[Hashable, np.ndarray], graph: dict[Any, Any], source: Any) -> None:
        edge_index.setflags(write=False)
        for col in edge_attr.values():
            col.setflags(write=False)
        self.edge_index = edge_index
        self.num_nodes = len(nodes)
        self.nodes = tuple(nodes)
        self.edge_attr = edge_attr
        self.graph = graph
        self.source = source
        self._index: dict[Any, int] | None = None
        self._node_array: np.ndarray | None = None

    @classmethod
    def from_networkx(
        cls, G: Any, *, edge_attrs: Mapping[Hashable, Any] | None = None, graph_attrs: bool = True
    ) -> EdgeIndexGraph:
        """Convert an undirected networkx graph (see :func:`networkx_to_arrays`).

        Parameters
        ----------
        G : networkx.Graph or networkx.MultiGraph
        edge_attrs : mapping of name -> default, optional
            Edge attributes to keep as columns.
        graph_attrs : bool
            Copy ``G.graph`` (a shallow copy).

        Examples
        --------
        >>> import networkx as nx
        >>> EdgeIndexGraph.from_networkx(nx.path_graph(3)).edge_index.tolist()
        [[0, 1], [1, 2]]
        """
        edge_index, nodes, cols = networkx_to_arrays(G, edge_attrs=edge_attrs)
        out = cls.__new__(cls)
        out._set(edge_index, nodes, cols, dict(G.graph) if graph_attrs else {}, G)
        return out

    def to_networkx(self) -> Any:
        """A new ``networkx.Graph`` with the same nodes (in order), edges and edge columns.

        Parallel edges collapse (the last one's attributes win).

        Examples
        --------
        >>> EdgeIndexGraph([[0], [1]], 3, edge_attr={"weight": [2.5]}).to_networkx().edges(data=True)
        EdgeDataView([(0, 1, {'weight': 2.5})])
        """
        import networkx as nx

        H = nx.Graph()
        H.graph.update(self.graph)
        H.add_nodes_from(self.nodes)
        labels = self.node_array
        src = labels[self.edge_index[0]].tolist()
        dst = labels[self.edge_index[1]].tolist()
        if self.edge_attr:
            names = list(self.edge_attr)
            rows = zip(*(self.edge_attr[k].tolist() for k in names))
            H.add_edges_from(zip(src, dst, (dict(zip(names, r)) for r in rows)))
        else:
            H.add_edges_from(zip(src, dst))
        return H

    @property
    def node_array(self) -> np.ndarray:
        """Labels as an array ``[N]`` for fancy indexing (int64 for int labels, else object)."""
        if self._node_array is None:
            ints = _int_labels(list(self.nodes))
            arr = ints if ints is not None else np.fromiter(self.nodes, object, self.num_nodes)
            arr.setflags(write=False)
            self._node_array = arr
        return self._node_array

    @property
    def index(self) -> dict[Any, int]:
        """Label -> position (built on first use, O(N))."""
        if self._index is None:
            self._index = dict(zip(self.nodes, range(self.num_nodes)))
        return self._index

    def labels_of(self, positions: np.ndarray) -> list[Any]:
        """Node labels (Python objects, never numpy scalars) at ``positions``."""
        out: list[Any] = self.node_array[positions].tolist()
        return out

    # The few networkx.Graph methods networkx's decorators call on a backend graph.
    def is_directed(self) -> bool:
        return False

    def is_multigraph(self) -> bool:
        return False

    def number_of_nodes(self) -> int:
        return self.num_nodes

    def number_of_edges(self) -> int:
        """Columns of ``edge_index`` (duplicates counted)."""
        return int(self.edge_index.shape[1])

    def __len__(self) -> int:
        return self.num_nodes

    def __iter__(self) -> Iterator[Any]:
        return iter(self.nodes)

    def __contains__(self, node: object) -> bool:
        try:
            return node in self.index
        except TypeError:
            return False

    def __repr__(self) -> str:
        return f"EdgeIndexGraph(num_nodes={self.num_nodes}, num_edges={self.number_of_edges()})"


def as_backend_graph(G: Any, *, edge_attrs: Mapping[Hashable, Any] | None = None) -> EdgeIndexGraph:
    """Return ``G`` if it already is an :class:`EdgeIndexGraph`, else convert it.

    Examples
    --------
    >>> import networkx as nx
    >>> g = as_backend_graph(nx.empty_graph(2))
    >>> as_backend_graph(g) is g
    True
    """
    if isinstance(G, EdgeIndexGraph):
        return G
    import networkx as nx

    if not isinstance(G, nx.Graph):
        raise TypeError(f"expected a networkx graph or an EdgeIndexGraph (got {type(G).__name__})")
    return EdgeIndexGraph.from_networkx(G, edge_attrs=edge_attrs)
