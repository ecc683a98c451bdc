"""The store on disk: one folder per scene, written so that a killed process never changes it.

::

    STORE/
      .graphseg-output                 marker: a graphseg output of kind "store" (no manifest: never deleted)
      store.json                       the pointer: {"format": "graphseg-store", "version": 1,
                                       "generation": G, "state": ..., "result": ...}
      store.lock                       the writers' lock (flock) and the pid of the holder
      views/V000007.npz                one view: rgb, depth, points, confidence, K, pose,
                                       ground truth, masks, background, composed masks, node table
      pairs/M000012.npz                the matches computed by the add of generation 12, per view
                                       pair (key P000003-000007: view uid 3 matched against uid 7)
      generations/000012.state.json    what generation 12 holds: config, views, pairs, object ids, history
      generations/000012.result.npz    its Result (graphseg.Result.load): the stage graphs with every
                                       edge and its evidence, labels, object clouds

Every file is written once, under a temporary name, flushed and renamed
(:func:`write_file`); files are never changed afterwards. An add writes its
new view, pair and generation files first and then replaces ``store.json``
(one :func:`os.replace`, the commit). A process killed at any point leaves
``store.json`` naming the old generation, whose files are untouched: the
store is as it was before the add. Files no generation refers to (left by a
killed add) are removed by the next add (:func:`collect_garbage`); so are
generations older than the previous one.

One writer at a time: :class:`StoreLock` takes an exclusive ``flock`` on
``store.lock`` (released by the kernel when the process dies) and writes its
pid there, so a second writer is refused with one line naming it.

All arrays are numpy ``.npz`` without pickle; their declared sizes are checked
before they are read (:func:`graphseg.graphs.native.check_npz_sizes`).

Examples
--------
>>> import tempfile, os
>>> d = tempfile.mkdtemp()
>>> root = create_store(os.path.join(d, "s"), {"seed": 0})
>>> read_pointer(root)["generation"], sorted(p.name for p in root.iterdir())
(0, ['.graphseg-output', 'generations', 'pairs', 'store.json', 'views'])
"""

from __future__ import annotations

import contextlib
import json
import os
import re
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..io.files import NpzFile, describe, read_json
from ..result import jsonable
from ..scene import Matches, SceneError, View

__all__ = [
    "FORMAT",
    "VERSION",
    "READS",
    "POINTER",
    "LOCK",
    "StoreError",
    "StoreLockedError",
    "StoreLock",
    "is_store",
    "create_store",
    "read_pointer",
    "read_state",
    "write_file",
    "write_json",
    "commit",
    "view_file",
    "pair_file",
    "write_view",
    "read_view",
    "pair_key",
    "write_pairs",
    "read_pairs",
    "sync_dirs",
    "written",
    "collect_garbage",
]

FORMAT = "graphseg-store"
#: The format version this graphseg writes.
VERSION = 1
#: The format versions this graphseg reads.
READS = (1,)
POINTER = "store.json"
LOCK = "store.lock"
_TMP = ".tmp-"


class StoreError(SceneError):
    """A store that cannot be opened or written (one line naming the file and field)."""


class StoreLockedError(StoreError):
    """Another process is writing the store."""


