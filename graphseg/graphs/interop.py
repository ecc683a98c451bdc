"""Views of a :class:`CorrespondenceGraph` in other libraries' formats.

* NetworkX: :func:`to_networkx` / :func:`from_networkx` (a ``MultiGraph``, since
  two criteria may join the same pair of masks).
* GraphML: :func:`write_graphml` / :func:`read_graphml` through networkx. GraphML
  holds scalars only, so vector columns are flattened (``bbox`` ->
  ``bbox_0..bbox_3``) and a JSON schema in the graph attributes restores names,
  dtypes and shapes: lossless for every scalar attribute. An edge has no
  ``<data>`` for a numeric attribute it has no value for (NaN / -1 in memory).
  Masks are not part of GraphML; use :mod:`graphseg.graphs.native` for them.
* PyG: :func:`to_pyg` / :func:`from_pyg`.

Examples
--------
>>> import numpy as np
>>> from graphseg.graphs import CorrespondenceGraph
>>> g = CorrespondenceGraph(2, edge_index=[[0], [1]],
...     edge_attr={"criterion": np.array(["dino"]), "weight": [0.9]},
...     node_attr={"bbox": np.array([[0, 0, 3, 3], [1, 1, 2, 2]])})
>>> nxg = to_networkx(g)
>>> nxg.nodes[1]["bbox_2"], list(nxg.edges(data="criterion"))
(2, [(0, 1, 'dino')])
>>> back = from_networkx(nxg)
>>> np.array_equal(back.node_attr["bbox"], g.node_attr["bbox"])
True
"""

from __future__ import annotations

import json
from os import PathLike
from typing import Any

import numpy as np

from ..registry import require
from .graph import CorrespondenceGraph, GraphValidationError

__all__ = ["to_networkx", "from_networkx", "write_graphml", "read_graphml", "to_pyg", "from_pyg"]

_SCHEMA = "graphseg_schema"


def _col_schema(cols: dict[str, np.ndarray]) -> dict[str, Any]:
    return {k: {"dtype": v.dtype.str if v.dtype.kind != "O" else "<U0", "shape": list(v.shape[1:])} for k, v in cols.items()}


def _flatten(cols: dict[str, np.ndarray], n: int) -> dict[str, list[Any]]:
    out: dict[str, list[Any]] = {}
    for name, col in cols.items():
        if col.dtype.kind == "O":
            col = col.astype(str)
        if col.ndim == 1:
            out[name] = col.tolist()
        else:
            flat = col.reshape(n, int(np.prod(col.shape[1:], dtype=np.int64)))
            for j in range(flat.shape[1]):
                out[f"{name}_{j}"] = flat[:, j].tolist()
    return out


#: Most values a GraphML schema may declare per file byte (each value needs several bytes of XML).
_MAX_VALUES_PER_BYTE = 1


def _unflatten(rows: list[dict[str, Any]], schema: dict[str, Any], limit: int | None = None) -> dict[str, np.ndarray]:
    """Columns from flat rows; ``limit`` caps the total number of values declared (checked before allocating)."""
    n = len(rows)
    out: dict[str, np.ndarray] = {}
    if not isinstance(schema, dict):
        raise GraphValidationError(f"expected a column schema object (got {type(schema).__name__})")
    total = 0
    for name, spec in schema.items():
        try:
            dtype = np.dtype(spec["dtype"])
            shape = tuple(int(x) for x in spec["shape"])
        except (KeyError, TypeError, ValueError) as err:
            raise GraphValidationError(f"{_SCHEMA}: column {name!r}: expected {{'dtype': str, 'shape': [int, ...]}} ({err})") from err
        if dtype.hasobject or any(x < 0 for x in shape) or len(shape) > 8:
            raise GraphValidationError(f"{_SCHEMA}: column {name!r}: invalid dtype or shape ({dtype}, {list(shape)})")
        width = int(np.prod(shape, dtype=object)) if shape else 1
        total += n * width
        if limit is not None and total > limit:
            raise GraphValidationError(f"{_SCHEMA}: column {name!r}: declares {n} x {list(shape)} values, more than the file can hold")
        if dtype.kind == "U":
            vals = [str(r.get(name, "")) for r in rows]
            out[name] = np.array(vals, dtype=str) if n else np.zeros(0, dtype="<U1")
            continue
        if not shape:
            vals = [r.get(name, np.nan if dtype.kind == "f" else -1) for r in rows]
            out[name] = np.array(vals, dtype=dtype).reshape(n)
        else:
            arr = np.array(
                [[r.get(f"{name}_{j}", np.nan if dtype.kind == "f" else -1) for j in range(width)] for r in rows],
                dtype=dtype,
            ).reshape((n,) + shape)
            out[name] = arr
    return out


