"""Photos without depth (issue 52, deliverable 7): no silent zero, and no phantom objects from views too close together.

* A run that finds no object says which step lost them, in one warning line
  (stderr) and in ``run.json`` (``no_objects``): :func:`graphseg.pipeline.no_objects_reason`.
* Views under a degree apart give stereo and triangulation no parallax: the
  ``sfm`` lifter refuses them with one line and exit 2 (given cameras, and
  photos only), before any stereo, instead of writing phantom objects.
"""

import json
import re

import numpy as np
import pytest

from graphseg.cli import main
from graphseg.config import Config
from graphseg.io import write_scene_folder
from graphseg.io.images import write_rgb
from graphseg.pipeline import NO_OBJECT_STEPS, no_objects_reason, run
from graphseg.scene import Scene, SceneError
from graphseg.testing.scenes import TWO_BOXES, box_scene

SHAPE = (48, 64)


@pytest.fixture(scope="module")
def boxes():
    return box_scene(TWO_BOXES, views=3, shape=SHAPE)


def _cli(args, capsys):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


# ----------------------------------------------------------------------------- no silent zero


def test_no_masks_names_the_masks_step(boxes):
    res = run(boxes, masks=[np.zeros(SHAPE, np.int32)] * 3)
    why = res.info["no_objects"]
    assert res.num_objects == 0 and why["step"] == "masks"
    assert res.info["warnings"] == [why["line"]] == ["0 objects: lost at the masks step: the segmenter gave no mask in any of the 3 views"]


def test_masks_on_the_table_name_the_background_step(boxes):
    table = [(v.instances == 0).astype(np.int32) for v in boxes.views]  # one mask per view: the table only
    res = run(boxes, masks=table)
    why = no_objects_reason(res, boxes)
    assert why["step"] == "background" and why["masks_background"] == 3
    assert why["line"].startswith("0 objects: lost at the background step: all 3 masks were dropped: 3 lay at least 50% in the background class")
    assert res.info["warnings"] == [why["line"]]


def test_objects_below_the_support_name_the_support_step(boxes):
    cfg = Config(objects={"min_point_fraction": 1.0})  # no object can have a whole view's pixels in points
    res = run(boxes, cfg)
    why = res.info["no_objects"]
    assert why["step"] == "support" and why["masks_kept"] > 0
    assert "every one below the minimum support" in why["line"] and len(res.info["warnings"]) == 1


def test_no_point_names_the_lifting_step(boxes):
    nan = Scene([v.replace(points=np.full((*SHAPE, 3), np.nan, np.float32), depth=None) for v in boxes.views], boxes.objects, "nan", {"lifter": "sfm"})
    res = run(nan, masks=[(v.instances > 0).astype(np.int32) for v in boxes.views])
    why = res.info["no_objects"]
    assert why["step"] == "lifting" and why["line"] == "0 objects: lost at the lifting step: the lifter (sfm) gave no valid 3D point in any of the 3 views"


def test_masks_lost_on_sparse_points_name_the_lifting_step(boxes):
    """Structure from motion that found a few points only (a tune scene: 13 points, 9% of the pixels lifted) loses every mask."""
    keep = np.zeros(SHAPE, bool)
    keep[-8:] = True  # 17% of the pixels keep their point: the table in front of the boxes
    sparse = Scene([v.replace(points=np.where(keep[..., None], v.points, np.nan).astype(np.float32), depth=None) for v in boxes.views], boxes.objects, "sparse", {"lifter": "sfm", "sfm": {"points": 13, "dense_fraction": [0.005] * 3}})
    res = run(sparse, masks=[keep.astype(np.int32)] * 3)
    why = res.info["no_objects"]
    assert why["step"] == "lifting" and why["coverage"] < 0.25
    assert why["line"].startswith("0 objects: lost at the lifting step: 3D points cover only 17% of the pixels (structure from motion triangulated 13 points, dense stereo covered 0.5% of the pixels), and then all 3 masks were dropped")
    assert why["line"].endswith("give depth, or take photos with more texture and overlap")


def test_views_left_out_by_the_lifter_name_registration(boxes):
    two = Scene(boxes.views[:2], boxes.objects, "two", {"lifter": "sfm", "dropped_views": ["a", "b"], "sfm": {"registered": 2}})
    res = run(two, masks=[np.zeros(SHAPE, np.int32)] * 2)
    why = res.info["no_objects"]
    assert why["step"] == "registration"
    assert why["line"].endswith("; structure from motion registered 2 of 4 views and segmented 2, so the points may be wrong")
    assert set(NO_OBJECT_STEPS) >= {why["step"]}


