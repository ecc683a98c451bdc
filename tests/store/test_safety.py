"""Safe storage: a killed add leaves the store as it was, one writer at a time, format versions, user files."""

import json
import multiprocessing
import os
import signal
import time

import numpy as np
import pytest

from graphseg.output import read_marker
from graphseg.store import SceneGraph, StoreError, StoreLockedError
from graphseg.store.layout import POINTER, StoreLock, read_pointer

from .conftest import partition

FORK = multiprocessing.get_context("fork")


def _state(path):
    """Everything a reader of the store sees, for comparison."""
    sg = SceneGraph.open(path, create=False)
    r = sg.result() if sg.view_names else None
    return {
        "pointer": (path / POINTER).read_bytes(),
        "generation": sg.generation,
        "views": sg.view_names,
        "ids": sg.object_ids,
        "objects": sg.objects,
        "history": json.dumps(sg.history, sort_keys=True),
        "partition": partition(r) if r is not None else None,
        "labels": [lab.tolist() for lab in r.labels] if r is not None else None,
    }


def _add_and_die(path, view, lookup, kill_at, after):
    """Child: add one view, SIGKILL itself at the ``kill_at``-th file rename (before it, or just after with ``after``)."""
    real = os.replace
    calls = [0]

    def replace(src, dst, *a, **k):
        calls[0] += 1
        if calls[0] == kill_at and not after:
            os.kill(os.getpid(), signal.SIGKILL)
        out = real(src, dst, *a, **k)
        if calls[0] == kill_at and after:
            os.kill(os.getpid(), signal.SIGKILL)
        return out

    os.replace = replace
    SceneGraph.open(path, create=False).add(view, segmenter=lookup.segment, matcher=lookup.match)
    os._exit(0)


def _count_renames(path, view, lookup):
    real, calls = os.replace, [0]

    def replace(*a, **k):
        calls[0] += 1
        return real(*a, **k)

    os.replace = replace
    try:
        SceneGraph.open(path, create=False).add(view, segmenter=lookup.segment, matcher=lookup.match)
    finally:
        os.replace = real
    return calls[0]


def test_sigkill_during_add_leaves_the_store_as_before(boxes, tmp_path):
    scene, lookup = boxes
    path = tmp_path / "s"
    SceneGraph.open(path).add(scene.views[:3], segmenter=lookup.segment, matcher=lookup.match)
    before = _state(path)
    # how many renames one add makes (view, matches, result, state, and last the pointer: the commit)
    probe = tmp_path / "probe"
    SceneGraph.open(probe).add(scene.views[:3], segmenter=lookup.segment, matcher=lookup.match)
    renames = _count_renames(probe, scene.views[3], lookup)
    assert renames >= 5
    files = {f"{sub}/{f.name}" for sub in ("views", "pairs", "generations") for f in (path / sub).iterdir()}
    for k in range(1, renames + 1):  # killed before each rename, the commit included
        p = FORK.Process(target=_add_and_die, args=(path, scene.views[3], lookup, k, False))
        p.start()
        p.join(30)
        assert p.exitcode == -signal.SIGKILL, k
        assert _state(path) == before, f"killed before rename {k}"
    left_behind = {f"{sub}/{f.name}" for sub in ("views", "pairs", "generations") for f in (path / sub).iterdir()} - files
    assert any(".tmp-" in f for f in left_behind) and any(f.startswith("views/V") for f in left_behind)  # killed mid-write indeed
    # killed just after the commit: the store holds the add
    p = FORK.Process(target=_add_and_die, args=(path, scene.views[3], lookup, renames, True))
    p.start()
    p.join(30)
    assert p.exitcode == -signal.SIGKILL
    after = _state(path)
    assert after["generation"] == before["generation"] + 1 and after["views"] == [*before["views"], scene.views[3].name]
    # the next add cleans what the killed ones left and gives what an uninterrupted store gives
    sg = SceneGraph.open(path, create=False)
    sg.add(scene.views[4], segmenter=lookup.segment, matcher=lookup.match)
    SceneGraph.open(probe, create=False).add(scene.views[4], segmenter=lookup.segment, matcher=lookup.match)
    assert _state(path)["partition"] == _state(probe)["partition"]
    assert _state(path)["ids"] == _state(probe)["ids"]
    left = [f.name for sub in ("views", "pairs", "generations") for f in (path / sub).iterdir()]
    assert not [f for f in left if ".tmp-" in f]
    assert sorted(f for f in left if f.startswith("V")) == [f"V{u:06d}.npz" for u in range(5)]


def _slow_add(path, views, lookup):
    SceneGraph.open(path, create=False).add(views, segmenter=lookup.segment, matcher=lookup.match)
    os._exit(0)


def test_sigkill_at_random_times_leaves_the_store_before_or_after(boxes, tmp_path):
    scene, lookup = boxes
    path = tmp_path / "s"
    SceneGraph.open(path).add(scene.views[0], segmenter=lookup.segment, matcher=lookup.match)
    before = _state(path)
    seen = set()
    for delay in (0.02, 0.08, 0.2):
        p = FORK.Process(target=_slow_add, args=(path, scene.views[1:], lookup))
        p.start()
        time.sleep(delay)
        os.kill(p.pid, signal.SIGKILL)
        p.join(30)
        now = _state(path)
        assert now == before or (now["generation"] == before["generation"] + 1 and len(now["views"]) == 5)
        seen.add(now["generation"])
        if now != before:
            break


