from pathlib import Path

import numpy as np
import pytest

import graphseg.output as output
from graphseg.io import read_ply
from graphseg.method.segment import segment
from graphseg.output import read_output, write_output
from graphseg.report import overlay, palette, render_report
from graphseg.testing.scenes import two_boxes_scene


@pytest.fixture(scope="module")
def run():
    scene, masks, matches = two_boxes_scene()
    return scene, segment(scene, masks, matches)


def test_write_and_read_back(run, tmp_path):
    scene, result = run
    out = write_output(tmp_path / "out", result, scene, metrics={"objects": [], "mean": {}})
    back, info = read_output(out)
    assert back.num_objects == result.num_objects and info["views"] == result.view_names
    pts, cols = read_ply(out / "objects" / "001.ply")
    np.testing.assert_allclose(pts, result.object_cloud(1)[0], atol=1e-6)
    assert cols is not None and len(cols) == len(pts)


def test_failure_leaves_nothing_and_keeps_the_old_folder(run, tmp_path, monkeypatch):
    scene, result = run
    out = tmp_path / "out"
    write_output(out, result, scene)
    before = sorted(p.name for p in out.iterdir())

    def boom(*a, **k):
        raise OSError("disk full")

    monkeypatch.setattr(output, "write_graphml", boom)
    with pytest.raises(OSError, match="disk full"):
        write_output(out, result, scene)
    assert sorted(p.name for p in out.iterdir()) == before  # the previous output is intact
    with pytest.raises(OSError):
        write_output(tmp_path / "new", result, scene)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no half output, no temp folder


def test_palette_overlay_report():
    pal = palette(3)
    assert pal.shape == (4, 3) and (pal[0] == 0).all() and len({tuple(c) for c in pal}) == 4
    rgb = np.zeros((20, 30, 3), np.uint8)
    lab = np.zeros((20, 30), np.int32)
    lab[5:15, 5:15] = 2
    ov = overlay(rgb, lab, pal)
    assert ov.shape == rgb.shape and ov.dtype == np.uint8 and ov[10, 10].any() and not ov[0, 0].any()
    page = render_report(title="t<>", view_names=["a"], overlays=[ov], points=np.zeros((5, 3)), point_colors=np.zeros((5, 3), np.uint8), metrics=None, summary={"k": "v"})
    assert "t&lt;&gt;" in page and "<canvas" in page and "cdn" not in page.lower()


# ------------------------------------------------------------------ safety of the output folder
def test_marker_kinds_and_refusals(run, tmp_path):
    from graphseg.output import MARKER, check_target, read_marker
    from graphseg.scene import SceneError

    scene, result = run
    out = write_output(tmp_path / "out", result, scene)
    marker = read_marker(out)
    assert marker is not None
    assert {k: marker[k] for k in ("kind", "version")} == {"kind": "run", "version": 1} and "graphseg" in marker
    assert "result.npz" in marker["files"] and "labels" in marker["dirs"]  # the manifest of what graphseg wrote
    write_output(out, result, scene)  # same kind: replaced
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "a.txt").write_text("keep")
    with pytest.raises(SceneError, match="not a graphseg run output"):
        write_output(mine, result, scene)
    assert (mine / "a.txt").read_text() == "keep" and not (mine / MARKER).exists()
    with pytest.raises(SceneError, match="a graphseg run output, not synth"):
        check_target(out, "synth")
    write_output(mine, result, scene, overwrite=True)  # explicit: replaced
    assert read_marker(mine)["kind"] == "run"
    with pytest.raises(SceneError, match="input of this command"):
        write_output(tmp_path / "inputs" / "out", result, scene, inputs=[tmp_path / "inputs" / "out" / "deeper"], overwrite=True)


def test_folders_follow_the_umask(run, tmp_path):
    import os

    scene, result = run
    old = os.umask(0o027)
    try:
        out = write_output(tmp_path / "out", result, scene)
    finally:
        os.umask(old)
    assert (out.stat().st_mode & 0o777) == 0o750
    assert ((out / "labels").stat().st_mode & 0o777) == 0o750


def test_stale_temporaries_of_dead_runs_are_removed(run, tmp_path):
    from graphseg.output import MARKER

    scene, result = run
    stale = tmp_path / ".out.graphseg-tmp-999999999-abc"  # a killed run's folder: marker, dead pid
    stale.mkdir()
    (stale / MARKER).write_text('{"kind": "run", "version": 1}')
    lookalike = tmp_path / ".out.graphseg-tmp-999999999-xyz"  # same pattern but no marker: not ours
    lookalike.mkdir()
    (lookalike / "data").write_text("user")
    write_output(tmp_path / "out", result, scene)
    assert not stale.exists() and (lookalike / "data").read_text() == "user"
    assert sorted(p.name for p in tmp_path.iterdir()) == [lookalike.name, "out"]


