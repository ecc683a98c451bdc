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

from .graph import CorrespondenceGraph, GraphValidationError

__all__ = ["save_graph", "load_graph", "save_native", "load_native", "check_npz_sizes", "bomb_limit", "NativeFile", "FORMAT", "VERSION", "MAX_ARRAY_BYTES", "BOMB_RATIO", "BOMB_MIN_BYTES"]

FORMAT = "graphseg-graph"
VERSION = 1
#: Upper bound on the total decompressed size of the arrays of one file (override with
#: the environment variable ``GRAPHSEG_MAX_ARRAY_BYTES``).
MAX_ARRAY_BYTES = 16 * 2**30
#: Deflate cannot compress better than about 1032:1.
_MAX_RATIO = 1100
#: An entry that packs more than this many bytes per compressed byte (only runs of one
#: value do: 4 GiB of zeros deflate 1028:1, real label images 100-500:1) ...
BOMB_RATIO = 1000
#: ... and is larger than this (or than 8 bytes per pixel of the pixel budget, one int32
#: label image and more) is refused as a zip bomb before it is decompressed.
BOMB_MIN_BYTES = 64 * 2**20


def bomb_limit() -> int:
    """Bytes above which an entry compressed at :data:`BOMB_RATIO`:1 or more is refused.

    ``max(BOMB_MIN_BYTES, 8 * pixel budget)``: a real output holds no near-constant
    array larger than one int32 label image of the largest allowed view
    (``$GRAPHSEG_MAX_PIXELS``, :func:`graphseg.io.images.max_pixels`).

    Examples
    --------
    >>> bomb_limit() >= BOMB_MIN_BYTES
    True
    """
    from ..io.images import max_pixels

    return max(BOMB_MIN_BYTES, 8 * max_pixels())


