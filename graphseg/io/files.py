r"""Reading files that may be damaged: ``.npz`` / ``.npy`` arrays and JSON documents.

Every reader of these formats in graphseg goes through this module, so that
any damage (a truncated file, zeroed or flipped bytes, a broken zip member or
``.npy`` header, a missing entry, invalid UTF-8 or JSON, nesting too deep)
raises one :class:`~graphseg.scene.SceneError` naming the file and the entry,
``PATH: ENTRY: what is wrong (the decoder's own words)``, never whatever the
decoder raised (``zlib.error``, ``zipfile.BadZipFile``, tokenize errors from
numpy's header parser, ...). The command line turns it into one line and exit 2.

An ``.npz`` is checked before anything in it is decompressed or allocated
(:func:`npz_headers`): every entry's shape and dtype are read from its
``.npy`` header, object arrays (pickle) are refused, and the declared sizes
are checked against the bytes the entry holds, a total cap and the zip-bomb
rule. PNG images are read by :mod:`graphseg.io.images`, YAML configurations
by :func:`graphseg.config.load_yaml_text`.

Examples
--------
>>> import tempfile, os
>>> d = tempfile.mkdtemp()
>>> np.savez(os.path.join(d, "a.npz"), x=np.arange(3))
>>> with NpzFile(os.path.join(d, "a.npz")) as z:
...     z.files, z["x"].tolist(), z.headers["x"][0]
(['x'], [0, 1, 2], (3,))
>>> with open(os.path.join(d, "a.npz"), "r+b") as f:
...     _ = f.write(b"\0" * 60)  # the zip header of the member x.npy
>>> NpzFile(os.path.join(d, "a.npz"))
Traceback (most recent call last):
...
graphseg.scene.SceneError: .../a.npz: x: damaged array header (BadZipFile: Bad magic number for file header)
"""

from __future__ import annotations

import json
import os
import struct
import tokenize
import zipfile
import zlib
from collections.abc import Iterable
from os import PathLike
from typing import Any

import numpy as np

from ..scene import SceneError

__all__ = [
    "DAMAGE",
    "describe",
    "npz_headers",
    "NpzFile",
    "read_npy",
    "read_json",
    "bomb_limit",
    "MAX_ARRAY_BYTES",
    "BOMB_RATIO",
    "BOMB_MIN_BYTES",
]


def _damage_types() -> tuple[type[BaseException], ...]:
    out: list[type[BaseException]] = [
        ValueError,  # numpy's header checks, JSON, UnicodeDecodeError
        TypeError,
        KeyError,  # a missing entry
        IndexError,
        OSError,  # short reads, bz2
        EOFError,
        OverflowError,
        RecursionError,  # JSON nested too deep
        NotImplementedError,  # zipfile: an unknown compression method or flag
        zlib.error,  # a damaged deflate stream
        zipfile.BadZipFile,  # a bad CRC, local header or directory
        tokenize.TokenError,  # numpy's .npy header parser on an unbalanced header
        SyntaxError,
        struct.error,
    ]
    try:
        import lzma

        out.append(lzma.LZMAError)
    except ImportError:  # pragma: no cover - Python built without lzma
        pass
    return tuple(out)


#: What decoding a damaged file can raise; caught only at the boundaries in this module.
DAMAGE: tuple[type[BaseException], ...] = _damage_types()

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
#: The longest decoder message quoted in an error line.
_MAX_TEXT = 160


def describe(err: BaseException) -> str:
    """One short line for a decoding error: its type and the first line of its message.

    Examples
    --------
    >>> describe(zlib.error("Error -3 while decompressing data: invalid distance too far back"))
    'zlib.error: Error -3 while decompressing data: invalid distance too far back'
    >>> describe(tokenize.TokenError("EOF in multi-line statement", (2, 0)))
    "TokenError: ('EOF in multi-line statement', (2, 0))"
    >>> describe(json.JSONDecodeError("Expecting value", "x", 0))
    'Expecting value: line 1 column 1 (char 0)'
    """
    text = (str(err).splitlines() or [""])[0].strip()
    if len(text) > _MAX_TEXT:
        text = text[: _MAX_TEXT - 3] + "..."
    name = type(err).__name__
    if name == "error":  # zlib.error, struct.error
        name = f"{type(err).__module__}.error"
    if isinstance(err, json.JSONDecodeError) and text:
        return text
    return f"{name}: {text}" if text else name


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
    from .images import max_pixels

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


