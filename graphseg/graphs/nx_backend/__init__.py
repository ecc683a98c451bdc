"""graphseg as a networkx backend: ``nx.connected_components(G, backend="graphseg")``.

Registered under the ``networkx.backends`` entry point as ``graphseg`` (the object
:class:`~graphseg.graphs.nx_backend.interface.BackendInterface`), with
``networkx.backend_info`` pointing at :func:`graphseg._nx_backend_info.get_info` (kept
outside ``graphseg.graphs`` so that networkx's own import stays cheap).

Implemented: ``connected_components``, ``number_connected_components``,
``node_connected_component``, ``is_connected`` (on graphseg's contractors) and
``quotient_graph`` (undirected simple graphs, default edge relation). Choose the
contractor with ``nx.config.backends.graphseg.contractor = "star"`` (or per call,
``contractor="star"``); the default is the fastest measured one, ``scipy``.

Modules: ``graph`` (the backend graph type and conversion), ``components``,
``quotient`` and ``interface`` (the object networkx loads); the metadata networkx
reads at import lives in the dependency-free :mod:`graphseg._nx_backend_info`. This
package imports none of them eagerly.

Examples
--------
>>> import networkx as nx
>>> G = nx.Graph([("a", "b"), ("c", "d")])
>>> [sorted(c) for c in nx.connected_components(G, backend="graphseg")]
[['a', 'b'], ['c', 'd']]
>>> from graphseg.graphs.nx_backend import EdgeIndexGraph
>>> nx.is_connected(EdgeIndexGraph([[0, 1], [1, 2]], 3))  # a backend graph dispatches by itself
True
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = [
    "EdgeIndexGraph",
    "BackendInterface",
    "connected_components",
    "number_connected_components",
    "node_connected_component",
    "is_connected",
    "quotient_graph",
    "component_labels",
]

_HOMES = {
    "EdgeIndexGraph": "graph",
    "BackendInterface": "interface",
    "connected_components": "components",
    "number_connected_components": "components",
    "node_connected_component": "components",
    "is_connected": "components",
    "component_labels": "components",
    "quotient_graph": "quotient",
}


def __getattr__(name: str) -> Any:
    if name in _HOMES:
        return getattr(importlib.import_module(f"{__name__}.{_HOMES[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
