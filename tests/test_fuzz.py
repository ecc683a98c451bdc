"""Seeded fuzz test of every reader: damaged scene folders, precomputed inputs, configs, outputs and stores.

A small valid scene is written, run once (an output folder with ``result.npz``),
added to a store (``graphseg add``), and its precomputed inputs (masks, matches,
point maps) and its configuration are saved. Each group of cases works on one
copy of one of these trees: a case damages one file with a mutation drawn from
``numpy.random.default_rng([SEED, group, case])`` (truncation, zeroed or flipped
bytes, damaged zip members and ``.npy`` headers, deleted entries, wrong dtypes
and shapes, garbage or deeply nested JSON/YAML, empty files, ...), runs the
commands that read it in-process (:func:`graphseg.cli.main`), and restores the
file. The first cases of a group try every (file, mutation) pair once.

Every command must exit 0, or exit 2 with exactly one stderr line
``graphseg: error: ...``; none may exit 1 (internal error) or print a
traceback. For byte-level damage of an ``.npz`` or PNG the line must also name
the damaged file, and for damage inside one zip member that entry. No command
may write into its input. A failure is reported as ``GROUP #CASE: FILE: MUTATION``;
:func:`make_case` rebuilds one case alone, for example
``make_case("output", 38, BASE, Path("/tmp/c"))`` with ``BASE`` the fixture's folder.
"""

from __future__ import annotations

import contextlib
import fnmatch
import io
import json
import shutil
import struct
import time
import warnings
import zipfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
import yaml

from graphseg.cli import main
from graphseg.io import write_scene_folder
from graphseg.io.precomputed import write_masks, write_matches_folder, write_point_maps
from graphseg.scene import Scene, backproject
from graphseg.testing.scenes import TWO_BOXES, box_scene, exact_matches

SEED = 52
SHAPE = (32, 40)

#: group -> (tree, files with their weights, number of cases)
GROUPS: dict[str, tuple[str, dict[str, int], int]] = {
    "scene": ("scene", {"scene.json": 3, "rgb/*.png": 1, "depth/*.png": 1, "instances/*.png": 1}, 80),
    "inputs": ("inputs", {"masks/*.npz": 2, "masks/*.png": 1, "matches/*.npz": 2, "points/*.npz": 2}, 60),
    "config": ("cfg", {"config.yaml": 1}, 40),
    "output": ("out", {"result.npz": 6, "run.json": 1, "metrics.json": 1}, 120),
    "store": ("store", {"store.json": 1, "generations/000001.state.json": 2, "generations/000001.result.npz": 3, "views/*.npz": 3, "pairs/*.npz": 1}, 100),
}


# ----------------------------------------------------------------------------- the valid inputs
@pytest.fixture(scope="module")
def base(tmp_path_factory):
    root = tmp_path_factory.mktemp("fuzz-base")
    scene = box_scene(TWO_BOXES, views=2, shape=SHAPE)
    write_scene_folder(scene, root / "scene")
    _run(["run", root / "scene", "-o", root / "out", "--quiet"], expect=0)
    _run(["add", root / "store", root / "scene", "--quiet"], expect=0)
    inputs = root / "inputs"
    v0, v1 = scene.views
    write_masks(inputs / "masks", v0.name, [v0.instances == k for k in np.unique(v0.instances) if k])
    write_masks(inputs / "masks", v1.name, v1.instances.astype(np.uint16))
    write_matches_folder(inputs / "matches", scene, exact_matches(scene, num_matches=60, rng=0))
    lifted = Scene([v.replace(points=backproject(v.depth, v.K, v.cam_to_world)) for v in scene.views], scene.objects, scene.name)
    write_point_maps(inputs / "points", lifted)
    (root / "cfg").mkdir()
    shutil.copy(root / "out" / "config.yaml", root / "cfg" / "config.yaml")
    for group in GROUPS:  # every command reads the valid inputs cleanly
        for argv in commands(group, root, root):
            _run(argv, expect=0)
        shutil.rmtree(root / "new", ignore_errors=True)
    return root


