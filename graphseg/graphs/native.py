"""The native graph file: one compressed ``.npz`` with a JSON header.

The file holds one or more named graphs with every column, their masks (label
images, stored once when graphs share them), extra named arrays, and JSON
metadata, so a saved graph can be reopened and contracted again without
re-running any backend. No pickle is used: string columns are stored as numpy
unicode arrays.

Layout of the keys inside the ``.npz``:

``__header__``
    uint8 bytes of a UTF-8 JSON object: ``{"format": "graphseg-graph",
    "version": 1, "graphs": {name: {...}}, "meta": {...}}``.
``G/edge_index``, ``G/edge/<col>``, ``G/node/<col>``, ``G/members/<col>``
    The arrays of graph ``G``.
``masks/<set>/<view>``
    Label images of mask set ``<set>``.
``arrays/<name>``
    Extra arrays.

Examples
--------
>>> import tempfile, os
>>> import numpy as np
>>> from graphseg.graphs import CorrespondenceGraph
>>> g = CorrespondenceGraph.from_masks([np.array([[1, 1], [0, 2]])])
>>> g = g.add_edges([[0], [1]], {"criterion": ["pixel_match"], "weight": [0.5]})
>>> with tempfile.TemporaryDirectory() as d:
...     save_graph(os.path.join(d, "g.npz"), g)
...     h = load_graph(os.path.join(d, "g.npz"))
>>> h.edge_attr["criterion"].tolist(), h.masks[0].tolist()
(['pixel_match'], [[1, 1], [0, 2]])
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from os import PathLike
from typing import Any

import numpy as np

from ..io.files import (
    BOMB_MIN_BYTES,
    BOMB_RATIO,
    DAMAGE,
    MAX_ARRAY_BYTES,
    NpzFile,
    bomb_limit,
    describe,
    npz_headers,
)
from .graph import CorrespondenceGraph, GraphValidationError

__all__ = ["save_graph", "load_graph", "save_native", "load_native", "check_npz_sizes", "bomb_limit", "NativeFile", "FORMAT", "VERSION", "MAX_ARRAY_BYTES", "BOMB_RATIO", "BOMB_MIN_BYTES"]

FORMAT = "graphseg-graph"
VERSION = 1


def check_npz_sizes(path: str | PathLike[str], *, limit: int | None = None) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
    """Shapes and dtypes of the arrays of an ``.npz``, read from their headers (nothing loaded).

    :func:`graphseg.io.files.npz_headers`: declared sizes are checked against
    the uncompressed size, the compressed size (deflate's maximum ratio) and
    ``limit`` (default :data:`MAX_ARRAY_BYTES` or ``$GRAPHSEG_MAX_ARRAY_BYTES``)
    before anything is allocated; an entry larger than :func:`bomb_limit` that
    is compressed :data:`BOMB_RATIO`:1 or better (a zip bomb: gigabytes of
    zeros in a few megabytes) is refused before it is decompressed.

    Returns
    -------
    dict
        Array name -> ``(shape, dtype)``.

    Raises
    ------
    GraphValidationError
        Naming the file and the array that is damaged, tampered or too large.

    Examples
    --------
    >>> import tempfile, os
    >>> with tempfile.TemporaryDirectory() as d:
    ...     np.savez_compressed(os.path.join(d, "a.npz"), x=np.zeros((2, 3)))
    ...     check_npz_sizes(os.path.join(d, "a.npz"))["x"][0]
    (2, 3)
    """
    from ..scene import SceneError

    try:
        return npz_headers(path, limit=limit)
    except SceneError as err:
        raise GraphValidationError(str(err)) from err


@dataclass
class NativeFile:
    """Contents of a native file: graphs by name, extra arrays, metadata."""

    graphs: dict[str, CorrespondenceGraph] = field(default_factory=dict)
    arrays: dict[str, np.ndarray] = field(default_factory=dict)
    meta: dict[str, Any] = field(default_factory=dict)


def _compact(lab: np.ndarray) -> np.ndarray:
    hi = int(lab.max()) if lab.size else 0
    lo = int(lab.min()) if lab.size else 0
    if lo >= 0 and hi < 2**16:
        return lab.astype(np.uint16)
    return lab.astype(np.int32)


def _str_safe(col: np.ndarray) -> np.ndarray:
    return col.astype(str) if col.dtype.kind == "O" else col


def save_native(
    path: str | PathLike[str],
    graphs: Mapping[str, CorrespondenceGraph],
    arrays: Mapping[str, np.ndarray] | None = None,
    meta: Mapping[str, Any] | None = None,
) -> None:
    """Write graphs, their masks, extra arrays and metadata to one ``.npz``.

    The file is written to a temporary name and renamed, so a crash never
    leaves half a file.

    Parameters
    ----------
    path : path-like
        Target file (``.npz`` is conventional).
    graphs : mapping of str to CorrespondenceGraph
    arrays : mapping of str to numpy.ndarray, optional
    meta : mapping, optional
        JSON-serialisable metadata.
    """
    store: dict[str, np.ndarray] = {}
    header: dict[str, Any] = {"format": FORMAT, "version": VERSION, "graphs": {}, "meta": dict(meta or {})}
    mask_sets: list[list[np.ndarray]] = []
    for name, g in graphs.items():
        if "/" in name:
            raise ValueError(f"graph names may not contain '/' (got {name!r})")
        g.validate()
        entry: dict[str, Any] = {
            "num_nodes": g.num_nodes,
            "level": g.level,
            "meta": g.meta,
            "node": list(g.node_attr),
            "edge": list(g.edge_attr),
            "members": g._members is not None,
            "masks": None,
        }
        store[f"{name}/edge_index"] = g.edge_index
        for col, arr in g.node_attr.items():
            store[f"{name}/node/{col}"] = _str_safe(arr)
        for col, arr in g.edge_attr.items():
            store[f"{name}/edge/{col}"] = _str_safe(arr)
        if g._members is not None:
            for col, arr in g._members.items():
                store[f"{name}/members/{col}"] = arr
        if g.masks is not None:
            for s, existing in enumerate(mask_sets):
                if len(existing) == len(g.masks) and all(a is b for a, b in zip(existing, g.masks)):
                    entry["masks"] = s
                    break
            else:
                entry["masks"] = len(mask_sets)
                mask_sets.append(g.masks)
                for v, lab in enumerate(g.masks):
                    store[f"masks/{entry['masks']}/{v}"] = _compact(lab)
            entry["num_views"] = len(g.masks)
        header["graphs"][name] = entry
    for name, arr in (arrays or {}).items():
        store[f"arrays/{name}"] = _str_safe(np.asarray(arr))
    header["arrays"] = list(arrays or {})
    store["__header__"] = np.frombuffer(json.dumps(header).encode(), dtype=np.uint8)
    path = os.fspath(path)
    tmp = f"{path}.tmp-{os.getpid()}.npz"
    try:
        _savez_reproducible(tmp, store)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


def _savez_reproducible(path: str, arrays: dict[str, np.ndarray]) -> None:
    """``np.savez_compressed`` with a fixed timestamp on every entry: the same arrays give the same bytes.

    (numpy stamps each entry with the current time, so two identical results
    written a second apart would differ.)
    """
    import zipfile

    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED, allowZip64=True) as zf:
        for key, arr in arrays.items():
            info = zipfile.ZipInfo(f"{key}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            with zf.open(info, "w", force_zip64=True) as f:
                np.lib.format.write_array(f, np.asanyarray(arr), allow_pickle=False)


def load_native(path: str | PathLike[str]) -> NativeFile:
    """Read a file written by :func:`save_native`.

    Declared array sizes are checked before anything is allocated
    (:func:`check_npz_sizes`); every array is read through
    :class:`graphseg.io.files.NpzFile`, so damaged bytes name their entry.

    Raises
    ------
    GraphValidationError
        If the file is not a graphseg native file, has an unknown version, or is
        damaged, corrupt or tampered (the message names the file and the entry).
    """
    from ..scene import SceneError

    try:
        return _load_native(path)
    except GraphValidationError:
        raise
    except SceneError as err:  # from NpzFile: "PATH: ENTRY: damaged ..."
        raise GraphValidationError(str(err)) from err
    except (*DAMAGE, AttributeError) as err:
        raise GraphValidationError(f"{path}: file: corrupt or tampered graphseg file ({describe(err)})") from err


def _load_native(path: str | PathLike[str]) -> NativeFile:
    with NpzFile(path) as z:
        if "__header__" not in z:
            raise GraphValidationError(f"{path}: not a graphseg native file (no __header__)")
        if z.headers["__header__"][0] > (2**24,):
            raise GraphValidationError(f"{path}: __header__: larger than 16 MiB")
        try:
            header = json.loads(bytes(z["__header__"]).decode())
        except (ValueError, RecursionError) as err:
            raise GraphValidationError(f"{path}: __header__: not a JSON header ({describe(err)})") from err
        if not isinstance(header, dict):
            raise GraphValidationError(f"{path}: __header__: expected a JSON object")
        if header.get("format") != FORMAT:
            raise GraphValidationError(f"{path}: expected format {FORMAT!r} (got {header.get('format')!r})")
        if header.get("version") != VERSION:
            raise GraphValidationError(f"{path}: unsupported version {header.get('version')!r}")
        for key, kind in (("graphs", dict), ("meta", dict), ("arrays", list)):
            if not isinstance(header.get(key, kind()), kind):
                raise GraphValidationError(f"{path}: __header__: expected {key!r} to be a JSON {'object' if kind is dict else 'list'}")

        def ints(key: str) -> np.ndarray:
            a = z[key]
            if a.dtype.kind not in "iu":
                raise GraphValidationError(f"{path}: {key}: expected integers (got {a.dtype})")
            return a

        def column(key: str) -> np.ndarray:
            a = z[key]
            if a.dtype.kind not in "biufUS":
                raise GraphValidationError(f"{path}: {key}: expected numbers, booleans or strings (got {a.dtype})")
            return a

        mask_cache: dict[int, list[np.ndarray]] = {}
        out = NativeFile(meta=header.get("meta", {}))
        for name, entry in header["graphs"].items():
            masks = None
            if entry.get("masks") is not None:
                s = int(entry["masks"])
                if s not in mask_cache:
                    mask_cache[s] = [ints(f"masks/{s}/{v}").astype(np.int32) for v in range(entry["num_views"])]
                masks = mask_cache[s]
            members = None
            if entry.get("members"):
                members = {c: ints(f"{name}/members/{c}") for c in ("view", "mask_id", "node")}
            g = CorrespondenceGraph(
                entry["num_nodes"],
                ints(f"{name}/edge_index"),
                {c: column(f"{name}/edge/{c}") for c in entry["edge"]},
                {c: column(f"{name}/node/{c}") for c in entry["node"]},
                masks=masks,
                members=members,
                level=entry["level"],
                meta=entry.get("meta", {}),
            )
            g.validate()
            out.graphs[name] = g
        for name in header.get("arrays", []):
            out.arrays[name] = column(f"arrays/{name}")
    return out


def save_graph(path: str | PathLike[str], graph: CorrespondenceGraph) -> None:
    """Save one graph (see :func:`save_native`)."""
    save_native(path, {"graph": graph})


def load_graph(path: str | PathLike[str]) -> CorrespondenceGraph:
    """Load the single graph saved by :func:`save_graph`."""
    f = load_native(path)
    if len(f.graphs) != 1:
        raise GraphValidationError(f"{path}: expected one graph (got {sorted(f.graphs)})")
    return next(iter(f.graphs.values()))