def _read_header(f: Any) -> tuple[tuple[int, ...], np.dtype]:
    version = np.lib.format.read_magic(f)
    if version == (1, 0):
        shape, _, dtype = np.lib.format.read_array_header_1_0(f, max_header_size=10000)
    else:
        shape, _, dtype = np.lib.format.read_array_header_2_0(f, max_header_size=10000)
    return tuple(int(s) for s in shape), dtype


def npz_headers(
    path: str | PathLike[str], *, limit: int | None = None, error: type[SceneError] = SceneError
) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
    """Shapes and dtypes of the arrays of an ``.npz``, read from their headers, checked before anything is loaded.

    Each entry's declared size must fit its uncompressed size, the total must
    stay under ``limit`` (default :data:`MAX_ARRAY_BYTES` or
    ``$GRAPHSEG_MAX_ARRAY_BYTES``), and an entry larger than :func:`bomb_limit`
    that is compressed :data:`BOMB_RATIO`:1 or better (a zip bomb: gigabytes of
    zeros in a few megabytes) is refused before it is decompressed. Members
    that are not ``.npy`` files are skipped (never read).

    Returns
    -------
    dict
        Array name (the member without ``.npy``) -> ``(shape, dtype)``.

    Raises
    ------
    SceneError (or ``error``)
        ``PATH: ENTRY: ...`` for a damaged, tampered or too large entry,
        ``PATH: file: ...`` when the file is no readable zip at all.
        A missing file raises :class:`FileNotFoundError`.
    """
    cap = int(limit if limit is not None else os.environ.get("GRAPHSEG_MAX_ARRAY_BYTES", MAX_ARRAY_BYTES))
    bomb = bomb_limit()
    where = os.fspath(path)
    out: dict[str, tuple[tuple[int, ...], np.dtype]] = {}
    total = 0
    name = None
    try:
        with zipfile.ZipFile(where) as zf:
            for info in zf.infolist():
                if not info.filename.endswith(".npy"):
                    continue
                name = info.filename[:-4]
                if info.file_size > max(info.compress_size, 1) * _MAX_RATIO + 2**20:
                    raise error(f"declared size {info.file_size} bytes is impossible for {info.compress_size} compressed bytes (tampered file)", where=where, field=name)
                if info.file_size > bomb and info.file_size >= max(info.compress_size, 1) * BOMB_RATIO:
                    raise error(
                        f"{_size(info.file_size)} compressed into {_size(info.compress_size)} "
                        f"({info.file_size // max(info.compress_size, 1)}:1); refused as a zip bomb before decompressing "
                        f"(an entry over {_size(bomb)} must compress less than {BOMB_RATIO}:1; raise GRAPHSEG_MAX_PIXELS for larger images)",
                        where=where,
                        field=name,
                    )
                with zf.open(info) as f:
                    shape, dtype = _read_header(f)
                if dtype.hasobject:
                    raise error("object arrays are not allowed (no pickle)", where=where, field=name)
                nbytes = int(np.prod(shape, dtype=object)) * dtype.itemsize
                if nbytes > info.file_size:
                    raise error(f"declares {list(shape)} ({nbytes} bytes) but holds {info.file_size} bytes (tampered file)", where=where, field=name)
                total += nbytes
                if total > cap:
                    raise error(f"arrays need {total} bytes, more than the limit of {cap} (GRAPHSEG_MAX_ARRAY_BYTES)", where=where, field=name)
                out[name] = (shape, dtype)
    except SceneError:
        raise
    except FileNotFoundError:
        raise
    except DAMAGE as err:
        if name is None:
            raise error(f"not a readable .npz file ({describe(err)})", where=where, field="file") from err
        raise error(f"damaged array header ({describe(err)})", where=where, field=name) from err
    return out