def commands(group: str, ws: Path, base: Path) -> list[list]:
    """The commands that read the tree of ``group`` (copied into ``ws``)."""
    new = ["-o", ws / "new", "--quiet"]
    if group == "scene":
        return [["info", ws / "scene"], ["run", ws / "scene", *new]]
    if group == "inputs":
        i = ws / "inputs"
        return [["run", base / "scene", "--masks", i / "masks", "--matches", i / "matches", "--points", i / "points", *new]]
    if group == "config":
        return [["run", base / "scene", "--config", ws / "cfg" / "config.yaml", *new]]
    if group == "output":
        return [["info", ws / "out"], ["eval", ws / "out"]]
    return [["info", ws / "store"], ["eval", ws / "store"], ["run", ws / "store", *new]]


def _run(argv: list, *, expect: int | None = None) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main([str(a) for a in argv])
    if expect is not None:
        assert code == expect, (argv, err.getvalue())
    return code, err.getvalue()


# ----------------------------------------------------------------------------- mutations
# Each takes (path, rng), changes the file in place and returns a description
# (and the zip entry it damaged, for damage inside one member).
def _bytes(path: Path, data: bytes) -> None:
    path.write_bytes(data)


def m_truncate(path: Path, rng) -> str:
    data = path.read_bytes()
    n = int(rng.integers(0, max(len(data) - 1, 1)))
    _bytes(path, data[:n])
    return f"truncated to {n} of {len(data)} bytes"


def m_zero(path: Path, rng) -> str:
    data = bytearray(path.read_bytes())
    k = int(rng.choice([1, 4, 16, 60, 256]))
    a = int(rng.integers(0, max(len(data) - k, 1)))
    data[a : a + k] = bytes(len(data[a : a + k]))
    _bytes(path, bytes(data))
    return f"zeroed bytes {a}..{a + k}"


def m_flip(path: Path, rng) -> str:
    data = bytearray(path.read_bytes())
    k = int(rng.integers(1, 9))
    at = sorted(int(x) for x in rng.integers(0, len(data), k))
    for a in at:
        data[a] ^= int(rng.integers(1, 256))
    _bytes(path, bytes(data))
    return f"flipped bytes at {at}"


def m_empty(path: Path, rng) -> str:
    _bytes(path, b"")
    return "emptied"


def m_garbage(path: Path, rng) -> str:
    n = int(rng.choice([1, 7, 100, 4000]))
    head = path.read_bytes()[: int(rng.choice([0, 4, 30]))]  # sometimes keep the magic bytes
    _bytes(path, head + rng.integers(0, 256, n, dtype=np.uint8).tobytes())
    return f"replaced by {len(head)} original and {n} random bytes"


# -- zip members
def _members(path: Path) -> dict[str, bytes]:
    with zipfile.ZipFile(path) as z:
        return {i.filename: z.read(i.filename) for i in z.infolist()}


def _write_members(path: Path, members: dict[str, bytes]) -> None:
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for name, data in members.items():
            z.writestr(name, data)


def _pick_member(members: dict[str, bytes], rng) -> str:
    names = sorted(members)
    return names[int(rng.integers(len(names)))]


def m_member_bytes(path: Path, rng) -> tuple[str, str]:
    """Damage the compressed bytes of one member (the zip directory stays intact)."""
    data = bytearray(path.read_bytes())
    with zipfile.ZipFile(io.BytesIO(bytes(data))) as z:
        infos = [i for i in z.infolist() if i.compress_size > 0]
    info = infos[int(rng.integers(len(infos)))]
    n, m = struct.unpack("<HH", data[info.header_offset + 26 : info.header_offset + 30])
    start = info.header_offset + 30 + n + m
    k = min(int(rng.choice([1, 8, 60])), info.compress_size)
    a = start + int(rng.integers(0, info.compress_size - k + 1))
    if rng.random() < 0.5:
        data[a : a + k] = bytes(k)
        how = "zeroed"
    else:
        for j in range(a, a + k):
            data[j] ^= 0xA5
        how = "flipped"
    _bytes(path, bytes(data))
    return f"{how} {k} compressed bytes of member {info.filename}", info.filename[:-4]


