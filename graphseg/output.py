"""The output folder of a run, and the safety rules of every file graphseg writes.

::

    OUT/
      .graphseg-output       marker (JSON: {"kind": "run", "version": 1}); see below
      labels/VIEW.png        uint16 object ids, consistent across views (0 = background)
      overlays/VIEW.png      RGB with coloured objects and their ids
      objects/OBJ.ply        per-object points and colours (OBJ = 001, 002, ...; never empty)
      objects/OBJ_mesh.ply   per-object mesh fused from all views (open3d installed; graphseg.objects3d)
      objects.json           per object: views, points, centroid, boxes, mesh file (or null and why)
      graphs/stageS.graphml  one GraphML per stage S = 0, 1, ... (the graph with that stage's edges)
      graphs/objects.graphml the objects graph: mask fragments, the steps after the last contraction
                             as edges and cuts, each node's object (Result.objects_graph)
      points/VIEW.npz        the point maps the run estimated (a lifter of lifted.lifters: sfm,
                             dust3r, da3), so that `graphseg eval` scores the run's own points
      result.npz             the native result file (Result.load)
      config.yaml            the configuration used
      run.json               scene path, views (and their file names), backends, timings
      metrics.json           when the scene has ground truth
      report.html            overlays + interactive 3D view, works offline

Safety rules (:func:`check_target`, :func:`atomic_folder`, :func:`atomic_file`).
A user's files are never deleted or overwritten:

* graphseg writes only to a path that does not exist, or to an earlier graphseg
  output of the same kind, recognised by its marker file ``.graphseg-output``
  (JSON: ``{"kind": "run" | "synth" | "demo" | "export" | "batch" | "store", "version": 1,
  "graphseg": VERSION, "dirs": [...], "files": {PATH: [SIZE, MTIME_NS], ...}}``;
  ``dirs`` and ``files``, the manifest of every folder and file graphseg wrote
  there, are written when the folder is complete; markers without them, from
  older versions, are still read). Anything else is refused unless
  ``overwrite=True``.
* An existing target is deleted only when it is a graphseg output of the same
  kind whose contents are exactly its manifest (the same folders and files, of
  the same sizes and modification times). Anything else that is replaced (a
  folder that is no graphseg output, or of another kind, given
  ``overwrite=True``; a graphseg output with a file added, changed or removed;
  an older output without a manifest; an existing file given to
  :func:`atomic_file`, unless it holds exactly the new bytes) is moved aside,
  by one :func:`os.replace`, to the new sibling ``NAME.graphseg-backup-N``
  (the first free ``N``; a file stays a file), and the ``moved`` list passed
  to :func:`atomic_folder` / :func:`atomic_file` gets ``(old, backup)``, for
  one line of :func:`backup_message`. :func:`clean_stale` never removes a
  backup.
* Even with ``overwrite=True``, a target that is, contains or lies inside an
  input of the command (or contains the working folder) is refused; so is a
  symbolic link at the target path.
* Folders are built in a temporary sibling ``.NAME.graphseg-tmp-PID-XXXX`` (with
  the marker written first) and renamed into place; single files are written
  inside such a marked sibling folder and moved with :func:`os.replace`. An
  existing target is moved (aside or away) only after the new output is
  complete. Stale temporary siblings of dead processes that carry the marker
  are removed by the next write to the same target.
* Interrupted (SIGINT, or SIGTERM in the command line) or failed writes remove
  their temporary sibling and any parent folders they created, and leave an
  existing target where it was.
* Created folders follow the umask.

Examples
--------
>>> import tempfile, os
>>> d = tempfile.mkdtemp()
>>> with atomic_folder(os.path.join(d, "out"), "run") as tmp:
...     _ = (tmp / "a.txt").write_text("hi")
>>> sorted(os.listdir(os.path.join(d, "out")))
['.graphseg-output', 'a.txt']
>>> read_marker(os.path.join(d, "out"))["kind"]
'run'
"""

from __future__ import annotations

import contextlib
import filecmp
import json
import os
import re
import shutil
import tempfile
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .graphs import write_graphml
from .io.files import read_json
from .io.images import unique_file_names, write_png
from .io.ply import write_ply
from .report import overlay, palette, render_report
from .result import Result
from .scene import Scene, SceneError