def _hold(path, ready, done):
    with StoreLock(path):
        ready.set()
        done.wait(20)
    os._exit(0)


def test_a_second_writer_is_refused_with_one_line(boxes, tmp_path):
    scene, lookup = boxes
    path = tmp_path / "s"
    sg = SceneGraph.open(path)
    ready, done = FORK.Event(), FORK.Event()
    p = FORK.Process(target=_hold, args=(path, ready, done))
    p.start()
    try:
        assert ready.wait(20)
        with pytest.raises(StoreLockedError) as err:
            sg.add(scene.views[0], segmenter=lookup.segment, matcher=lookup.match)
        msg = str(err.value)
        assert "\n" not in msg and f"pid {p.pid}" in msg and msg.startswith(f"{path}: lock: ")
        assert sg.generation == 0 and SceneGraph.open(path, create=False).generation == 0
    finally:
        done.set()
        p.join(20)
    assert sg.add(scene.views[0], segmenter=lookup.segment, matcher=lookup.match).generation == 1  # free again


@pytest.mark.parametrize(
    "doc, words",
    [
        ({"format": "graphseg-store", "version": 0, "generation": 0, "state": "x"}, "format version 0 is older than any this graphseg reads (1); re-create the store"),
        ({"format": "graphseg-store", "version": 7, "generation": 0, "state": "x"}, "format version 7 is newer than this graphseg reads (1); upgrade graphseg"),
        ({"format": "something-else", "version": 1}, "not a graphseg store (format 'something-else'"),
        ({"format": "graphseg-store", "version": "1"}, "expected an integer format version (got '1')"),
        ({"format": "graphseg-store", "version": 1, "generation": -1, "state": "x"}, "expected a generation >= 0"),
    ],
)
def test_an_unknown_format_version_is_refused_with_one_line(tmp_path, doc, words):
    path = tmp_path / "s"
    SceneGraph.open(path)
    (path / POINTER).write_text(json.dumps(doc))
    with pytest.raises(StoreError) as err:
        SceneGraph.open(path, create=False)
    assert words in str(err.value) and "\n" not in str(err.value)


def test_a_version_1_store_reads(tmp_path):
    path = tmp_path / "s"
    SceneGraph.open(path)
    assert read_pointer(path)["version"] == 1
    assert SceneGraph.open(path, create=False).generation == 0


def test_garbled_pointer_and_missing_state_are_one_line_errors(tmp_path):
    path = tmp_path / "s"
    SceneGraph.open(path)
    (path / POINTER).write_text("{not json")
    with pytest.raises(StoreError, match="store.json: store.json: unreadable"):
        SceneGraph.open(path, create=False)
    (path / POINTER).write_text(json.dumps({"format": "graphseg-store", "version": 1, "generation": 0, "state": "generations/000009.state.json"}))
    with pytest.raises(StoreError, match="file not found"):
        SceneGraph.open(path, create=False)
    (path / POINTER).write_text(json.dumps({"format": "graphseg-store", "version": 1, "generation": 0, "state": "../../etc/passwd"}))
    with pytest.raises(StoreError, match="leaves the store"):
        SceneGraph.open(path, create=False)


def test_the_store_follows_the_output_safety_rules(boxes, tmp_path):
    scene, lookup = boxes
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep")
    with pytest.raises(StoreError, match="exists and is not a graphseg store"):
        SceneGraph.open(mine)
    assert sorted(p.name for p in mine.iterdir()) == ["notes.txt"]
    (tmp_path / "file").write_text("x")
    with pytest.raises(StoreError, match="exists and is not a graphseg store"):
        SceneGraph.open(tmp_path / "file")
    with pytest.raises(StoreError, match="lies inside an input"):
        SceneGraph.open(mine / "store", inputs=[mine])
    with pytest.raises(StoreError, match="no such store"):
        SceneGraph.open(tmp_path / "none", create=False)
    os.symlink(mine, tmp_path / "link")
    with pytest.raises(StoreError):
        SceneGraph.open(tmp_path / "link")
    path = tmp_path / "s"
    sg = SceneGraph.open(path)
    assert read_marker(path)["kind"] == "store" and "files" not in read_marker(path)  # never deleted as a stale output
    (path / "views" / "my-notes.txt").write_text("mine")  # a user's file inside the store is never removed
    sg.add(scene.views[:2], segmenter=lookup.segment, matcher=lookup.match)
    sg.add(scene.views[2], segmenter=lookup.segment, matcher=lookup.match)
    assert (path / "views" / "my-notes.txt").read_text() == "mine"
    (path / ".graphseg-output").unlink()
    with pytest.raises(StoreError, match="no graphseg store marker"):
        SceneGraph.open(path, create=False)


def test_a_tampered_view_file_is_a_one_line_error(boxes, tmp_path):
    scene, lookup = boxes
    path = tmp_path / "s"
    SceneGraph.open(path).add(scene.views[:2], segmenter=lookup.segment, matcher=lookup.match)
    f = path / "views" / "V000000.npz"
    f.write_bytes(f.read_bytes()[:200])
    sg = SceneGraph.open(path, create=False)
    with pytest.raises(StoreError) as err:
        sg.add(scene.views[2], segmenter=lookup.segment, matcher=lookup.match)
    assert str(err.value).startswith(str(f)) and "\n" not in str(err.value)
    assert SceneGraph.open(path, create=False).generation == 1
    np.testing.assert_equal(len(list((path / "views").iterdir())), 2)