def test_view_names_that_collide_or_are_not_utf8_safe(tmp_path):
    from graphseg.scene import Scene
    from graphseg.testing.scenes import TWO_BOXES, box_scene, exact_matches

    s = box_scene(TWO_BOXES, views=3, shape=(48, 64))
    names = ["a/b", "a_b", "caf\udce9"]  # a lone surrogate: what os.fsdecode gives for a non-UTF-8 byte
    s = Scene([v.replace(name=n) for v, n in zip(s.views, names)], s.objects)
    masks = [v.instances.astype(np.int32) for v in s.views]
    result = segment(s, masks, exact_matches(s))
    out = write_output(tmp_path / "out", result, s)
    assert sorted(p.name for p in (out / "labels").iterdir()) == ["a_b-2.png", "a_b.png", "caf_.png"]
    assert "caf" in (out / "report.html").read_text(encoding="utf-8")
    back, info = read_output(out)
    assert back.view_names == names and info["view_files"] == ["a_b", "a_b-2", "caf_"]


def test_no_empty_ply_files(run, tmp_path):
    from graphseg.graphs import PointSets
    from graphseg.output import write_object_clouds

    _, result = run
    pts = result.object_points
    empty_first = PointSets(pts.points, np.r_[0, 0, pts.ptr[1:]], pts.colors)  # object 1 has no points
    r2 = type(result)(**{**result.__dict__, "object_points": empty_first})
    n = write_object_clouds(r2, tmp_path / "ply")
    assert n == r2.num_objects - 1 and not (tmp_path / "ply" / "001.ply").exists()
    assert all(len(read_ply(p)[0]) > 0 for p in (tmp_path / "ply").glob("*.ply"))


def test_old_output_layout_still_lists_its_graphs(tmp_path):
    from graphseg.output import stage_graph_files

    (tmp_path / "graph_2d.graphml").write_text("x")
    (tmp_path / "graph_3d.graphml").write_text("x")
    assert [p.name for p in stage_graph_files(tmp_path)] == ["graph_2d.graphml", "graph_3d.graphml"]


def test_failed_write_removes_the_parents_it_created(run, tmp_path, monkeypatch):
    scene, result = run

    def boom(*a, **k):
        raise OSError("disk full")

    monkeypatch.setattr(output, "write_graphml", boom)
    with pytest.raises(OSError):
        write_output(tmp_path / "a" / "b" / "out", result, scene)
    assert list(tmp_path.iterdir()) == []


def test_atomic_file_leaves_nothing_on_failure_and_cleans_killed_runs(tmp_path):
    from graphseg.output import MARKER, atomic_file

    with atomic_file(tmp_path / "g.graphml") as tmp:
        tmp.write_text("ok")
    assert (tmp_path / "g.graphml").read_text() == "ok"
    with pytest.raises(RuntimeError), atomic_file(tmp_path / "g.graphml") as tmp:
        tmp.write_text("half")
        raise RuntimeError("killed")
    assert (tmp_path / "g.graphml").read_text() == "ok" and sorted(p.name for p in tmp_path.iterdir()) == ["g.graphml"]
    stale = tmp_path / ".g.graphml.graphseg-tmp-999999999-k"
    stale.mkdir()
    (stale / MARKER).write_text('{"kind": "export", "version": 1}')
    (stale / "g.graphml").write_text("half")
    with atomic_file(tmp_path / "g.graphml") as tmp:
        tmp.write_text("new")
    # the stale temporary is gone; the replaced file is kept, not deleted (issue 19)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g.graphml", "g.graphml.graphseg-backup-1"]
    assert (tmp_path / "g.graphml").read_text() == "new" and (tmp_path / "g.graphml.graphseg-backup-1").read_text() == "ok"


# ------------------------------------------------------------------ issue 19: replacing never deletes a user's files
def _siblings(path):
    return sorted(p.name for p in path.parent.iterdir())


def _tree(root):
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def test_a_users_file_inside_a_run_output_survives_a_rerun(run, tmp_path):
    scene, result = run
    out = write_output(tmp_path / "out", result, scene)
    (out / "notes.txt").write_text("my notes")
    before = _tree(out)
    moved: list[tuple[Path, Path]] = []
    write_output(out, result, scene, moved=moved)  # no --overwrite needed: it is a run output
    backup = tmp_path / "out.graphseg-backup-1"
    assert moved == [(out, backup)]
    assert _tree(backup) == before  # everything, the user's file included, intact
    assert not (out / "notes.txt").exists() and (out / "result.npz").is_file()
    assert _siblings(out) == ["out", "out.graphseg-backup-1"]  # no temporary left