def _missing_tests(cols: dict[str, np.ndarray]) -> dict[str, Any]:
    """Per flattened column name, the test for "this edge has no value" (:func:`graphseg.graphs.graph.fill_value`).

    NaN in float columns and -1 in signed integer columns are what a graph
    stores for an edge that lacks the column (a Chamfer edge has no pixel
    ``count``); :func:`_unflatten` restores exactly these values for an
    absent key, so leaving them out is lossless.
    """
    tests: dict[str, Any] = {}
    for name, col in cols.items():
        if col.dtype.kind == "f":
            test: Any = _is_nan
        elif col.dtype.kind == "i":
            test = _is_minus_one
        else:
            continue
        width = int(np.prod(col.shape[1:], dtype=np.int64))
        for key in [name] if col.ndim == 1 else [f"{name}_{j}" for j in range(width)]:
            tests[key] = test
    return tests


def _is_nan(x: Any) -> bool:
    return bool(x != x)


def _is_minus_one(x: Any) -> bool:
    return bool(x == -1)


def to_networkx(graph: CorrespondenceGraph, *, omit_missing: bool = False) -> Any:
    """A ``networkx.MultiGraph`` with scalar node/edge attributes.

    Nodes are ``0..N-1``; edge keys are the edge positions ``0..E-1`` and the
    edge attribute ``graphseg_src`` keeps each edge's stored orientation. Vector
    columns are flattened to ``name_j``; the graph attribute ``graphseg_schema``
    (JSON) records names, dtypes, shapes, ``level``, ``meta`` and ``members``.

    With ``omit_missing`` an edge lacks the attributes it has no value for
    (NaN in a float column, -1 in an integer column: the placeholders a graph
    stores when edges of different criteria are joined, like ``count`` and
    ``ratio`` of a Chamfer edge or ``multiplicity`` of an edge added after a
    contraction); :func:`from_networkx` restores the placeholders.

    Notes
    -----
    O(N + E) Python objects.
    """
    import networkx as nx

    graph.validate()
    g = nx.MultiGraph()
    schema = {
        "level": graph.level,
        "num_nodes": graph.num_nodes,
        "node": _col_schema(graph.node_attr),
        "edge": _col_schema(graph.edge_attr),
        "meta": graph.meta,
    }
    if graph._members is not None:
        schema["members"] = {k: v.tolist() for k, v in graph._members.items()}
    g.graph[_SCHEMA] = json.dumps(schema)
    ncols = _flatten(graph.node_attr, graph.num_nodes)
    for i in range(graph.num_nodes):
        g.add_node(i, **{k: v[i] for k, v in ncols.items()})
    ecols = _flatten(graph.edge_attr, graph.num_edges)
    missing = _missing_tests(graph.edge_attr) if omit_missing else {}
    src, dst = graph.edge_index.tolist()
    for e in range(graph.num_edges):
        attrs = {k: v[e] for k, v in ecols.items() if k not in missing or not missing[k](v[e])}
        g.add_edge(src[e], dst[e], key=e, graphseg_src=src[e], **attrs)
    return g