def _size(n: int) -> str:
    """``n`` bytes in the largest binary unit that keeps one digit before the point.

    Examples
    --------
    >>> _size(3 * 2**30), _size(1536), _size(12)
    ('3.0 GiB', '1.5 KiB', '12 B')
    """
    for unit, k in (("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if n >= k:
            return f"{n / k:.1f} {unit}"
    return f"{n} B"


def check_npz_sizes(path: str | PathLike[str], *, limit: int | None = None) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
    """Read the declared shape and dtype of every array in an ``.npz`` without loading any.

    Every declared size is checked against the member's size in the zip, the
    compressed size (deflate's maximum ratio) and ``limit`` (default
    :data:`MAX_ARRAY_BYTES` or ``$GRAPHSEG_MAX_ARRAY_BYTES``) before anything
    is allocated. An entry larger than :func:`bomb_limit` that is compressed
    :data:`BOMB_RATIO`:1 or better (a zip bomb: gigabytes of zeros in a few
    megabytes) is refused before it is decompressed.

    Returns
    -------
    dict
        Array name -> ``(shape, dtype)``.

    Raises
    ------
    GraphValidationError
        Naming the file and the array that is corrupt or too large.

    Examples
    --------
    >>> import tempfile, os
    >>> with tempfile.TemporaryDirectory() as d:
    ...     np.savez_compressed(os.path.join(d, "a.npz"), x=np.zeros((2, 3)))
    ...     check_npz_sizes(os.path.join(d, "a.npz"))["x"][0]
    (2, 3)
    """
    import zipfile

    cap = int(limit if limit is not None else os.environ.get("GRAPHSEG_MAX_ARRAY_BYTES", MAX_ARRAY_BYTES))
    bomb = bomb_limit()
    out: dict[str, tuple[tuple[int, ...], np.dtype]] = {}
    total = 0
    try:
        with zipfile.ZipFile(os.fspath(path)) as zf:
            for info in zf.infolist():
                name = info.filename[:-4] if info.filename.endswith(".npy") else info.filename
                if info.file_size > max(info.compress_size, 1) * _MAX_RATIO + 2**20:
                    raise GraphValidationError(f"{path}: {name}: declared size {info.file_size} bytes is impossible for {info.compress_size} compressed bytes (tampered file)")
                if info.file_size > bomb and info.file_size >= max(info.compress_size, 1) * BOMB_RATIO:
                    raise GraphValidationError(
                        f"{path}: {name}: {_size(info.file_size)} compressed into {_size(info.compress_size)} "
                        f"({info.file_size // max(info.compress_size, 1)}:1); refused as a zip bomb before decompressing "
                        f"(an entry over {_size(bomb)} must compress less than {BOMB_RATIO}:1; raise GRAPHSEG_MAX_PIXELS for larger images)"
                    )
                with zf.open(info) as f:
                    version = np.lib.format.read_magic(f)
                    if version == (1, 0):
                        shape, _, dtype = np.lib.format.read_array_header_1_0(f, max_header_size=10000)
                    else:
                        shape, _, dtype = np.lib.format.read_array_header_2_0(f, max_header_size=10000)
                if dtype.hasobject:
                    raise GraphValidationError(f"{path}: {name}: object arrays are not allowed")
                nbytes = int(np.prod(shape, dtype=object)) * dtype.itemsize
                if nbytes > info.file_size:
                    raise GraphValidationError(f"{path}: {name}: declares {list(shape)} ({nbytes} bytes) but holds {info.file_size} bytes (tampered file)")
                total += nbytes
                if total > cap:
                    raise GraphValidationError(f"{path}: {name}: arrays need {total} bytes, more than the limit of {cap} (GRAPHSEG_MAX_ARRAY_BYTES)")
                out[name] = (tuple(int(x) for x in shape), dtype)
    except (zipfile.BadZipFile, ValueError, EOFError, OSError, SyntaxError) as err:
        if isinstance(err, (FileNotFoundError, GraphValidationError)):
            raise
        raise GraphValidationError(f"{path}: file: not a valid .npz ({str(err).splitlines()[0] if str(err) else type(err).__name__})") from err
    return out


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
    (:func:`check_npz_sizes`).

    Raises
    ------
    GraphValidationError
        If the file is not a graphseg native file, has an unknown version, or is
        corrupt or tampered (the message names the file and the entry).
    """
    try:
        return _load_native(path)
    except GraphValidationError:
        raise
    except (KeyError, ValueError, TypeError, IndexError, AttributeError, EOFError, UnicodeDecodeError) as err:
        text = str(err).splitlines()[0] if str(err) else type(err).__name__
        raise GraphValidationError(f"{path}: file: corrupt or tampered graphseg file ({type(err).__name__}: {text})") from err


def _load_native(path: str | PathLike[str]) -> NativeFile:
    declared = check_npz_sizes(path)
    with np.load(os.fspath(path), allow_pickle=False) as z:
        if declared.get("__header__", ((0,), None))[0] > (2**24,):
            raise GraphValidationError(f"{path}: __header__: larger than 16 MiB")
        if "__header__" not in z.files:
            raise GraphValidationError(f"{path}: not a graphseg native file (no __header__)")
        header = json.loads(bytes(z["__header__"]).decode())
        if header.get("format") != FORMAT:
            raise GraphValidationError(f"{path}: expected format {FORMAT!r} (got {header.get('format')!r})")
        if header.get("version") != VERSION:
            raise GraphValidationError(f"{path}: unsupported version {header.get('version')!r}")
        mask_cache: dict[int, list[np.ndarray]] = {}
        out = NativeFile(meta=header.get("meta", {}))
        for name, entry in header["graphs"].items():
            masks = None
            if entry.get("masks") is not None:
                s = int(entry["masks"])
                if s not in mask_cache:
                    mask_cache[s] = [z[f"masks/{s}/{v}"].astype(np.int32) for v in range(entry["num_views"])]
                masks = mask_cache[s]
            members = None
            if entry.get("members"):
                members = {c: z[f"{name}/members/{c}"] for c in ("view", "mask_id", "node")}
            g = CorrespondenceGraph(
                entry["num_nodes"],
                z[f"{name}/edge_index"],
                {c: z[f"{name}/edge/{c}"] for c in entry["edge"]},
                {c: z[f"{name}/node/{c}"] for c in entry["node"]},
                masks=masks,
                members=members,
                level=entry["level"],
                meta=entry.get("meta", {}),
            )
            g.validate()
            out.graphs[name] = g
        for name in header.get("arrays", []):
            out.arrays[name] = z[f"arrays/{name}"]
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