@pytest.mark.parametrize("change", ["add_folder", "remove", "same_size_edit", "old_marker", "symlink"])
def test_a_changed_run_output_is_kept_not_deleted(run, tmp_path, change):
    import os

    from graphseg.output import MARKER

    scene, result = run
    out = write_output(tmp_path / "out", result, scene)
    if change == "add_folder":
        (out / "mine").mkdir()
    elif change == "remove":
        (out / "report.html").unlink()
    elif change == "same_size_edit":  # e.g. a number edited in config.yaml: same size, newer file
        p = out / "config.yaml"
        data = p.read_bytes()
        p.write_bytes(data[:-1] + (b"x" if data[-1:] != b"x" else b"y"))
        st = p.stat()
        os.utime(p, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    elif change == "old_marker":  # written by an older graphseg: no manifest
        (out / MARKER).write_text('{"kind": "run", "version": 1}')
    elif change == "symlink":
        (tmp_path / "data.txt").write_text("user data")
        (out / "link").symlink_to(tmp_path / "data.txt")
    before = _tree(out)
    moved: list[tuple[Path, Path]] = []
    write_output(out, result, scene, moved=moved)
    backup = tmp_path / "out.graphseg-backup-1"
    assert moved == [(out, backup)] and _tree(backup) == before
    assert (out / "result.npz").is_file() and not (out / "mine").exists()
    if change == "symlink":
        assert (backup / "link").is_symlink() and (tmp_path / "data.txt").read_text() == "user data"


def test_an_unchanged_output_is_replaced_without_backup(run, tmp_path):
    scene, result = run
    out = write_output(tmp_path / "out", result, scene)
    for _ in range(2):
        moved: list[tuple[Path, Path]] = []
        write_output(out, result, scene, moved=moved)
        assert moved == [] and _siblings(out) == ["out"]


def test_overwrite_moves_a_foreign_folder_aside(run, tmp_path):
    from graphseg.output import MARKER, read_marker

    scene, result = run
    mine = tmp_path / "mine"
    (mine / "sub").mkdir(parents=True)
    (mine / "a.txt").write_text("keep")
    (mine / "sub" / "b.txt").write_text("keep too")
    synth = tmp_path / "synth"  # a graphseg output of another kind, intact
    output.check_target(synth, "synth")
    with output.atomic_folder(synth, "synth") as tmp:
        (tmp / "scene.json").write_text("{}")
    moved: list[tuple[Path, Path]] = []
    write_output(mine, result, scene, overwrite=True, moved=moved)
    write_output(synth, result, scene, overwrite=True, moved=moved)
    assert moved == [(mine, tmp_path / "mine.graphseg-backup-1"), (synth, tmp_path / "synth.graphseg-backup-1")]
    assert _tree(tmp_path / "mine.graphseg-backup-1") == {"a.txt": b"keep", "sub/b.txt": b"keep too"}
    assert (read_marker(tmp_path / "synth.graphseg-backup-1") or {}).get("kind") == "synth"
    assert (read_marker(mine) or {}).get("kind") == "run" and not (mine / "a.txt").exists() and (mine / MARKER).is_file()
    # a second replacement takes the next free number and keeps the first backup
    (mine / "c.txt").write_text("more")
    write_output(mine, result, scene, overwrite=True, moved=moved)
    assert moved[-1] == (mine, tmp_path / "mine.graphseg-backup-2") and (tmp_path / "mine.graphseg-backup-2" / "c.txt").read_text() == "more"
    assert (tmp_path / "mine.graphseg-backup-1" / "a.txt").read_text() == "keep"


def test_an_export_file_replaced_with_overwrite_is_kept(tmp_path):
    from graphseg.output import atomic_file, check_target

    f = tmp_path / "g.graphml"
    f.write_text("the user's file")
    moved: list[tuple[Path, Path]] = []
    with atomic_file(check_target(f, "export", overwrite=True, folder=False), moved=moved) as tmp:
        tmp.write_text("new graph")
    assert moved == [(f, tmp_path / "g.graphml.graphseg-backup-1")]
    assert f.read_text() == "new graph" and (tmp_path / "g.graphml.graphseg-backup-1").read_text() == "the user's file"
    assert (tmp_path / "g.graphml.graphseg-backup-1").is_file()
    # the same bytes again: nothing is lost, so no backup
    moved.clear()
    with atomic_file(f, moved=moved) as tmp:
        tmp.write_text("new graph")
    assert moved == [] and _siblings(f) == ["g.graphml", "g.graphml.graphseg-backup-1"]


def test_an_interrupted_export_keeps_the_old_file(tmp_path, monkeypatch):
    import os

    from graphseg.output import atomic_file

    f = tmp_path / "m.json"
    f.write_text("the user's file")
    real = os.replace
    fired: list[object] = []

    def ctrl_c(src, dst):  # once, as the new file is renamed into place
        if os.fspath(dst) == os.fspath(f) and ".graphseg-tmp-" in os.fspath(src) and not fired:
            fired.append(src)
            raise KeyboardInterrupt
        return real(src, dst)

    monkeypatch.setattr(os, "replace", ctrl_c)
    with pytest.raises(KeyboardInterrupt), atomic_file(f) as tmp:
        tmp.write_text("new")
    assert fired and f.read_text() == "the user's file" and _siblings(f) == ["m.json"]


@pytest.mark.parametrize("user_file", [True, False])
@pytest.mark.parametrize("when", ["moving_aside", "renaming_into_place"])
def test_interrupted_replacement_keeps_the_old_folder_where_it_was(run, tmp_path, monkeypatch, user_file, when):
    import os

    scene, result = run
    out = write_output(tmp_path / "out", result, scene)
    if user_file:
        (out / "notes.txt").write_text("my notes")
    before = _tree(out)
    real = os.replace

    def ctrl_c(src, dst):  # Ctrl-C as the old folder is moved aside, or as the new one is renamed into place
        if (when == "moving_aside" and os.fspath(src) == os.fspath(out)) or (".graphseg-tmp-" in os.fspath(src) and os.fspath(dst) == os.fspath(out)):
            raise KeyboardInterrupt
        return real(src, dst)

    monkeypatch.setattr(os, "replace", ctrl_c)
    with pytest.raises(KeyboardInterrupt):
        write_output(out, result, scene)
    monkeypatch.undo()
    assert _tree(out) == before and _siblings(out) == ["out"]  # put back; no backup, no temporary

    def boom(*a, **k):  # Ctrl-C while the new folder is written
        raise KeyboardInterrupt

    monkeypatch.setattr(output, "write_graphml", boom)
    with pytest.raises(KeyboardInterrupt):
        write_output(out, result, scene)
    assert _tree(out) == before and _siblings(out) == ["out"]


def test_clean_stale_never_removes_a_backup(run, tmp_path):
    from graphseg.output import MARKER, clean_stale

    scene, result = run
    out = write_output(tmp_path / "out", result, scene)
    (out / "notes.txt").write_text("mine")
    write_output(out, result, scene)
    backup = tmp_path / "out.graphseg-backup-1"
    before = _tree(backup)
    assert (backup / MARKER).is_file()  # a backup of a graphseg output carries its marker
    hidden = tmp_path / ".out.graphseg-backup-2-999999999-x"  # even a hidden look-alike with a dead pid
    hidden.mkdir()
    (hidden / MARKER).write_text('{"kind": "run", "version": 1}')
    assert clean_stale(out) == [] and clean_stale(backup) == []
    write_output(out, result, scene)
    assert _tree(backup) == before and hidden.is_dir()


def test_large_manifests_are_read_and_the_cap_holds(tmp_path, monkeypatch):
    from graphseg.output import MARKER, atomic_folder, read_marker

    out = tmp_path / "out"
    with atomic_folder(out, "run") as tmp:
        for i in range(300):
            (tmp / f"file-{i:04d}.txt").write_text(str(i))
    assert (out / MARKER).stat().st_size > 4096 and len((read_marker(out) or {}).get("files", ())) == 300
    moved: list[tuple[Path, Path]] = []
    with atomic_folder(out, "run", moved=moved) as tmp:
        (tmp / "x").write_text("x")
    assert moved == []  # the large manifest matched: replaced, no backup
    monkeypatch.setattr(output, "MARKER_MAX_BYTES", 10)
    assert read_marker(out) is None


def test_run_job_warns_where_it_kept_the_old_output(tmp_path, monkeypatch):
    from graphseg.config import Config
    from graphseg.job import run_job
    from graphseg.testing.scenes import TWO_BOXES, box_scene

    monkeypatch.chdir(tmp_path)
    scene = box_scene(TWO_BOXES, views=3, shape=(48, 64))
    job = run_job(scene, "out", Config())
    assert not any("graphseg-backup" in w for w in job.warnings)
    (tmp_path / "out" / "notes.txt").write_text("mine")
    job = run_job(scene, "out", Config())
    msg = "kept your existing out as out.graphseg-backup-1 (it was not a complete graphseg run output)"
    assert msg in job.warnings and msg not in job.result.info.get("warnings", [])
    assert (tmp_path / "out.graphseg-backup-1" / "notes.txt").read_text() == "mine"
    assert msg not in (tmp_path / "out" / "run.json").read_text()
