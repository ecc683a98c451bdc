"""The object networkx loads for ``backend="graphseg"`` (entry point ``networkx.backends``).

networkx looks up, on :class:`BackendInterface`:

* one attribute per implemented function (``connected_components``, ...);
* ``convert_from_nx`` / ``convert_to_nx``: to and from
  :class:`~graphseg.graphs.nx_backend.graph.EdgeIndexGraph`;
* ``can_run(name, args, kwargs)``: True, or a string saying why these arguments are
  not supported (networkx then falls back to its own code when
  ``nx.config.fallback_to_nx`` is set, or reports the reason);
* ``should_run(name, args, kwargs)``: whether automatic dispatch
  (``nx.config.backend_priority``) should pick graphseg; graphs below
  :data:`SHOULD_RUN_MIN_NODES` nodes stay with networkx, where conversion would cost
  more than it saves;
* ``on_start_tests(items)``: called by networkx's conftest when its test suite runs
  against this backend (``NETWORKX_TEST_BACKEND=graphseg``); marks the tests that
  check networkx-internal behaviour this backend does not reproduce.

Examples
--------
>>> import networkx as nx
>>> G = nx.Graph([(0, 1), (2, 3)])
>>> g = BackendInterface.convert_from_nx(G)
>>> [sorted(c) for c in BackendInterface.connected_components(g)]
[[0, 1], [2, 3]]
>>> BackendInterface.can_run("quotient_graph", (nx.MultiGraph(), [{0}]), {})
'multigraphs: their quotient keeps one edge per original edge with its data; networkx runs it'
"""

from __future__ import annotations

from collections.abc import Hashable, Mapping, Sequence
from typing import Any

from . import components, quotient
from .graph import EdgeIndexGraph

__all__ = ["BackendInterface", "SHOULD_RUN_MIN_NODES", "KNOWN_NX_TEST_FAILURES"]

#: Smallest graph automatic dispatch sends to graphseg: converting and running (cache off) beat
#: networkx's connected_components from 1e4 nodes (1.1-1.2x) and lost at 3e3 (0.5x) on the
#: random graphs of benchmarks/bench_nx_backend.py (2-core CPU machine).
SHOULD_RUN_MIN_NODES = 10_000

#: networkx tests (module file name, test name) -> why they fail against this backend.
KNOWN_NX_TEST_FAILURES: dict[tuple[str, str], str] = {}


class BackendInterface:
    """The graphseg networkx backend: functions, conversions and dispatch hooks.

    Examples
    --------
    >>> import networkx as nx
    >>> nx.number_connected_components(nx.path_graph(3), backend="graphseg")
    1
    """

    connected_components = staticmethod(components.connected_components)
    number_connected_components = staticmethod(components.number_connected_components)
    node_connected_component = staticmethod(components.node_connected_component)
    is_connected = staticmethod(components.is_connected)
    quotient_graph = staticmethod(quotient.quotient_graph)

    @staticmethod
    def convert_from_nx(
        graph: Any,
        *,
        edge_attrs: Mapping[Hashable, Any] | None = None,
        node_attrs: Mapping[Hashable, Any] | None = None,
        preserve_edge_attrs: bool = False,
        preserve_node_attrs: bool = False,
        preserve_graph_attrs: bool = False,
        name: str | None = None,
        graph_name: str | None = None,
    ) -> EdgeIndexGraph:
        """Convert a networkx graph for the call ``name``.

        Only the edge attributes networkx asks for by name (``edge_attrs``) are
        read; node attributes and "preserve all" requests are not needed by any
        implemented function, and the source graph stays reachable as
        ``EdgeIndexGraph.source``.

        Raises
        ------
        NotImplementedError
            For a directed graph (networkx then falls back or reports it).
        TypeError
            For anything that is not a networkx graph.
        """
        if isinstance(graph, EdgeIndexGraph):
            return graph
        import networkx as nx

        if not isinstance(graph, nx.Graph):
            raise TypeError(f"argument {graph_name!r} of {name}: expected a networkx graph (got {type(graph).__name__})")
        return EdgeIndexGraph.from_networkx(graph, edge_attrs=edge_attrs, graph_attrs=bool(preserve_graph_attrs))

    @staticmethod
    def convert_to_nx(obj: Any, *, name: str | None = None) -> Any:
        """An ``EdgeIndexGraph`` becomes a ``networkx.Graph``; any other result is returned as is."""
        if isinstance(obj, EdgeIndexGraph):
            return obj.to_networkx()
        return obj

    @staticmethod
    def can_run(name: str, args: Sequence[Any], kwargs: Mapping[str, Any]) -> bool | str:
        """True, or why graphseg cannot run ``name`` with these arguments."""
        if name == "quotient_graph":
            reason = quotient.unsupported(*args, **kwargs)
            return True if reason is None else reason
        if name in ("connected_components", "number_connected_components", "node_connected_component", "is_connected"):
            graph = args[0] if args else kwargs.get("G")
            if graph is not None and graph.is_directed():
                return "directed graphs: networkx defines these functions for undirected graphs only"
            return True
        return f"graphseg does not implement {name}"

    @staticmethod
    def should_run(name: str, args: Sequence[Any], kwargs: Mapping[str, Any]) -> bool | str:
        """Whether automatic dispatch should use graphseg (large enough graphs only)."""
        graph = args[0] if args else kwargs.get("G")
        if graph is not None and not isinstance(graph, EdgeIndexGraph) and len(graph) < SHOULD_RUN_MIN_NODES:
            return f"graphs below {SHOULD_RUN_MIN_NODES} nodes are faster in networkx than converted"
        return True

    @staticmethod
    def on_start_tests(items: Sequence[Any]) -> None:
        """Mark networkx tests this backend is known to fail (networkx's conftest calls this)."""
        if not KNOWN_NX_TEST_FAILURES:
            return
        import pytest

        for item in items:
            key = (item.path.name, item.name)
            if key in KNOWN_NX_TEST_FAILURES:
                item.add_marker(pytest.mark.xfail(reason=KNOWN_NX_TEST_FAILURES[key], strict=True))