_HEADER_CHARS = list("(){}[],:'\" \n\t0123456789<>|fiuUbO.-_xyz\\#")


def m_npy_header(path: Path, rng) -> tuple[str, str]:
    """Damage the .npy header of one member; the zip itself stays valid."""
    members = _members(path)
    name = _pick_member(members, rng)
    raw = bytearray(members[name])
    hlen = struct.unpack("<H", raw[8:10])[0] if raw[6] == 1 else struct.unpack("<I", raw[8:12])[0]
    h0 = 10 if raw[6] == 1 else 12
    how = int(rng.integers(5))
    if how == 0:  # characters of the header dict replaced
        for a in rng.integers(h0, h0 + hlen, int(rng.integers(1, 4))):
            raw[int(a)] = ord(_HEADER_CHARS[int(rng.integers(len(_HEADER_CHARS)))])
        what = "characters replaced"
    elif how == 1:  # the dict cut short (unbalanced brackets), padded back to its length
        cut = int(rng.integers(1, hlen - 1))
        raw[h0 + cut : h0 + hlen - 1] = b" " * (hlen - 1 - cut)
        what = f"dict cut at {cut}"
    elif how == 2:  # the header length field
        raw[8:10] = struct.pack("<H", int(rng.integers(0, 2**16)))
        what = "length field changed"
    elif how == 3:  # magic or version
        a = int(rng.integers(0, 8))
        raw[a] ^= int(rng.integers(1, 256))
        what = f"magic/version byte {a} changed"
    else:  # the whole header dict replaced by text
        text = rng.choice(["{", "(", "{'descr': '<i8', 'fortran_order': False, 'shape': (2, ", "[1, 2", "'", "{'descr': 'O'}", "1 +", "\\"])
        body = str(text).encode().ljust(hlen - 1) + b"\n"
        raw[h0 : h0 + hlen] = body[:hlen]
        what = f"dict replaced by {str(text)!r}"
    members[name] = bytes(raw)
    _write_members(path, members)
    return f"npy header of {name}: {what}", name[:-4]


def m_npy_body(path: Path, rng) -> tuple[str, str]:
    members = _members(path)
    name = _pick_member(members, rng)
    raw = members[name]
    if rng.random() < 0.6:
        keep = int(rng.integers(0, len(raw)))
        members[name] = raw[:keep]
        what = f"cut to {keep} of {len(raw)} bytes"
    else:
        members[name] = raw + b"\x01" * int(rng.integers(1, 100))
        what = "extra bytes"
    _write_members(path, members)
    return f"npy data of {name}: {what}", name[:-4]


def m_delete_member(path: Path, rng) -> str:
    members = _members(path)
    name = _pick_member(members, rng)
    del members[name]
    _write_members(path, members)
    return f"member {name} deleted"