__all__ = [
    "write_output",
    "read_output",
    "write_object_clouds",
    "fill_output",
    "stage_graph_files",
    "check_target",
    "atomic_folder",
    "atomic_file",
    "read_marker",
    "clean_stale",
    "pid_alive",
    "backup_message",
    "BACKUP",
    "unique_file_names",
    "MARKER",
    "KINDS",
    "RESULT_FILE",
]

RESULT_FILE = "result.npz"
#: Name of the marker file inside every folder graphseg writes.
MARKER = ".graphseg-output"
#: Kinds of output folder.
KINDS = ("run", "synth", "demo", "export", "batch", "store")
MARKER_VERSION = 1
_TMP = ".graphseg-tmp-"
_OLD = ".graphseg-old-"
#: Infix of the sibling that keeps a replaced target: ``NAME.graphseg-backup-N``.
BACKUP = ".graphseg-backup-"
#: Largest marker file read (a run output's manifest lists thousands of files).
MARKER_MAX_BYTES = 8 * 2**20


# ----------------------------------------------------------------------------- marker, targets
def read_marker(path: str | os.PathLike[str]) -> dict[str, Any] | None:
    """The marker of a graphseg output folder, or None when ``path`` has no valid marker.

    Markers of older versions (no manifest) are read too; a marker larger than
    :data:`MARKER_MAX_BYTES` is not.
    """
    p = Path(path) / MARKER
    try:
        if p.is_symlink() or not p.is_file():
            return None
        doc = read_json(p, field="marker", max_bytes=MARKER_MAX_BYTES)
    except (OSError, SceneError):
        return None
    if not isinstance(doc, dict) or doc.get("kind") not in KINDS:
        return None
    return doc


def write_marker(folder: str | os.PathLike[str], kind: str, *, manifest: bool = False) -> None:
    """Mark ``folder`` as a graphseg output of ``kind``.

    Without ``manifest`` (folders filled incrementally, like a batch) the
    folder is never deleted when replaced, only kept as a backup. With
    ``manifest``, call it when the folder is complete (a nested output built
    inside an :func:`atomic_folder`): the marker then lists the folder's files.
    """
    _write_marker(Path(folder), kind, manifest=manifest)


def _write_marker(folder: Path, kind: str, *, manifest: bool = False) -> None:
    """Write the marker of ``folder``; with ``manifest``, list the folder's current contents in it.

    The marker is written to a temporary name and renamed, so it is never half
    written. A folder whose contents cannot be listed (a symbolic link or a
    special file in it) or whose manifest would exceed :data:`MARKER_MAX_BYTES`
    gets a marker without a manifest: it will be kept as a backup, not
    deleted, when replaced.
    """
    from ._version import __version__

    doc: dict[str, Any] = {"kind": kind, "version": MARKER_VERSION, "graphseg": __version__}
    text = json.dumps(doc)
    if manifest:
        listed = _scan(folder)
        if listed is not None:
            doc["dirs"], doc["files"] = listed[1], {k: list(v) for k, v in sorted(listed[0].items())}
            full = json.dumps(doc, separators=(",", ":"))
            if len(full) <= MARKER_MAX_BYTES:
                text = full
    new = folder / f"{MARKER}.new"
    new.write_text(text, encoding="utf-8")
    os.replace(new, folder / MARKER)


def _scan(root: Path, limit: int | None = None) -> tuple[dict[str, tuple[int, int]], list[str]] | None:
    """The files ``{relative path: (size, mtime_ns)}`` and folders (sorted) under ``root``.

    The top-level marker is left out. None when something else than plain
    files and folders is found (a symbolic link, a socket...), when ``root``
    cannot be read, or when it holds more than ``limit`` entries.
    """
    files: dict[str, tuple[int, int]] = {}
    dirs: list[str] = []
    stack = [(root, "")]
    try:
        while stack:
            folder, rel = stack.pop()
            with os.scandir(folder) as it:
                for entry in it:
                    name = rel + entry.name
                    if not rel and entry.name == MARKER:
                        continue
                    if entry.is_symlink():
                        return None
                    if entry.is_dir(follow_symlinks=False):
                        dirs.append(name)
                        stack.append((Path(entry.path), name + "/"))
                    elif entry.is_file(follow_symlinks=False):
                        st = entry.stat(follow_symlinks=False)
                        files[name] = (st.st_size, st.st_mtime_ns)
                    else:
                        return None
                    if limit is not None and len(files) + len(dirs) > limit:
                        return None
    except OSError:
        return None
    return files, sorted(dirs)