def _fsync_dir(path: Path) -> None:
    with contextlib.suppress(OSError):
        fd = os.open(path, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def write_file(path: Path, writer: Any, *, sync_dir: bool = True) -> None:
    """Write ``path`` atomically: ``writer(tmp)`` fills a temporary sibling, which is flushed and renamed.

    A killed process leaves at most the temporary ``NAME.tmp-PID``, which
    :func:`collect_garbage` removes later; never half a ``path``. With
    ``sync_dir=False`` the caller flushes the folder itself (:func:`sync_dirs`)
    before it commits.
    """
    tmp = path.with_name(f"{path.name}{_TMP}{os.getpid()}")
    try:
        writer(tmp)
        with open(tmp, "rb+") as f:
            os.fsync(f.fileno())
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    if sync_dir:
        _fsync_dir(path.parent)


def sync_dirs(root: str | os.PathLike[str]) -> None:
    """Flush the store's folders, so that the files renamed into them survive a power cut."""
    for sub in ("views", "pairs", "generations"):
        _fsync_dir(Path(root) / sub)


def write_json(path: Path, doc: Any) -> None:
    """:func:`write_file` of one JSON document."""
    text = json.dumps(doc, indent=1, default=jsonable)

    def put(tmp: Path) -> None:
        tmp.write_text(text, encoding="utf-8")

    write_file(path, put)


def _savez(path: Path, arrays: Mapping[str, np.ndarray], *, level: int = 1) -> None:
    """A compressed ``.npz`` (deflate ``level``: 1 is twice as fast as numpy's default for float maps,
    and as small) without pickle; object arrays are refused."""
    import zipfile

    for k, a in arrays.items():
        if np.asarray(a).dtype.hasobject:
            raise TypeError(f"{k}: object arrays are not stored (got {np.asarray(a).dtype})")

    def put(tmp: Path) -> None:
        with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=level, allowZip64=True) as zf:
            for k, a in arrays.items():
                with zf.open(f"{k}.npy", "w", force_zip64=True) as f:
                    np.lib.format.write_array(f, np.asanyarray(a), allow_pickle=False)

    write_file(path, put, sync_dir=False)


def _loadz(path: Path, skip: Sequence[str] = ()) -> dict[str, np.ndarray]:
    """Every array of a store file but ``skip``; sizes checked first, damage named by entry (:class:`~graphseg.io.files.NpzFile`)."""
    if not path.is_file():
        raise StoreError("file not found (the store is incomplete)", where=str(path), field="file")
    with NpzFile(path, error=StoreError) as z:
        return z.read(skip=skip)


def _header(arrays: dict[str, np.ndarray], path: Path) -> dict[str, Any]:
    raw = arrays.get("__header__")
    if raw is not None and (raw.dtype != np.uint8 or raw.ndim != 1):
        raise StoreError(f"expected uint8 bytes of JSON (got {raw.dtype} {list(raw.shape)})", where=str(path), field="__header__")
    try:
        doc = json.loads(raw.tobytes().decode()) if raw is not None else None
    except (ValueError, RecursionError) as err:
        raise StoreError(f"unreadable header ({describe(err)})", where=str(path), field="__header__") from err
    if not isinstance(doc, dict):
        raise StoreError("missing header", where=str(path), field="__header__")
    return doc


def _header_array(doc: Mapping[str, Any]) -> np.ndarray:
    return np.frombuffer(json.dumps(doc, default=jsonable).encode(), dtype=np.uint8)


