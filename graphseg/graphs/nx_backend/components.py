"""Connected components for networkx, computed by graphseg's contractors.

Each function takes an :class:`~graphseg.graphs.nx_backend.graph.EdgeIndexGraph`
(or a networkx graph, converted first), runs one contractor on its ``edge_index``
to get the cluster vector (node -> component id, numbered in order of first
appearance over the nodes), and maps the ids back to node labels. Because the ids
follow node order, components come out in networkx's own order: the component of
the first node first.

The contractor is ``nx.config.backends.graphseg.contractor`` unless a call passes
``contractor=`` (a name of :data:`graphseg.graphs.contractors`, a class or an
instance). Only plain contractors qualify; signed ones (``uses_edge_attr``) need
edge signs a networkx graph does not have.

Examples
--------
>>> import networkx as nx
>>> G = nx.Graph([(0, 1), (2, 3)])
>>> G.add_node("solo")
>>> list(connected_components(G))
[{0, 1}, {2, 3}, {'solo'}]
>>> number_connected_components(G, contractor="star"), is_connected(G)
(3, False)
>>> sorted(node_connected_component(G, 3))
[2, 3]
"""

from __future__ import annotations

from collections.abc import Hashable, Iterator
from typing import Any

import numpy as np

from ..._nx_backend_info import default_contractor
from .graph import BACKEND_NAME, EdgeIndexGraph, as_backend_graph

__all__ = [
    "connected_components",
    "number_connected_components",
    "node_connected_component",
    "is_connected",
    "component_labels",
    "resolve_contractor",
    "configured_contractor",
]


def configured_contractor() -> str:
    """``nx.config.backends.graphseg.contractor``, or the default when networkx has no graphseg config.

    Examples
    --------
    >>> isinstance(configured_contractor(), str)
    True
    """
    import networkx as nx

    cfg = nx.config.backends.get(BACKEND_NAME) if BACKEND_NAME in nx.config.backends else None
    name = getattr(cfg, "contractor", None) if cfg is not None else None
    return name or default_contractor()


def resolve_contractor(contractor: Any = None) -> Any:
    """A plain contractor instance from a name, class or instance (None: the configured one).

    Raises
    ------
    graphseg.registry.PluginNotFoundError
        For an unknown name (the message lists the installed ones).
    ValueError
        For a signed contractor (``uses_edge_attr = True``).

    Examples
    --------
    >>> type(resolve_contractor("star")).__name__
    'StarContraction'
    >>> resolve_contractor("gaec")
    Traceback (most recent call last):
    ...
    ValueError: contractor 'gaec' reads signed edge attributes; connected components need a plain contractor such as 'scipy', 'star' or 'union_find'
    """
    from ..registry import contractors

    spec = configured_contractor() if contractor is None else contractor
    instance = contractors.resolve(spec)
    if getattr(instance, "uses_edge_attr", False):
        name = spec if isinstance(spec, str) else getattr(instance, "name", type(instance).__name__)
        raise ValueError(
            f"contractor {name!r} reads signed edge attributes; connected components need a plain "
            "contractor such as 'scipy', 'star' or 'union_find'"
        )
    return instance


def component_labels(G: Any, *, contractor: Any = None) -> np.ndarray:
    """Component id of every node position: the contractor's cluster vector.

    Parameters
    ----------
    G : EdgeIndexGraph or networkx.Graph
    contractor : str, class or instance, optional
        Default: :func:`configured_contractor`.

    Returns
    -------
    numpy.ndarray
        int64 ``[N]``, ids ``0..k-1`` in order of first appearance over the nodes.

    Notes
    -----
    The cost of the contractor: O(N + E) for ``scipy``, O((N + E) log N)
    expected for ``star``, O((N + E) alpha(N)) in Python for ``union_find``.

    Examples
    --------
    >>> component_labels(EdgeIndexGraph([[0], [2]], 3)).tolist()
    [0, 1, 0]
    """
    g = as_backend_graph(G)
    run = resolve_contractor(contractor)
    # rng only steers the star contractor's random labels; the components do not depend on it.
    cluster = np.asarray(run(g.edge_index, g.num_nodes, rng=0), dtype=np.int64)
    if cluster.shape != (g.num_nodes,):
        raise ValueError(f"contractor returned a cluster of shape {list(cluster.shape)} for {g.num_nodes} nodes")
    return cluster


def _iter_components(g: EdgeIndexGraph, cluster: np.ndarray) -> Iterator[set[Any]]:
    if cluster.size == 0:
        return
    order = np.argsort(cluster, kind="stable")
    ends = np.cumsum(np.bincount(cluster)).tolist()
    labels = g.labels_of(order)
    start = 0
    for end in ends:  # one step per component; set() over a list slice runs in C
        yield set(labels[start:end])
        start = end


def connected_components(G: Any, *, contractor: Any = None) -> Iterator[set[Any]]:
    """Generate the connected components of an undirected graph, as sets of nodes.

    Parameters
    ----------
    G : EdgeIndexGraph or networkx.Graph
        Undirected (networkx rejects directed graphs before dispatching).
    contractor : str, class or instance, optional
        Default: ``nx.config.backends.graphseg.contractor``.

    Returns
    -------
    generator of set
        One new set per component, in networkx's order (the component of the
        first node first).

    Notes
    -----
    The contractor runs when this function is called; the generator only
    slices a node list sorted by component, one ``set`` per component.

    Examples
    --------
    >>> [sorted(c) for c in connected_components(EdgeIndexGraph([[1], [2]], 4))]
    [[0], [1, 2], [3]]
    """
    g = as_backend_graph(G)
    return _iter_components(g, component_labels(g, contractor=contractor))


def number_connected_components(G: Any, *, contractor: Any = None) -> int:
    """Number of connected components.

    Examples
    --------
    >>> number_connected_components(EdgeIndexGraph([[1], [2]], 4))
    3
    >>> number_connected_components(EdgeIndexGraph([[], []], 0))
    0
    """
    g = as_backend_graph(G)
    if g.num_nodes == 0:
        return 0
    return int(component_labels(g, contractor=contractor).max()) + 1


def is_connected(G: Any, *, contractor: Any = None) -> bool:
    """True when the graph has exactly one connected component.

    Raises
    ------
    networkx.NetworkXPointlessConcept
        For the null graph, as networkx does.

    Notes
    -----
    A graph with fewer than ``N - 1`` edge columns is disconnected without
    running the contractor.

    Examples
    --------
    >>> is_connected(EdgeIndexGraph([[0, 1], [1, 2]], 3)), is_connected(EdgeIndexGraph([[0], [1]], 3))
    (True, False)
    """
    g = as_backend_graph(G)
    if g.num_nodes == 0:
        import networkx as nx

        raise nx.NetworkXPointlessConcept("Connectivity is undefined for the null graph.")
    if g.number_of_edges() < g.num_nodes - 1:
        return False
    return bool(component_labels(g, contractor=contractor).max() == 0)


def node_connected_component(G: Any, n: Hashable, *, contractor: Any = None) -> set[Any]:
    """The set of nodes in the component of node ``n``.

    Raises
    ------
    KeyError
        If ``n`` is not a node, as networkx does.

    Examples
    --------
    >>> sorted(node_connected_component(EdgeIndexGraph([[1], [2]], 4, nodes="abcd"), "c"))
    ['b', 'c']
    """
    g = as_backend_graph(G)
    i = g.index[n]
    cluster = component_labels(g, contractor=contractor)
    return set(g.labels_of(np.flatnonzero(cluster == cluster[i])))