def from_networkx(g: Any, *, limit: int | None = 10**9) -> CorrespondenceGraph:
    """Inverse of :func:`to_networkx`; also accepts plain networkx graphs.

    Without a ``graphseg_schema`` attribute, nodes are relabelled ``0..N-1`` in
    iteration order and every attribute present on all nodes/edges becomes a
    column.
    """
    raw = g.graph.get(_SCHEMA)
    nodes = list(g.nodes)
    index = {u: i for i, u in enumerate(nodes)}
    if g.is_multigraph():
        edges = sorted(g.edges(keys=True, data=True), key=lambda t: (t[2] if isinstance(t[2], int) else 0))
        edge_rows = [(u, v, d) for u, v, _, d in edges]
    else:
        edge_rows = list(g.edges(data=True))
    node_rows = [dict(g.nodes[u]) for u in nodes]
    erows = [d for _, _, d in edge_rows]
    schema: dict[str, Any]
    if raw is None:
        def infer(rows: list[dict[str, Any]]) -> dict[str, Any]:
            common = set.intersection(*(set(r) for r in rows)) if rows else set()
            return {k: {"dtype": np.asarray([r[k] for r in rows]).dtype.str, "shape": []} for k in sorted(common)}

        schema = {"level": "mask", "node": infer(node_rows), "edge": infer(erows), "meta": {}}
    else:
        try:
            schema = json.loads(raw)
        except (ValueError, RecursionError) as err:
            raise GraphValidationError(f"{_SCHEMA}: invalid JSON ({err})") from err
        if not isinstance(schema, dict) or not isinstance(schema.get("node", {}), dict) or not isinstance(schema.get("edge", {}), dict):
            raise GraphValidationError(f"{_SCHEMA}: expected an object with 'node' and 'edge' column schemas")
    # undirected views lose the stored orientation; graphseg_src restores it
    oriented = [(v, u) if d.get("graphseg_src", u) != u else (u, v) for u, v, d in edge_rows]
    ei = np.array([[index[u] for u, _ in oriented], [index[v] for _, v in oriented]], dtype=np.int64).reshape(2, -1)
    members = schema.get("members")
    out = CorrespondenceGraph(
        len(nodes),
        ei,
        _unflatten(erows, schema.get("edge", {}), limit),
        _unflatten(node_rows, schema.get("node", {}), limit),
        members=None if members is None else {k: np.asarray(v, np.int64) for k, v in members.items()},
        level=schema.get("level", "mask"),
        meta=schema.get("meta", {}),
    )
    out.validate()
    return out


def write_graphml(graph: CorrespondenceGraph, path: str | PathLike[str]) -> None:
    """Write ``graph`` as GraphML (through networkx).

    An edge carries no ``<data>`` for an attribute it has no value for (see
    ``omit_missing`` in :func:`to_networkx`): a Chamfer edge has no ``count``
    or ``ratio``, an edge added after a contraction no ``multiplicity``.
    :func:`read_graphml` restores the in-memory placeholders (NaN, -1).

    Examples
    --------
    >>> import tempfile, os
    >>> from graphseg.graphs import CorrespondenceGraph
    >>> g = CorrespondenceGraph(2, edge_index=[[0], [1]], edge_attr={"weight": [0.25]})
    >>> with tempfile.TemporaryDirectory() as d:
    ...     write_graphml(g, os.path.join(d, "g.graphml"))
    ...     read_graphml(os.path.join(d, "g.graphml")).edge_attr["weight"].tolist()
    [0.25]
    """
    import networkx as nx

    nx.write_graphml(to_networkx(graph, omit_missing=True), str(path))