# ----------------------------------------------------------------------------- the folder
def is_store(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is a folder holding a store pointer (``store.json``).

    Examples
    --------
    >>> is_store("/nonexistent")
    False
    """
    p = Path(path)
    return p.is_dir() and (p / POINTER).is_file()


def create_store(path: str | os.PathLike[str], config: Mapping[str, Any], *, inputs: Sequence[str | os.PathLike[str]] = (), name: str | None = None) -> Path:
    """Create an empty store (generation 0) at ``path``, which must not exist.

    The folder is built in a marked temporary sibling and renamed into place
    (:func:`graphseg.output.atomic_folder`), as every graphseg output.

    Raises
    ------
    StoreError
        When ``path`` exists (and is no store), is a link, or lies in an input.
    """
    from ..output import atomic_folder, check_target, write_marker

    where = str(path)
    if os.path.lexists(path):
        raise StoreError("exists and is not a graphseg store (choose a new folder)", where=where, field="store")
    try:
        dest = check_target(path, "store", inputs=inputs)
    except StoreError:
        raise
    except SceneError as err:
        raise StoreError(str(err).split(": ", 2)[-1], where=where, field="store") from err
    with atomic_folder(dest, "store") as tmp:
        for sub in ("views", "pairs", "generations"):
            (tmp / sub).mkdir()
        state = {"format": FORMAT, "version": VERSION, "generation": 0, "name": name or dest.name, "config": dict(config), "views": [], "pairs": [], "mask_uid": [], "mask_pid": [], "next_uid": 0, "next_pid": 1, "history": [], "objects": {}, "lifter": None}
        write_json(tmp / "generations" / "000000.state.json", state)
        write_json(tmp / POINTER, {"format": FORMAT, "version": VERSION, "generation": 0, "state": "generations/000000.state.json", "result": None})
    write_marker(dest, "store")  # no manifest: a store grows; it is never deleted, only kept as a backup
    return dest


def _check_version(doc: Any, where: str, field: str) -> None:
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        got = doc.get("format") if isinstance(doc, dict) else type(doc).__name__
        raise StoreError(f"not a graphseg store (format {got!r}, expected {FORMAT!r})", where=where, field=field)
    v = doc.get("version")
    if not isinstance(v, int) or isinstance(v, bool):
        raise StoreError(f"expected an integer format version (got {v!r})", where=where, field=field)
    if v not in READS:
        if v > max(READS):
            raise StoreError(f"format version {v} is newer than this graphseg reads ({', '.join(map(str, READS))}); upgrade graphseg", where=where, field="version")
        raise StoreError(f"format version {v} is older than any this graphseg reads ({', '.join(map(str, READS))}); re-create the store with graphseg add", where=where, field="version")


def read_pointer(root: str | os.PathLike[str]) -> dict[str, Any]:
    """The pointer ``store.json`` of a store, checked (format, version, generation).

    Raises
    ------
    StoreError
        One line: not a store, an unknown or unreadable format version.
    """
    p = Path(root) / POINTER
    where = str(p)
    if not Path(root).is_dir():
        raise StoreError("no such store folder", where=str(root), field="store")
    if not p.is_file():
        raise StoreError("not a graphseg store (no store.json)", where=str(root), field="store")
    try:
        doc = read_json(p, field="store.json", max_bytes=2**20, what="unreadable", error=StoreError)
    except OSError as err:
        raise StoreError(f"unreadable ({(str(err).splitlines() or [''])[0]})", where=where, field="store.json") from err
    _check_version(doc, where, "format")
    g = doc.get("generation")
    if not isinstance(g, int) or g < 0 or not isinstance(doc.get("state"), str):
        raise StoreError(f"expected a generation >= 0 and a state file (got {g!r})", where=where, field="generation")
    return doc


def _inside(root: Path, rel: str, where: str, field: str) -> Path:
    p = (root / rel).resolve()
    if not p.is_relative_to(root.resolve()) or not re.fullmatch(r"[A-Za-z0-9_./-]+", rel):
        raise StoreError(f"path {rel!r} leaves the store", where=where, field=field)
    return p


def read_state(root: str | os.PathLike[str], pointer: Mapping[str, Any]) -> dict[str, Any]:
    """The state of the generation ``pointer`` names (views, pairs, object ids, history, config)."""
    r = Path(root)
    p = _inside(r, str(pointer["state"]), str(r / POINTER), "state")
    where = str(p)
    try:
        doc = read_json(p, field="state", max_bytes=256 * 2**20, what="unreadable", error=StoreError)
    except FileNotFoundError as err:
        raise StoreError("file not found (the store is incomplete)", where=where, field="state") from err
    except OSError as err:
        raise StoreError(f"unreadable ({(str(err).splitlines() or [''])[0]})", where=where, field="state") from err
    _check_version(doc, where, "format")
    for key, kind in (("views", list), ("pairs", list), ("mask_uid", list), ("mask_pid", list), ("history", list), ("config", dict), ("next_uid", int), ("next_pid", int)):
        if not isinstance(doc.get(key), kind):
            raise StoreError(f"expected {kind.__name__} (got {type(doc.get(key)).__name__})", where=where, field=key)
    if doc.get("generation") != pointer["generation"]:
        raise StoreError(f"generation {doc.get('generation')!r} differs from store.json's {pointer['generation']}", where=where, field="generation")
    _check_state(doc, where)
    return doc


def _is_int(x: Any) -> bool:
    return isinstance(x, int) and not isinstance(x, bool) and -(2**63) <= x < 2**63


def _check_state(doc: dict[str, Any], where: str) -> None:
    """The entries of a state document that the store reads: their types and the view uids the pairs name.

    Raises
    ------
    StoreError
        Naming the state file and the first entry that is wrong (a damaged or edited file).
    """

    def bad(field: str, want: str) -> StoreError:
        return StoreError(f"expected {want} (a damaged or edited state file)", where=where, field=field)

    uids: set[int] = set()
    names: set[str] = set()
    for k, v in enumerate(doc["views"]):
        if not isinstance(v, dict) or not isinstance(v.get("name"), str) or not _is_int(v.get("uid")) or not isinstance(v.get("file"), str):
            raise bad(f"views[{k}]", "an object with a name, an integer uid and a file")
        if v["uid"] in uids or v["name"] in names:
            raise bad(f"views[{k}]", "a view name and uid of its own")
        uids.add(v["uid"])
        names.add(v["name"])
    for k, p in enumerate(doc["pairs"]):
        if not isinstance(p, dict) or not _is_int(p.get("a")) or not _is_int(p.get("b")) or not isinstance(p.get("file"), str) or not isinstance(p.get("key", ""), str):
            raise bad(f"pairs[{k}]", "an object with view uids a and b and a file")
        if p["a"] not in uids or p["b"] not in uids:
            raise bad(f"pairs[{k}]", f"uids of views of this generation (got {p['a']}, {p['b']})")
    for key in ("mask_uid", "mask_pid"):
        if not all(_is_int(x) for x in doc[key]):
            raise bad(key, "a list of integers")
    if len(doc["mask_uid"]) != len(doc["mask_pid"]):
        raise bad("mask_pid", f"{len(doc['mask_uid'])} integers like mask_uid")
    for k, h in enumerate(doc["history"]):
        events = h.get("events") if isinstance(h, dict) else None
        if (
            not isinstance(h, dict)
            or not _is_int(h.get("generation"))
            or not isinstance(h.get("added"), list)
            or not all(isinstance(n, str) for n in h["added"])
            or not isinstance(events, list)
            or not all(isinstance(e, dict) and isinstance(e.get("event"), str) for e in events)
        ):
            raise bad(f"history[{k}]", "an object with a generation, the views added and the events")
    objects = doc.get("objects") or {}
    if not isinstance(objects, dict) or not all(re.fullmatch(r"-?[0-9]+", k) for k in objects):
        raise bad("objects", "an object keyed by ground-truth ids")
    ids = doc.get("object_ids", [])
    if not isinstance(ids, list) or not all(_is_int(x) for x in ids):
        raise bad("object_ids", "a list of integers")
    for key in ("name", "lifter"):
        if doc.get(key) is not None and not isinstance(doc[key], str):
            raise bad(key, "a string")


def commit(root: str | os.PathLike[str], generation: int, state_rel: str, result_rel: str | None) -> None:
    """Make ``generation`` the store's current one: one atomic replace of ``store.json``.

    The store's folders are flushed first, so the files of ``generation`` are
    on disk before the pointer names them.
    """
    sync_dirs(root)
    write_json(Path(root) / POINTER, {"format": FORMAT, "version": VERSION, "generation": int(generation), "state": state_rel, "result": result_rel})


class StoreLock:
    """An exclusive lock on a store for one writer (``fcntl.flock`` on ``store.lock``).

    Raises
    ------
    StoreLockedError
        When another process holds it: ``STORE: lock: another graphseg process (pid N) is writing this store; ...``.

    Examples
    --------
    >>> import tempfile
    >>> d = tempfile.mkdtemp()
    >>> with StoreLock(d):
    ...     StoreLock(d).acquire()
    Traceback (most recent call last):
    ...
    graphseg.store.layout.StoreLockedError: ...: lock: another graphseg process (pid ...) is writing this store; try again when it has finished
    """

    def __init__(self, root: str | os.PathLike[str]) -> None:
        self.root = Path(root)
        self.fd: int | None = None

    def acquire(self) -> StoreLock:
        import fcntl

        path = self.root / LOCK
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            try:
                holder = os.read(fd, 64).decode(errors="replace").strip() or "?"
            except OSError:
                holder = "?"
            os.close(fd)
            raise StoreLockedError(f"another graphseg process (pid {holder}) is writing this store; try again when it has finished", where=str(self.root), field="lock") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        self.fd = fd
        return self

    def release(self) -> None:
        import fcntl

        if self.fd is not None:
            with contextlib.suppress(OSError):
                os.ftruncate(self.fd, 0)
            fcntl.flock(self.fd, fcntl.LOCK_UN)
            os.close(self.fd)
            self.fd = None

    def __enter__(self) -> StoreLock:
        return self.acquire()

    def __exit__(self, *exc: Any) -> None:
        self.release()


# ----------------------------------------------------------------------------- views and pairs
def view_file(uid: int) -> str:
    """The store-relative file of view ``uid``."""
    return f"views/V{int(uid):06d}.npz"


def pair_file(generation: int) -> str:
    """The store-relative file of the matches computed by the add that made ``generation``."""
    return f"pairs/M{int(generation):06d}.npz"


def pair_key(a: int, b: int) -> str:
    """The key of the matches of view ``a`` against view ``b`` inside a pair file."""
    return f"P{int(a):06d}-{int(b):06d}"


def write_view(root: str | os.PathLike[str], data: Any) -> str:
    """Write one :class:`~graphseg.store.incremental.ViewData`; return its store-relative file."""
    rel = view_file(data.uid)
    v: View = data.view
    arrays: dict[str, np.ndarray] = {"rgb": np.asarray(v.rgb, np.uint8), "points": np.asarray(v.points, np.float32), "background": np.asarray(data.background, bool)}
    lab = np.asarray(data.labels)
    arrays["labels"] = lab.astype(np.uint16) if lab.size == 0 or int(lab.max()) < 2**16 else lab.astype(np.int32)
    masks = np.asarray(data.masks)
    arrays["masks"] = masks if masks.dtype == bool else masks.astype(np.int32)
    for key in ("depth", "confidence", "K", "cam_to_world", "instances"):
        val = getattr(v, key)
        if val is not None:
            arrays[key] = np.asarray(val)
    for col, arr in data.nodes.items():
        arrays[f"nodes/{col}"] = np.asarray(arr)
    if data.features is not None:
        arrays["features"] = np.asarray(data.features)
    meta = {"name": v.name, "uid": int(data.uid), "info": data.info, "view_meta": {k: val for k, val in v.meta.items() if isinstance(val, (str, int, float, bool))}}
    arrays["__header__"] = _header_array(meta)
    _savez(Path(root) / rel, arrays)
    return rel


#: The dtype kinds of the arrays of a view file (others: numbers or booleans).
_VIEW_KINDS = {"rgb": "u", "points": "f", "depth": "f", "confidence": "f", "K": "f", "cam_to_world": "f", "background": "b", "labels": "iu", "instances": "iu", "masks": "biu"}
_KIND_WORDS = {"u": "unsigned integers", "f": "floats", "b": "booleans", "iu": "integers", "biu": "booleans or integers", "biuf": "numbers"}


def read_view(root: str | os.PathLike[str], rel: str, *, masks: bool = False, full: bool = True) -> Any:
    """Read a view written by :func:`write_view` (a :class:`~graphseg.store.incremental.ViewData`).

    The segmenter's masks (a large bool stack for some segmenters) are read
    only with ``masks=True``; else ``ViewData.masks`` is None. With
    ``full=False`` the view's depth and ground truth, which an add does not
    read, are left out too (``View.depth`` and ``View.instances`` are None).
    """
    from .incremental import ViewData

    r = Path(root)
    path = _inside(r, rel, str(r), "views")
    a = _loadz(path, skip=(() if masks else ("masks",)) + (() if full else ("depth", "instances")))
    meta = _header(a, path)
    for key in ("info", "view_meta"):
        if not isinstance(meta.get(key) or {}, dict):
            raise StoreError(f"expected an object (got {type(meta[key]).__name__})", where=str(path), field=f"__header__.{key}")
    for key, arr in a.items():
        kind = _VIEW_KINDS.get(key, "biuf")
        if key != "__header__" and arr.dtype.kind not in kind:
            raise StoreError(f"expected {_KIND_WORDS[kind]} (got {arr.dtype})", where=str(path), field=key)
    field = "rgb"
    try:
        rgb = a["rgb"]
        h, w = rgb.shape[:2]
        for field, shape in (("points", (h, w, 3)), ("background", (h, w)), ("labels", (h, w))):
            if a[field].shape != shape:
                raise StoreError(f"expected {list(shape)} (got {list(a[field].shape)})", where=str(path), field=field)
        view = View(
            str(meta["name"]),
            rgb,
            depth=a.get("depth"),
            points=a["points"],
            confidence=a.get("confidence"),
            K=a.get("K"),
            cam_to_world=a.get("cam_to_world"),
            instances=a.get("instances"),
            meta=dict(meta.get("view_meta") or {}),
        )
        field = "points"
        if np.isinf(view.points).any():
            raise StoreError("contains inf (NaN marks invalid points)", where=str(path), field=field)
        field = "view"
        view.validate()
        nodes = {k.split("/", 1)[1]: v for k, v in a.items() if k.startswith("nodes/")}
        field = "uid"
        uid = int(meta["uid"])
    except StoreError:
        raise
    except (KeyError, ValueError, TypeError, IndexError) as err:
        raise StoreError(f"corrupt view file ({type(err).__name__}: {(str(err).splitlines() or [''])[0]})", where=str(path), field=field) from err
    return ViewData(view, uid, a.get("masks"), a["background"].astype(bool), a["labels"].astype(np.int32), nodes, dict(meta.get("info") or {}), a.get("features"))


def write_pairs(root: str | os.PathLike[str], generation: int, matches: Mapping[tuple[int, int], Matches]) -> str:
    """Write the matches of the view pairs ``(a, b)`` matched by one add (view ``a`` in ``xy_i``); return the file."""
    rel = pair_file(generation)
    arrays: dict[str, np.ndarray] = {}
    for (a, b), m in matches.items():
        k = pair_key(a, b)
        arrays[f"{k}/xy_i"], arrays[f"{k}/xy_j"], arrays[f"{k}/certainty"] = m.xy_i, m.xy_j, m.certainty
    arrays["__header__"] = _header_array({"generation": int(generation), "pairs": [[int(a), int(b)] for a, b in matches]})
    _savez(Path(root) / rel, arrays)
    return rel


def read_pairs(root: str | os.PathLike[str], rel: str) -> dict[str, Matches]:
    """The matches of a file written by :func:`write_pairs`, by :func:`pair_key`."""
    r = Path(root)
    path = _inside(r, rel, str(r), "pairs")
    a = _loadz(path)
    out = {}
    for name in a:
        if name.endswith("/xy_i"):
            k = name[: -len("/xy_i")]
            try:
                out[k] = Matches(a[f"{k}/xy_i"], a[f"{k}/xy_j"], a[f"{k}/certainty"])
            except (KeyError, ValueError) as err:
                raise StoreError(f"corrupt matches ({type(err).__name__}: {(str(err).splitlines() or [''])[0]})", where=str(path), field=k) from err
    return out


# ----------------------------------------------------------------------------- cleaning up
_OURS = re.compile(r"^(V\d{6}\.npz|M\d{6}\.npz|\d{6}\.(state\.json|result\.npz))$")
_TEMP = re.compile(r"^(.+)" + re.escape(_TMP) + r"(\d+)(\.npz)?$")


def collect_garbage(root: str | os.PathLike[str], keep: set[str]) -> list[str]:
    """Remove the store's own files that no kept generation refers to; return them (store-relative).

    Only files named as the store names them (``views/V*.npz``,
    ``pairs/M*.npz``, ``generations/*.state.json`` / ``*.result.npz``) and
    temporary files of dead processes are removed; anything else in the
    folder is left alone.
    """
    from ..output import pid_alive

    r = Path(root)
    removed = []
    for sub in ("views", "pairs", "generations"):
        folder = r / sub
        if not folder.is_dir():
            continue
        for f in folder.iterdir():
            rel = f"{sub}/{f.name}"
            if f.is_symlink() or not f.is_file():
                continue
            m = _TEMP.match(f.name)
            if m and not pid_alive(int(m.group(2))):
                f.unlink(missing_ok=True)
                removed.append(rel)
            elif _OURS.match(f.name) and rel not in keep:
                f.unlink(missing_ok=True)
                removed.append(rel)
    return sorted(removed)


@contextlib.contextmanager
def written(root: str | os.PathLike[str]) -> Iterator[list[str]]:
    """Collect the store-relative files an add writes; on failure remove them again (best effort)."""
    files: list[str] = []
    try:
        yield files
    except BaseException:
        for rel in files:
            with contextlib.suppress(OSError):
                (Path(root) / rel).unlink()
        raise
