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
    assert read_marker(out) == {"kind": "run", "version": 1, "graphseg": read_marker(out)["graphseg"]}
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
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g.graphml"]