class NpzFile:
    """An ``.npz`` opened for reading: sizes checked first (:func:`npz_headers`), every entry read through one guard.

    ``z[key]`` raises ``PATH: KEY: missing`` for an absent entry and
    ``PATH: KEY: damaged array data (...)`` when its bytes do not decode
    (a bad CRC, a broken deflate stream, a short entry). No pickle is loaded.

    Parameters
    ----------
    path : path-like
    limit : int, optional
        Total decompressed bytes allowed (see :func:`npz_headers`).
    error : subclass of SceneError
        The error raised (the store raises its :class:`~graphseg.store.layout.StoreError`).
    """

    def __init__(self, path: str | PathLike[str], *, limit: int | None = None, error: type[SceneError] = SceneError) -> None:
        self.where = os.fspath(path)
        self.error = error
        self.headers = npz_headers(path, limit=limit, error=error)
        try:
            with open(self.where, "rb") as f:
                magic = f.read(4)
            if magic not in (b"PK\x03\x04", b"PK\x05\x06"):  # zipfile also reads a zip behind other leading bytes; numpy does not
                raise error("not a readable .npz file (no zip signature at its start)", where=self.where, field="file")
            z = np.load(self.where, allow_pickle=False)
        except SceneError:
            raise
        except FileNotFoundError:
            raise
        except DAMAGE as err:
            raise error(f"not a readable .npz file ({describe(err)})", where=self.where, field="file") from err
        if not isinstance(z, np.lib.npyio.NpzFile):  # pragma: no cover - ruled out by the signature
            raise error("not a readable .npz file", where=self.where, field="file")
        self._z = z

    @property
    def files(self) -> list[str]:
        """The names of the arrays (the ``.npy`` members)."""
        return [k for k in self._z.files if k in self.headers]

    def __contains__(self, key: object) -> bool:
        return key in self.headers

    def __getitem__(self, key: str) -> np.ndarray:
        if key not in self.headers:
            raise self.error("missing", where=self.where, field=key)
        try:
            arr = self._z[key]
        except DAMAGE as err:
            raise self.error(f"damaged array data ({describe(err)})", where=self.where, field=key) from err
        if not isinstance(arr, np.ndarray):  # pragma: no cover - numpy returns arrays for .npy members
            raise self.error("not an array", where=self.where, field=key)
        return arr

    def get(self, key: str, default: Any = None) -> Any:
        return self[key] if key in self.headers else default

    def read(self, keys: Iterable[str] | None = None, *, skip: Iterable[str] = ()) -> dict[str, np.ndarray]:
        """The arrays named ``keys`` that the file has (default: all), less ``skip``."""
        skipped = set(skip)
        names = self.files if keys is None else [k for k in keys if k in self.headers]
        return {k: self[k] for k in names if k not in skipped}

    def close(self) -> None:
        self._z.close()

    def __enter__(self) -> NpzFile:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def read_npy(path: str | PathLike[str], *, field: str, max_bytes: int = 64 * 2**20, error: type[SceneError] = SceneError) -> np.ndarray:
    """A numeric ``.npy`` file (no pickle, at most ``max_bytes``), memory-mapped and copied.

    Raises
    ------
    SceneError (or ``error``)
        ``PATH: FIELD: ...`` for a file that is too large, damaged, not an
        ``.npy`` or not numeric. A missing file raises :class:`FileNotFoundError`.
    """
    where = os.fspath(path)
    if os.stat(where).st_size > max_bytes:
        raise error(f"larger than {_size(max_bytes)}", where=where, field=field)
    try:
        with open(where, "rb") as f:
            _read_header(f)  # numpy's own error for a non-.npy file is about pickles
        arr = np.array(np.load(where, mmap_mode="r", allow_pickle=False))
    except FileNotFoundError:
        raise
    except DAMAGE as err:
        raise error(f"cannot read .npy ({describe(err)})", where=where, field=field) from err
    if not isinstance(arr, np.ndarray) or arr.dtype.kind not in "biuf":
        raise error(f"expected a numeric array (got {getattr(arr, 'dtype', type(arr).__name__)})", where=where, field=field)
    return arr


def read_json(
    path: str | PathLike[str], *, field: str, max_bytes: int = 64 * 2**20, what: str = "invalid JSON", error: type[SceneError] = SceneError
) -> Any:
    """The parsed JSON document of ``path`` (at most ``max_bytes``).

    Raises
    ------
    SceneError (or ``error``)
        ``PATH: FIELD: invalid JSON (...)`` (or ``what``) for a file that is
        too large, not UTF-8, not JSON or nested too deep. A missing file
        raises :class:`FileNotFoundError`.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> p = Path(tempfile.mkdtemp()) / "x.json"
    >>> _ = p.write_text("[" * 100000)
    >>> read_json(p, field="x.json")
    Traceback (most recent call last):
    ...
    graphseg.scene.SceneError: .../x.json: x.json: invalid JSON (RecursionError: maximum recursion depth exceeded while decoding a JSON array from a unicode string)
    """
    where = os.fspath(path)
    try:
        if os.stat(where).st_size > max_bytes:
            raise error(f"{what} (larger than {_size(max_bytes)})", where=where, field=field)
        with open(where, "rb") as f:
            text = f.read().decode("utf-8")
        return json.loads(text)
    except SceneError:
        raise
    except FileNotFoundError:
        raise
    except DAMAGE as err:
        raise error(f"{what} ({describe(err)})", where=where, field=field) from err
