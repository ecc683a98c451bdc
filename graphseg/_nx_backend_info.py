"""What the graphseg networkx backend declares (entry point ``networkx.backend_info``).

networkx calls :func:`get_info` while ``import networkx`` is still running (right after
``networkx.utils``), so this module imports nothing but the standard library: no numpy,
no networkx and no other graphseg module.

Examples
--------
>>> info = get_info()
>>> info["backend_name"], sorted(info["functions"])[:2]
('graphseg', ['connected_components', 'is_connected'])
>>> info["default_config"] == {"contractor": default_contractor()}
True
"""

from __future__ import annotations

import os
from typing import Any

__all__ = ["get_info", "default_contractor", "DEFAULT_CONTRACTOR", "CONTRACTOR_ENV", "FUNCTIONS"]

#: The fastest correct contractor measured by ``benchmarks/bench_nx_backend.py``.
DEFAULT_CONTRACTOR = "scipy"

#: Environment variable that overrides the default of ``nx.config.backends.graphseg.contractor``.
CONTRACTOR_ENV = "GRAPHSEG_NX_CONTRACTOR"

_CONTRACTOR_PARAM = {
    "contractor : str, optional": (
        "A plain graphseg contractor (``scipy``, ``star``, ``union_find`` or a registered "
        "plugin). Default: ``nx.config.backends.graphseg.contractor``."
    ),
}

_COMPONENTS_DOCS = (
    "Runs a graphseg contractor on the graph's ``edge_index`` (int64 ``[2, E]``): one "
    "array pass, no Python loop over nodes. Multi-edges and self-loops are accepted."
)

#: The networkx functions the backend implements, with the docs networkx appends to theirs.
FUNCTIONS: dict[str, dict[str, Any]] = {
    "connected_components": {"additional_docs": _COMPONENTS_DOCS, "additional_parameters": _CONTRACTOR_PARAM},
    "number_connected_components": {"additional_docs": _COMPONENTS_DOCS, "additional_parameters": _CONTRACTOR_PARAM},
    "node_connected_component": {"additional_docs": _COMPONENTS_DOCS, "additional_parameters": _CONTRACTOR_PARAM},
    "is_connected": {"additional_docs": _COMPONENTS_DOCS, "additional_parameters": _CONTRACTOR_PARAM},
    "quotient_graph": {
        "additional_docs": (
            "Block adjacency, edge weights and per-block edge counts come from one "
            "sort-and-reduce over ``edge_index`` (O(N + E log E)) instead of testing every "
            "pair of blocks. Undirected simple graphs, a collection of blocks (or a dict), "
            "and the default ``edge_relation`` only; other calls go to networkx."
        ),
    },
}


def default_contractor() -> str:
    """The contractor used when ``nx.config.backends.graphseg.contractor`` is not set.

    Examples
    --------
    >>> isinstance(default_contractor(), str)
    True
    """
    return os.environ.get(CONTRACTOR_ENV) or DEFAULT_CONTRACTOR


def get_info() -> dict[str, Any]:
    """The ``backend_info`` dict networkx reads: name, summary, functions, default config.

    Returns
    -------
    dict
        Keys ``backend_name``, ``project``, ``package``, ``short_summary``,
        ``functions`` (name -> docs) and ``default_config`` (``contractor``).

    Examples
    --------
    >>> get_info()["package"]
    'graphseg'
    """
    return {
        "backend_name": "graphseg",
        "project": "graphseg",
        "package": "graphseg",
        "short_summary": "Array-first connected components and quotient graphs on graphseg's contractors.",
        "functions": {name: dict(entry) for name, entry in FUNCTIONS.items()},
        "default_config": {"contractor": default_contractor()},
    }
