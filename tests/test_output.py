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