def read_graphml(path: str | PathLike[str]) -> CorrespondenceGraph:
    """Read a GraphML file written by :func:`write_graphml` (or any GraphML)."""
    import os
    import xml.etree.ElementTree as ET

    import networkx as nx

    size = os.path.getsize(path)
    try:
        g = nx.read_graphml(str(path), node_type=int, force_multigraph=True)
    except (ET.ParseError, nx.NetworkXError, ValueError, KeyError, TypeError) as err:
        raise GraphValidationError(f"{path}: graphml: cannot read ({(str(err) or type(err).__name__).splitlines()[0]})") from err
    # GraphML edge ids come back as str keys; restore integer order
    h = nx.MultiGraph()
    h.graph.update(g.graph)
    h.add_nodes_from(sorted(g.nodes(data=True), key=lambda t: t[0]))
    for u, v, k, d in g.edges(keys=True, data=True):
        try:
            key = int(k)
        except (TypeError, ValueError):
            key = k
        h.add_edge(u, v, key=key, **d)
    try:
        return from_networkx(h, limit=max(size * _MAX_VALUES_PER_BYTE, 1000))
    except GraphValidationError as err:
        raise GraphValidationError(f"{path}: {err}") from err
    except (KeyError, ValueError, TypeError, IndexError) as err:
        raise GraphValidationError(f"{path}: graphml: malformed ({type(err).__name__}: {(str(err) or '').splitlines()[0] if str(err) else ''})") from err


def to_pyg(graph: CorrespondenceGraph) -> Any:
    """PyG-style tensors: a ``torch_geometric.data.Data`` if PyG is installed, else a dict.

    Keys: ``edge_index`` (int64 ``[2, E]``), ``num_nodes``, every node column
    under its own name, every edge column as ``edge_<name>`` (str columns as
    Python lists), ``edge_attr`` (float32 ``[E, F]`` of the numeric edge
    columns) with ``edge_attr_names``.

    Raises
    ------
    MissingDependencyError
        Without torch; the message gives :data:`graphseg.registry.TORCH_CPU` (torch's CPU build).
    """
    torch = require("torch", "torch")
    graph.validate()
    out: dict[str, Any] = {"edge_index": torch.from_numpy(graph.edge_index.copy()), "num_nodes": graph.num_nodes}
    for name, col in graph.node_attr.items():
        out[name] = list(col.astype(str)) if col.dtype.kind in "UO" else torch.from_numpy(np.ascontiguousarray(col))
    numeric = []
    for name, col in graph.edge_attr.items():
        if col.dtype.kind in "UO":
            out[f"edge_{name}"] = [str(x) for x in col]
        else:
            out[f"edge_{name}"] = torch.from_numpy(np.ascontiguousarray(col))
            if col.ndim == 1:
                numeric.append(name)
    out["edge_attr"] = (
        torch.from_numpy(np.stack([graph.edge_attr[n].astype(np.float32) for n in numeric], 1))
        if numeric
        else torch.zeros((graph.num_edges, 0))
    )
    out["edge_attr_names"] = numeric
    out["level"] = graph.level
    try:
        from torch_geometric.data import Data
    except ImportError:
        return out
    return Data(**out)


def from_pyg(data: Any) -> CorrespondenceGraph:
    """Inverse of :func:`to_pyg` (accepts the ``Data`` or the dict form)."""
    items = dict(data.to_dict()) if hasattr(data, "to_dict") else dict(data)
    if "edge_index" not in items:
        raise GraphValidationError("expected a PyG object with an 'edge_index' entry")
    ei = np.asarray(items.pop("edge_index").cpu().numpy() if hasattr(items["edge_index"], "cpu") else items.pop("edge_index"))
    num_nodes = int(items.pop("num_nodes"))
    level = items.pop("level", "mask")
    items.pop("edge_attr", None)
    items.pop("edge_attr_names", None)
    node_attr, edge_attr = {}, {}
    for key, val in items.items():
        arr = val.cpu().numpy() if hasattr(val, "cpu") else np.asarray(val, dtype=str if isinstance(val, list) else None)
        if key.startswith("edge_"):
            edge_attr[key[5:]] = arr
        else:
            node_attr[key] = arr
    g = CorrespondenceGraph(num_nodes, ei, edge_attr, node_attr, level=level)
    g.validate()
    return g