def test_a_run_with_objects_has_no_reason(boxes):
    res = run(boxes)
    assert res.num_objects == 2 and no_objects_reason(res, boxes) is None and "no_objects" not in res.info


def test_cli_zero_objects_one_line_on_stderr_and_in_run_json(boxes, tmp_path, capsys):
    d = write_scene_folder(boxes, tmp_path / "scene")
    (tmp_path / "c.yaml").write_text("masks:\n  min_area: 1000000\n")
    code, stdout, err = _cli(["run", d, "-o", tmp_path / "o", "--quiet", "--config", tmp_path / "c.yaml"], capsys)
    assert code == 0 and stdout.startswith("0 objects")
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("graphseg: warning: 0 objects: lost at the masks step: all ")
    assert "below masks.min_area 1000000" in lines[0]
    info = json.loads((tmp_path / "o" / "run.json").read_text())
    assert info["no_objects"]["step"] == "masks" and info["warnings"] == [lines[0].removeprefix("graphseg: warning: ")]


# ----------------------------------------------------------------------------- views too close together

#: Degrees between neighbouring views as seen from the table's centre (3 views: 0.5 degrees in all).
STEP_DEG = 0.25


@pytest.fixture(scope="module")
def close_views():
    """A pybullet tabletop of 3 views (320 x 240) whose cameras step sideways by STEP_DEG degrees from the first one."""
    pytest.importorskip("pycolmap")
    pytest.importorskip("pybullet")
    from graphseg.sim import pybullet_scenes as ps

    real = ps.render_view
    first: dict = {}

    def near_first(p, cid, eye, target, size, *args):
        if not first:
            first.update(eye=np.asarray(eye, np.float64).copy(), target=np.asarray(target, np.float64).copy(), n=0)
        e0, t0 = first["eye"], first["target"]
        side = np.cross(t0 - e0, [0.0, 0.0, 1.0])
        side /= np.linalg.norm(side)
        eye = e0 + side * np.linalg.norm(t0 - e0) * np.tan(np.radians(STEP_DEG)) * first["n"]
        first["n"] += 1
        return real(p, cid, eye, t0, size, *args)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(ps, "render_view", near_first)
        return ps.synthesize(seed=3, objects=4, views=3, size=(320, 240), cameras=ps.CameraRig(arc_deg=50), settle_steps=240, table_texture="noise")


def test_close_views_with_given_cameras_are_refused(close_views, tmp_path, capsys):
    from graphseg.backends.lifters.sfm import MIN_SPAN, SfmLifter, camera_span

    span, _ = camera_span([v.cam_to_world for v in close_views.views], 0.5)
    assert span < 1.0  # under a degree apart
    assert SfmLifter().options.min_span == MIN_SPAN >= 1.0
    no_depth = Scene([v.replace(depth=None) for v in close_views.views], close_views.objects, "close")  # K and poses kept
    d = write_scene_folder(no_depth, tmp_path / "scene")
    code, stdout, err = _cli(["run", d, "-o", tmp_path / "o", "--quiet"], capsys)
    assert code == 2 and stdout == "" and len(err.strip().splitlines()) == 1, err
    assert re.search(r"^graphseg: error: .*the cameras are at most 0\.\d+ degrees apart as seen from the scene .*give depth .*take the views 5-20 degrees apart", err), err
    assert not (tmp_path / "o").exists()


def test_close_photos_only_are_refused(close_views, tmp_path, capsys):
    d = tmp_path / "photos"
    d.mkdir()
    for v in close_views.views:
        write_rgb(d / f"{v.name}.png", v.rgb)
    code, stdout, err = _cli(["run", d, "-o", tmp_path / "o", "--quiet"], capsys)
    assert code == 2 and stdout == "" and len(err.strip().splitlines()) == 1, err
    assert ("degrees apart" in err and "give depth" in err) or "structure from motion registered" in err
    assert not (tmp_path / "o").exists()


def test_close_views_run_with_min_span_zero_warns(close_views):
    """``min_span`` 0 runs anyway (the expert's choice), with the warning line."""
    from graphseg.backends.lifters.sfm import SfmLifter

    no_depth = Scene([v.replace(depth=None) for v in close_views.views], close_views.objects, "close")
    try:
        lifted = SfmLifter(min_span=0.0, stereo=False, fill=False)(no_depth)
    except SceneError as err:  # no point triangulated at all: the other one-line refusal
        assert "triangulated no point" in str(err)
        return
    assert any("degrees apart" in w and "depth is unreliable" in w for w in lifted.meta["warnings"])