def _other_array(arr: np.ndarray, rng) -> tuple[np.ndarray, str]:
    how = int(rng.integers(8))
    if how == 0:
        kinds = ("<U1", "S8", "<U300") if arr.dtype.kind == "U" else ("float64", "float32", "int8", "uint8", "int64", "bool", "complex64", "<U4")
        dt = [d for d in kinds if np.dtype(d) != arr.dtype]
        d = dt[int(rng.integers(len(dt)))]
        return arr.astype(d), f"as {d}"
    if how == 1:
        return arr.reshape(-1), "raveled"
    if how == 2:
        return arr[None], "extra axis"
    if how == 3:
        return arr[: len(arr) // 2] if arr.ndim else arr[None][:0], "first half"
    if how == 4:
        return np.zeros((0,) * max(arr.ndim, 1), arr.dtype), "empty"
    if how == 5:
        return np.asarray(arr.flat[0] if arr.size else 0), "a scalar"
    if how == 6:
        if arr.dtype.kind == "f":
            return np.full(arr.shape, rng.choice([np.nan, np.inf, -1e30]), arr.dtype), "non-finite or huge"
        if arr.dtype.kind in "iu":
            info = np.iinfo(arr.dtype)
            return np.full(arr.shape, rng.choice([info.max, info.min, -1 if info.min < 0 else info.max]), arr.dtype), "extreme ints"
        if arr.dtype.kind == "b":
            return ~arr, "inverted"
        return np.full(arr.shape, "?" * 50), "other strings"
    return np.array([None, "x"], dtype=object), "an object array"


def m_wrong_array(path: Path, rng) -> str:
    members = _members(path)
    name = _pick_member(members, rng)
    arr = np.load(io.BytesIO(members[name]), allow_pickle=False)
    with np.errstate(all="ignore"), warnings.catch_warnings():  # NaN to int and the like: the damage wanted
        warnings.simplefilter("ignore")
        new, what = _other_array(arr, rng)
    buf = io.BytesIO()
    np.save(buf, new, allow_pickle=True)
    members[name] = buf.getvalue()
    _write_members(path, members)
    return f"member {name} {what} ({arr.dtype} {list(arr.shape)} -> {new.dtype} {list(new.shape)})"


def m_header_json(path: Path, rng) -> str:
    """Change the JSON ``__header__`` of a native file or store file (a key deleted or a value replaced)."""
    members = _members(path)
    if "__header__.npy" not in members:
        return m_delete_member(path, rng)
    doc = json.loads(bytes(np.load(io.BytesIO(members["__header__.npy"]))).decode())
    what = _mutate_doc(doc, rng)
    buf = io.BytesIO()
    np.save(buf, np.frombuffer(json.dumps(doc).encode(), np.uint8))
    members["__header__.npy"] = buf.getvalue()
    _write_members(path, members)
    return f"__header__: {what}"


# -- PNG
def m_wrong_png(path: Path, rng) -> str:
    import cv2

    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    how = int(rng.integers(5))
    if how == 0:
        new, what = (img // 256 if img.dtype == np.uint16 else img).astype(np.uint8), "8-bit"
    elif how == 1:
        new, what = img.astype(np.uint16) * 257, "16-bit"
    elif how == 2:
        new, what = (np.dstack([img] * 3) if img.ndim == 2 else img[..., 0]), "other channels"
    elif how == 3:
        new, what = img[: img.shape[0] // 2], "half height"
    else:
        new, what = np.dstack([img if img.ndim == 2 else img[..., 0]] * 4), "four channels"
    ok, buf = cv2.imencode(".png", np.ascontiguousarray(new))
    assert ok
    _bytes(path, buf.tobytes())
    return f"a valid PNG, {what} ({img.dtype} {list(img.shape)} -> {new.dtype} {list(new.shape)})"


# -- JSON / YAML
_VALUES = [None, "x", "", -1, 0, 2**40, -(2**40), 1e300, 3.5, True, [], {}, [1, 2], {"a": 1}, "../../x", float("nan")]


def _paths(doc, prefix=()):
    yield prefix
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield from _paths(v, (*prefix, k))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            yield from _paths(v, (*prefix, i))


def _mutate_doc(doc, rng) -> str:
    paths = [p for p in _paths(doc) if p]
    if not paths:
        return "nothing to change"
    p = paths[int(rng.integers(len(paths)))]
    parent = doc
    for k in p[:-1]:
        parent = parent[k]
    if rng.random() < 0.4:
        del parent[p[-1]]
        return f"{'/'.join(map(str, p))} deleted"
    v = _VALUES[int(rng.integers(len(_VALUES)))]
    parent[p[-1]] = v
    return f"{'/'.join(map(str, p))} = {v!r}"


_TEXT_GARBAGE = ["{", "[", "null", "[]", "\"x\"", "1e999", "{\"a\": }", "[" * 5000, "\ufeff{}", "\x00\x01", "key: [unclosed", "a: b: c", "\t- x\n", "!!python/object:os.system x", "{}"]


def m_text_garbage(path: Path, rng) -> str:
    t = _TEXT_GARBAGE[int(rng.integers(len(_TEXT_GARBAGE)))]
    if rng.random() < 0.2:
        path.write_bytes(b"\xff\xfe" + t.encode("utf-8"))
        return f"invalid UTF-8 then {t[:20]!r}"
    path.write_text(t, encoding="utf-8")
    return f"replaced by {t[:20]!r}"


def m_deeply_nested(path: Path, rng) -> str:
    # PyYAML takes about 1.5 s to refuse 1000 levels or more (its composer recurses); JSON is fast at any depth
    n = int(rng.choice([300, 600, 1200] if path.suffix == ".yaml" else [300, 5000, 100_000]))
    open_, close = ("[", "]") if rng.random() < 0.5 else ("{\"a\": ", "}")
    path.write_text(open_ * n + close * n * int(rng.integers(0, 2)), encoding="utf-8")
    return f"nested {n} deep"


def m_doc(path: Path, rng) -> str:
    if path.suffix == ".yaml":
        doc = yaml.safe_load(path.read_text(encoding="utf-8"))
        what = _mutate_doc(doc, rng)
        path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    else:
        doc = json.loads(path.read_text(encoding="utf-8"))
        what = _mutate_doc(doc, rng)
        path.write_text(json.dumps(doc), encoding="utf-8")
    return what


_BYTES = [(m_truncate, 2), (m_zero, 2), (m_flip, 2), (m_empty, 1), (m_garbage, 1)]
MUTATIONS: dict[str, list[tuple[Callable, int]]] = {
    ".npz": _BYTES + [(m_member_bytes, 3), (m_npy_header, 4), (m_npy_body, 2), (m_delete_member, 2), (m_wrong_array, 4), (m_header_json, 2)],
    ".png": _BYTES + [(m_wrong_png, 3)],
    ".json": _BYTES + [(m_text_garbage, 2), (m_deeply_nested, 1), (m_doc, 5)],
    ".yaml": _BYTES + [(m_text_garbage, 2), (m_deeply_nested, 1), (m_doc, 5)],
}
#: Byte-level damage of a binary file (.npz, PNG): the error line must name the file ...
NAMES_THE_FILE = {m_truncate, m_zero, m_flip, m_empty, m_garbage, m_member_bytes, m_npy_header, m_npy_body}
#: ... and damage inside one zip member must name that entry too.
NAMES_THE_ENTRY = {m_member_bytes, m_npy_header, m_npy_body}


def _pick(weighted: list[tuple[object, int]], rng):
    w = np.array([x[1] for x in weighted], float)
    return weighted[int(rng.choice(len(weighted), p=w / w.sum()))][0]


@dataclass
class Case:
    what: str  # "GROUP #INDEX: FILE: MUTATION"
    path: Path  # the damaged file
    names_file: bool  # the error line must name the file ...
    entry: str | None  # ... and this zip entry


def combos(group: str) -> list[tuple[str, Callable]]:
    """Every (file pattern, mutation) pair of ``group``: the first cases cover each once."""
    return [(pattern, m) for pattern in GROUPS[group][1] for m, _ in MUTATIONS[Path(pattern).suffix]]


def damage(group: str, index: int, base: Path, ws: Path) -> tuple[Case, bytes]:
    """Damage one file of the valid copy ``ws/TREE`` as case ``index`` of ``group`` does; returns the case and the file's bytes before."""
    tree, patterns, _ = GROUPS[group]
    rng = np.random.default_rng([SEED, list(GROUPS).index(group), index])
    every = combos(group)
    pattern, mutation = every[index] if index < len(every) else (_pick(list(patterns.items()), rng), None)
    files = sorted(p.relative_to(base / tree) for p in (base / tree).rglob("*") if p.is_file() and fnmatch.fnmatch(p.relative_to(base / tree).as_posix(), pattern))
    assert files, (group, pattern)
    path = ws / tree / files[int(rng.integers(len(files)))]
    mutation = mutation or _pick(MUTATIONS[path.suffix], rng)
    before = path.read_bytes()
    what = mutation(path, rng)
    entry = None
    if isinstance(what, tuple):
        what, entry = what
    if path.read_bytes() == before:  # a mutation that changed nothing (rare): damage the bytes instead
        what += "; unchanged, so " + m_flip(path, rng)
        mutation, entry = m_flip, None
    binary = path.suffix in (".npz", ".png")
    case = Case(f"{group} #{index}: {path.relative_to(ws).as_posix()}: {what}", path, binary and mutation in NAMES_THE_FILE, entry if mutation in NAMES_THE_ENTRY else None)
    return case, before


@contextlib.contextmanager
def damaged(group: str, index: int, base: Path, ws: Path) -> Iterator[Case]:
    """:func:`damage`, then the file restored and ``ws/new`` (a run's output) removed."""
    path = None
    try:
        case, before = damage(group, index, base, ws)
        path = case.path
        yield case
    finally:
        if path is not None:
            path.write_bytes(before)
        shutil.rmtree(ws / "new", ignore_errors=True)


def make_case(group: str, index: int, base: Path, ws: Path) -> Case:
    """Rebuild case ``index`` of ``group`` alone in the empty folder ``ws`` (left damaged, to run by hand)."""
    shutil.copytree(base / GROUPS[group][0], ws / GROUPS[group][0])
    return damage(group, index, base, ws)[0]


def check(code: int, err: str, case: Case) -> str | None:
    """None if the outcome is acceptable, else what is wrong."""
    lines = err.strip().splitlines()
    if "Traceback" in err:
        return "printed a traceback"
    if code == 0:
        return "internal error on stderr" if "internal error" in err else None
    if code != 2:
        return f"exit {code}"
    if len(lines) != 1 or not lines[0].startswith("graphseg: error: "):
        return f"{len(lines)} stderr lines"
    if "internal error" in lines[0]:
        return "internal error"
    if case.names_file and case.path.name not in lines[0]:
        return f"the line does not name {case.path.name}"
    if case.entry and f": {case.entry}: " not in lines[0]:
        return f"the line does not name the entry {case.entry}"
    return None


def test_the_cases_cover_every_file_and_mutation():
    assert sum(n for *_, n in GROUPS.values()) >= 300
    for group, (_, patterns, n) in GROUPS.items():
        assert n >= len(combos(group)), group
        assert {Path(p).suffix for p in patterns} <= set(MUTATIONS), group


def _tree(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("group", list(GROUPS))
def test_fuzz(group, base, tmp_path, capfd, monkeypatch):
    monkeypatch.chdir(tmp_path)
    tree = GROUPS[group][0]
    shutil.copytree(base / tree, tmp_path / tree)  # one copy; each case damages one file and restores it
    capfd.readouterr()
    failures, exits = [], {0: 0, 2: 0}
    t = time.perf_counter()
    for index in range(GROUPS[group][2]):
        with damaged(group, index, base, tmp_path) as case:
            for argv in commands(group, tmp_path, base):
                code = main([str(a) for a in argv])
                err = capfd.readouterr().err  # fd level: native libraries' lines count too
                exits[code] = exits.get(code, 0) + 1
                wrong = check(code, err, case)
                if wrong:
                    failures.append(f"{case.what}\n    graphseg {argv[0]}: {wrong}: {err.strip()[-600:]}")
    seconds = time.perf_counter() - t
    assert not failures, f"{len(failures)} failed commands in {GROUPS[group][2]} cases of {group} (exits {exits}, {seconds:.1f} s):\n" + "\n".join(failures)
    assert _tree(tmp_path / tree) == _tree(base / tree)  # no command wrote into its input