def _intact(path: Path, kind: str) -> bool:
    """Whether ``path`` is a graphseg output of ``kind`` holding exactly what its manifest lists.

    Only such a folder may be deleted when it is replaced: it holds nothing but
    what graphseg wrote.
    """
    if path.is_symlink() or not path.is_dir():
        return False
    marker = read_marker(path)
    if marker is None or marker.get("kind") != kind:
        return False
    files, dirs = marker.get("files"), marker.get("dirs")
    if not isinstance(files, dict) or not isinstance(dirs, list):
        return False
    listed = _scan(path, limit=len(files) + len(dirs))
    if listed is None:
        return False
    try:
        want = {str(k): (int(v[0]), int(v[1])) for k, v in files.items()}
    except (TypeError, ValueError, IndexError):
        return False
    return listed[0] == want and listed[1] == sorted(str(d) for d in dirs)


def _reserve_backup(dest: Path, as_folder: bool) -> tuple[Path, tuple[int, int]]:
    """Create an empty placeholder ``NAME.graphseg-backup-N`` (first free N) for ``dest`` to be renamed onto.

    Created exclusively (``mkdir`` / ``O_EXCL``), so an existing path is never
    taken; renaming a folder onto the empty placeholder folder (or a file onto
    the empty placeholder file) is one atomic :func:`os.replace`. Returns the
    placeholder and its identity (device, inode), for :func:`_release`.
    """
    for n in range(1, 100_000):
        cand = dest.with_name(f"{dest.name}{BACKUP}{n}")
        try:
            if as_folder:
                os.mkdir(cand, 0o700)
            else:
                os.close(os.open(cand, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
        except FileExistsError:
            continue
        st = os.lstat(cand)
        return cand, (st.st_dev, st.st_ino)
    raise OSError(f"{dest}: no free backup name {dest.name}{BACKUP}N")


def _is_placeholder(path: Path, ident: tuple[int, int]) -> bool:
    try:
        st = os.lstat(path)
    except OSError:
        return False
    return (st.st_dev, st.st_ino) == ident


def _release(placeholder: Path, ident: tuple[int, int]) -> None:
    """Remove a backup placeholder that was not used (only if it still is the very one made)."""
    with contextlib.suppress(OSError):
        if _is_placeholder(placeholder, ident):
            if _is_folder(placeholder):
                placeholder.rmdir()
            else:
                placeholder.unlink()


def _is_folder(p: Path) -> bool:
    return p.is_dir() and not p.is_symlink()


def _put_in_place(new: Path, dest: Path, disposable: Any, kind: str) -> Path | None:
    """Rename the complete ``new`` to ``dest``; return where an existing ``dest`` was kept, if anywhere.

    An existing ``dest`` for which ``disposable(dest)`` holds is deleted (it is
    first renamed into a marked ``.NAME.graphseg-old-PID-XXXX`` sibling and
    checked again there, so that nothing added meanwhile is lost); any other
    is renamed to a new ``NAME.graphseg-backup-N``. If renaming ``new`` fails
    or is interrupted, the old ``dest`` is put back.
    """
    if not os.path.lexists(dest):
        os.replace(new, dest)
        return None
    if disposable(dest):
        old = Path(tempfile.mkdtemp(prefix=f".{dest.name}{_OLD}{os.getpid()}-", dir=dest.parent))
        _write_marker(old, kind)
        parked = old / "x"
        try:
            os.replace(dest, parked)
            os.replace(new, dest)
        except BaseException:
            if os.path.lexists(parked) and not os.path.lexists(dest):
                os.replace(parked, dest)  # put the old one back
            if not os.path.lexists(parked):
                shutil.rmtree(old, ignore_errors=True)
            raise
        if not disposable(parked):  # changed between the check and the move: keep it
            backup, _ = _reserve_backup(dest, _is_folder(parked))
            os.replace(parked, backup)
            shutil.rmtree(old, ignore_errors=True)
            return backup
        shutil.rmtree(old, ignore_errors=True)
        return None
    backup, ident = _reserve_backup(dest, _is_folder(dest))
    try:
        os.replace(dest, backup)
        os.replace(new, dest)
    except BaseException:
        if not os.path.lexists(dest) and not _is_placeholder(backup, ident):
            os.replace(backup, dest)  # moved aside, the new one not in place: put the old one back
        else:
            _release(backup, ident)
        raise
    return backup


def backup_message(old: str | os.PathLike[str], backup: str | os.PathLike[str], *, shown: str | os.PathLike[str] | None = None, kind: str | None = None) -> str:
    """The one line telling where an existing target was kept (an entry of the ``moved`` list).

    ``shown`` is the target as the user wrote it (the line then names both
    paths that way); ``kind`` (for folders) adds why it was not deleted.

    Examples
    --------
    >>> backup_message("/tmp/x/out", "/tmp/x/out.graphseg-backup-1", shown="out", kind="run")
    'kept your existing out as out.graphseg-backup-1 (it was not a complete graphseg run output)'
    >>> backup_message("/tmp/x/g.graphml", "/tmp/x/g.graphml.graphseg-backup-2")
    'kept your existing /tmp/x/g.graphml as /tmp/x/g.graphml.graphseg-backup-2'
    """
    a, b = Path(old), Path(backup)
    if shown is not None and Path(shown).name == a.name:
        a, b = Path(shown), Path(shown).with_name(b.name)
    why = f" (it was not a complete graphseg {kind} output)" if kind else ""
    return f"kept your existing {a} as {b}{why}"


def _related(a: Path, b: Path) -> bool:
    """Whether resolved paths ``a`` and ``b`` are equal or one lies inside the other."""
    return a == b or a.is_relative_to(b) or b.is_relative_to(a)


def check_target(
    out: str | os.PathLike[str],
    kind: str,
    *,
    inputs: Sequence[str | os.PathLike[str]] = (),
    overwrite: bool = False,
    folder: bool = True,
) -> Path:
    """Check that graphseg may write ``out``; return it as an absolute path.

    Parameters
    ----------
    out : path-like
        The folder (``folder=True``) or file to write.
    kind : {"run", "synth", "demo", "export"}
        An existing folder is replaced only if its marker names this kind (or
        with ``overwrite``).
    inputs : sequence of path-like
        Files and folders the command reads: the target may not be, contain or
        lie inside any of them, even with ``overwrite``.
    overwrite : bool
        Allow replacing an existing folder or file that is no graphseg output
        of ``kind`` (it is then kept as ``NAME.graphseg-backup-N``, see
        :func:`atomic_folder`).
    folder : bool
        Whether the target is a folder (else a single file).

    Raises
    ------
    SceneError
        ``OUT: output: ...`` naming what is wrong; nothing has been touched.

    Examples
    --------
    >>> import tempfile, os
    >>> d = tempfile.mkdtemp()
    >>> check_target(os.path.join(d, "new"), "run").name
    'new'
    >>> check_target(d, "run")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    graphseg.scene.SceneError: ...: output: exists and is not a graphseg run output (pass --overwrite to replace it)
    """
    where = str(out)
    p = Path(os.path.abspath(out))
    if p.is_symlink():
        raise SceneError("is a symbolic link; refusing to write through it", where=where, field="output")
    real = p.resolve()
    if real.parent == real or real == Path.home().resolve():
        raise SceneError("refusing to write to the root or home folder", where=where, field="output")
    if Path.cwd().resolve().is_relative_to(real):
        raise SceneError("is or contains the working folder", where=where, field="output")
    for inp in inputs:
        ip = Path(os.path.abspath(inp))
        if _related(real, ip.resolve()) or _related(p, ip):
            raise SceneError(f"is, contains or lies inside an input of this command ({inp})", where=where, field="output")
    probe = real.parent
    while not probe.exists():
        probe = probe.parent
    if not probe.is_dir():
        raise SceneError(f"the parent path {probe} is not a folder", where=where, field="output")
    if p.exists():
        if folder:
            if not p.is_dir():
                raise SceneError("exists and is not a folder", where=where, field="output")
            marker = read_marker(p)
            if not overwrite and (marker is None or marker.get("kind") != kind):
                what = f"a graphseg {marker['kind']} output, not {kind}" if marker else f"not a graphseg {kind} output"
                raise SceneError(f"exists and is {what} (pass --overwrite to replace it)", where=where, field="output")
        else:
            if p.is_dir():
                raise SceneError("exists and is a folder", where=where, field="output")
            if not overwrite:
                raise SceneError("exists (pass --overwrite to replace it)", where=where, field="output")
    return p


def pid_alive(pid: int) -> bool:
    """Whether process ``pid`` may still run: the owner test of a temporary file named after its writer.

    True for this process and for any process that exists (also one of
    another user); False only when there is no such process.

    Examples
    --------
    >>> pid_alive(os.getpid())
    True
    """
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True
    return True


def clean_stale(out: str | os.PathLike[str]) -> list[Path]:
    """Remove temporary siblings of ``out`` left by killed graphseg runs; return them.

    Only folders named ``.NAME.graphseg-tmp-PID-*`` or ``.NAME.graphseg-old-PID-*``
    that hold a graphseg marker and whose process ``PID`` is gone are removed;
    never a backup ``NAME.graphseg-backup-N``, nor anything else.
    """
    p = Path(os.path.abspath(out))
    if not p.parent.is_dir():
        return []
    pat = re.compile(re.escape(f".{p.name}") + r"\.graphseg-(?:tmp|old)-(\d+)-[A-Za-z0-9_]+$")
    removed = []
    for q in p.parent.iterdir():
        m = pat.match(q.name)
        if not m or q.is_symlink() or not q.is_dir() or read_marker(q) is None or pid_alive(int(m.group(1))):
            continue
        shutil.rmtree(q, ignore_errors=True)
        removed.append(q)
    return removed


def _make_parents(path: Path) -> list[Path]:
    """Create the missing parents of ``path``; return those created, deepest first."""
    created = []
    probe = path.parent
    while not probe.exists():
        created.append(probe)
        probe = probe.parent
    path.parent.mkdir(parents=True, exist_ok=True)
    return created


def _remove_empty(folders: list[Path]) -> None:
    for f in folders:
        try:
            f.rmdir()
        except OSError:
            break


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def _marked_tmp(dest: Path, kind: str) -> Iterator[Path]:
    """A marked temporary sibling folder of ``dest`` for the body to fill.

    It is removed afterwards if it still exists (the body may have renamed it
    into place); if the body fails, the parent folders made for it go too.
    """
    created = _make_parents(dest)
    clean_stale(dest)
    ok = False
    try:
        tmp = Path(tempfile.mkdtemp(prefix=f".{dest.name}{_TMP}{os.getpid()}-", dir=dest.parent))
    except BaseException:
        _remove_empty(created)
        raise
    try:
        _write_marker(tmp, kind)
        yield tmp
        ok = True
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
        if not ok:
            _remove_empty(created)


@contextlib.contextmanager
def atomic_folder(out: str | os.PathLike[str], kind: str, *, moved: list[tuple[Path, Path]] | None = None) -> Iterator[Path]:
    """Build a folder in a temporary sibling and rename it to ``out`` on success.

    The caller has checked ``out`` with :func:`check_target`. The temporary
    folder holds the marker from the start; when the body is done the marker
    gets the manifest of the folder. An existing ``out`` is replaced only
    after the new folder is complete: deleted if it is a graphseg output of
    ``kind`` holding exactly its manifest, else moved aside to
    ``NAME.graphseg-backup-N`` and ``(out, backup)`` appended to ``moved``
    (absolute paths). On any exception (including KeyboardInterrupt) the
    temporary folder and any parent folders it created are removed, and
    ``out`` is unchanged.

    Examples
    --------
    >>> import tempfile, os
    >>> d = tempfile.mkdtemp()
    >>> os.mkdir(os.path.join(d, "out"))
    >>> _ = Path(d, "out", "notes.txt").write_text("mine")
    >>> moved = []
    >>> with atomic_folder(os.path.join(d, "out"), "run", moved=moved) as tmp:
    ...     _ = (tmp / "a.txt").write_text("hi")
    >>> [(a.name, b.name) for a, b in moved]
    [('out', 'out.graphseg-backup-1')]
    >>> sorted(os.listdir(os.path.join(d, "out.graphseg-backup-1")))
    ['notes.txt']
    """
    dest = Path(os.path.abspath(out))
    with _marked_tmp(dest, kind) as tmp:
        os.chmod(tmp, 0o777 & ~_umask())
        yield tmp
        _write_marker(tmp, kind, manifest=True)
        kept = _put_in_place(tmp, dest, lambda p: _intact(p, kind), kind)
        if kept is not None and moved is not None:
            moved.append((dest, kept))


def _same_file(a: Path, b: Path) -> bool:
    """Whether ``a`` is a plain file with exactly the bytes of the plain file ``b``."""
    try:
        return not a.is_symlink() and a.is_file() and b.is_file() and filecmp.cmp(a, b, shallow=False)
    except OSError:
        return False


@contextlib.contextmanager
def atomic_file(path: str | os.PathLike[str], *, moved: list[tuple[Path, Path]] | None = None) -> Iterator[Path]:
    """Yield a temporary path to write; it replaces ``path`` on success, else is removed.

    The temporary file lives in a marked sibling folder
    ``.NAME.graphseg-tmp-PID-XXXX/`` so that :func:`clean_stale` can remove it
    after a killed run, like the folders of :func:`atomic_folder`. An existing
    ``path`` (which :func:`check_target` lets through only with ``overwrite``)
    is moved aside to ``NAME.graphseg-backup-N`` and ``(path, backup)``
    appended to ``moved``, unless it holds exactly the bytes just written.
    """
    dest = Path(os.path.abspath(path))
    with _marked_tmp(dest, "export") as box:
        tmp = box / dest.name
        yield tmp
        if tmp.exists():
            os.chmod(tmp, 0o666 & ~_umask())

        def disposable(p: Path) -> bool:  # the old file holds exactly the new bytes: nothing is lost
            return _same_file(p, tmp if p == dest else dest)

        kept = _put_in_place(tmp, dest, disposable, "export")
        if kept is not None and moved is not None:
            moved.append((dest, kept))


# ----------------------------------------------------------------------------- writing
def write_object_clouds(result: Result, folder: str | os.PathLike[str]) -> int:
    """Write one PLY per object with points (``001.ply``, ...) into ``folder``; returns how many.

    Objects without any point (possible with a large ``output.stride``) get no
    file, so every PLY written has at least one vertex.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    n = 0
    for k in range(1, result.num_objects + 1):
        pts, cols = result.object_cloud(k)
        if len(pts) == 0:
            continue
        write_ply(folder / f"{k:03d}.ply", pts, cols)
        n += 1
    return n


def write_output(
    out: str | os.PathLike[str],
    result: Result,
    scene: Scene,
    *,
    metrics: dict[str, Any] | None = None,
    run_info: dict[str, Any] | None = None,
    inputs: Sequence[str | os.PathLike[str]] = (),
    overwrite: bool = False,
    kind: str = "run",
    moved: list[tuple[Path, Path]] | None = None,
) -> Path:
    """Write every output file for ``result`` into ``out`` (see the module docstring).

    ``out`` must be new or an earlier graphseg output of ``kind`` (or
    ``overwrite``); see :func:`check_target` for ``inputs``. An existing
    ``out`` that is not exactly an earlier graphseg output of ``kind`` is kept
    as ``OUT.graphseg-backup-N``, and ``(out, backup)`` appended to ``moved``
    (see :func:`atomic_folder`).

    Raises
    ------
    SceneError
        When the target is refused.
    PermissionError, OSError
        When the parent folder cannot be written; nothing is left behind.
    """
    dest = check_target(out, kind, inputs=inputs, overwrite=overwrite)
    with atomic_folder(dest, kind, moved=moved) as tmp:
        fill_output(tmp, result, scene, metrics=metrics, run_info=run_info)
    return dest


def fill_output(
    tmp: Path,
    result: Result,
    scene: Scene,
    *,
    metrics: dict[str, Any] | None = None,
    run_info: dict[str, Any] | None = None,
) -> None:
    """Write the files of an output folder into the existing, empty folder ``tmp`` (no marker, no checks)."""
    colors = palette(result.num_objects)
    (tmp / "labels").mkdir()
    (tmp / "overlays").mkdir()
    (tmp / "graphs").mkdir()
    overlays = []
    files = unique_file_names(result.view_names)
    for v, (view, lab) in enumerate(zip(scene.views, result.labels)):
        write_png(tmp / "labels" / f"{files[v]}.png", lab.astype(np.uint16))
        ov = overlay(view.rgb, lab, colors)
        write_png(tmp / "overlays" / f"{files[v]}.png", ov)
        overlays.append(ov)
    write_object_clouds(result, tmp / "objects")
    from .objects3d import write_objects

    write_objects(tmp, scene, result)
    for s, g in enumerate(result.graphs):
        write_graphml(g, tmp / "graphs" / f"stage{s}.graphml")
    if result.objects_graph is not None:
        write_graphml(result.objects_graph, tmp / "graphs" / "objects.graphml")
    result.save(tmp / RESULT_FILE)
    if scene.meta.get("lifter") in result.config.lifted.lifters and all(v.points is not None for v in scene.views):
        from .io.precomputed import write_point_maps

        write_point_maps(tmp / "points", scene)  # estimated points: eval reads them instead of lifting again
    result.config.save(tmp / "config.yaml")
    info = dict(run_info or {})
    info.setdefault("views", result.view_names)
    info["view_files"] = files
    info.setdefault("num_objects", result.num_objects)
    info["num_stages"] = len(result.graphs)
    info.setdefault("pipeline", result.info.get("pipeline"))
    if result.info.get("warnings"):
        info["warnings"] = result.info["warnings"]
    _write_json(tmp / "run.json", info)
    if metrics is not None:
        _write_json(tmp / "metrics.json", metrics)
    summary = {
        "scene": info.get("scene", scene.name),
        "views": len(result.view_names),
        "objects": result.num_objects,
        "steps": " -> ".join(s if isinstance(s, str) else "+".join(s) for s in result.config.step_names()),
    }
    refiners = result.info.get("refiners") or {}
    if refiners.get("pixels"):  # the pixels the pixel refiners moved: the only ones the objects graph does not explain
        per = ", ".join(f"{k} {v}" for k, v in refiners.items() if k not in ("pixels", "fraction"))
        summary["pixel refiners"] = f"{refiners['pixels']} pixels moved ({100 * refiners.get('fraction', 0.0):.2f}%: {per})"
    if result.info.get("pipeline"):
        p = result.info["pipeline"]
        summary["backends"] = f"segmenter={p.get('segmenter')}, matcher={p.get('matcher')}, lifter={p.get('lifter')}"
    for w in result.info.get("warnings", []):
        summary["warning"] = w
    page = render_report(
        title=f"graphseg: {scene.name}",
        view_names=result.view_names,
        overlays=overlays,
        points=result.object_points.points,
        point_colors=colors[result.object_points.node_of_point() + 1],
        metrics=metrics,
        audit=(metrics or {}).get("audit"),
        summary=summary,
    )
    (tmp / "report.html").write_text(page, encoding="utf-8", errors="replace")


def _write_json(path: Path, doc: Any) -> None:
    path.write_text(json.dumps(doc, indent=2, default=str, ensure_ascii=True), encoding="utf-8")


def stage_graph_files(out: str | os.PathLike[str]) -> list[Path]:
    """The per-stage GraphML files of an output folder, in stage order (old layouts too)."""
    root = Path(out)
    new = sorted((root / "graphs").glob("stage*.graphml"), key=lambda p: int(re.sub(r"\D", "", p.stem) or 0))
    if new:
        return new
    return [p for p in (root / "graph_2d.graphml", root / "graph_3d.graphml") if p.is_file()]


def read_output(out: str | os.PathLike[str]) -> tuple[Result, dict[str, Any]]:
    """The :class:`Result` and ``run.json`` of an output folder.

    Raises
    ------
    SceneError
        When ``out`` is no graphseg output folder or a file in it is malformed.
    """
    root = Path(out)
    if not (root / RESULT_FILE).is_file():
        raise SceneError(f"not a graphseg output folder (no {RESULT_FILE})", where=str(root), field="path")
    info: dict[str, Any] = {}
    rj = root / "run.json"
    if rj.exists():
        info = read_json(rj, field="run.json")
        if not isinstance(info, dict):
            raise SceneError("expected a JSON object", where=str(rj), field="run.json")
        if not isinstance(info.get("scene") or "", str):
            raise SceneError(f"expected the scene's path (got {type(info['scene']).__name__})", where=str(rj), field="scene")
    return Result.load(root / RESULT_FILE), info
