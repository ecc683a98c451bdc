"""Hostile and malformed input: every case exits 2 with one clean stderr line and touches nothing.

Each case builds its input in a private workspace, hashes every file and link
under it, runs the command, and checks: exit code 2, exactly one stderr line
starting ``graphseg: error:`` that names the expected field, no traceback, and
the workspace byte-for-byte unchanged (so no output and no temporary sibling
is left behind and no protected file was modified).
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import shutil
import struct
import zipfile
from pathlib import Path

import numpy as np
import pytest
from scipy.io import savemat

from graphseg.cli import main
from graphseg.config import Config
from graphseg.io import write_scene_folder
from graphseg.io.images import write_png
from graphseg.job import run_job
from graphseg.sim.boxes import Box, intrinsics, look_at, render_boxes
from graphseg.testing.scenes import TWO_BOXES, box_scene

SHAPE = (48, 64)


# ----------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def base(tmp_path_factory):
    root = tmp_path_factory.mktemp("hostile-base")
    write_scene_folder(box_scene(TWO_BOXES, views=3, shape=SHAPE), root / "scene")
    run_job(root / "scene", root / "out", Config.preset("rgbd"))
    _ycbv(root / "ycbv")
    _bop(root / "bop")
    _graspnet(root / "graspnet")
    return root


def _render(eye):
    h, w = SHAPE
    K = intrinsics(w, h, 60)
    T = look_at(eye, [0, 0, 0])
    return render_boxes([Box((0.0, 0.0, 0.05), (0.1, 0.08, 0.1), 0.3)], T, K, (h, w)), K, T


def _ycbv(root):
    root.mkdir()
    for k, fr in enumerate(("000001", "000002")):
        r, K, T = _render([0.3, -0.3 + 0.05 * k, 0.3])
        write_png(root / f"{fr}-color.png", r.rgb)
        write_png(root / f"{fr}-depth.png", np.rint(r.depth * 10000).astype(np.uint16))
        write_png(root / f"{fr}-label.png", r.instances.astype(np.uint8))
        savemat(root / f"{fr}-meta.mat", {"intrinsic_matrix": K, "factor_depth": np.array([[10000]]), "rotation_translation_matrix": np.linalg.inv(T)[:3]})


def _bop(root):
    for d in ("rgb", "depth", "mask_visib"):
        (root / d).mkdir(parents=True)
    cams, gts = {}, {}
    for im, eye in enumerate([[0.3, -0.3, 0.35], [0.35, -0.2, 0.35]]):
        r, K, T = _render(eye)
        w2c = np.linalg.inv(T)
        write_png(root / "rgb" / f"{im:06d}.png", r.rgb)
        write_png(root / "depth" / f"{im:06d}.png", np.rint(r.depth * 10000).astype(np.uint16))
        write_png(root / "mask_visib" / f"{im:06d}_{0:06d}.png", (r.instances == 1).astype(np.uint8) * 255)
        cams[str(im)] = {"cam_K": K.ravel().tolist(), "depth_scale": 0.1, "cam_R_w2c": w2c[:3, :3].ravel().tolist(), "cam_t_w2c": (w2c[:3, 3] * 1000).tolist()}
        gts[str(im)] = [{"obj_id": 5}]
    (root / "scene_camera.json").write_text(json.dumps(cams))
    (root / "scene_gt.json").write_text(json.dumps(gts))


def _graspnet(root):
    cam = root / "realsense"
    for d in ("rgb", "depth", "label", "meta"):
        (cam / d).mkdir(parents=True)
    poses, T0 = [], None
    for k, eye in enumerate([[0.3, -0.3, 0.35], [0.35, -0.2, 0.35]]):
        r, K, T = _render(eye)
        T0 = T if T0 is None else T0
        poses.append(np.linalg.inv(T0) @ T)
        write_png(cam / "rgb" / f"{k:04d}.png", r.rgb)
        write_png(cam / "depth" / f"{k:04d}.png", np.rint(r.depth * 1000).astype(np.uint16))
        write_png(cam / "label" / f"{k:04d}.png", r.instances.astype(np.uint8))
        savemat(cam / "meta" / f"{k:04d}.mat", {"intrinsic_matrix": K, "factor_depth": np.array([[1000.0]])})
    np.save(cam / "camera_poses.npy", np.stack(poses))


class WS:
    """A case's workspace: ``root`` holds copies of the inputs it asks for."""

    def __init__(self, root: Path, base: Path):
        self.root, self.base = root, base

    def copy(self, name: str) -> Path:
        dst = self.root / name
        if not dst.exists():
            shutil.copytree(self.base / name, dst)
        return dst

    @property
    def scene(self) -> Path:
        return self.copy("scene")

    @property
    def out(self) -> Path:
        return self.copy("out")

    def user_folder(self) -> Path:
        d = self.root / "mine"
        d.mkdir(exist_ok=True)
        (d / "thesis.tex").write_text("precious")
        return d

    def edit_json(self, path: Path, fn) -> None:
        doc = json.loads(path.read_text())
        fn(doc)
        path.write_text(json.dumps(doc))

    def view(self, fn) -> Path:
        """Apply ``fn(view0_dict)`` to the first view of scene.json."""
        s = self.scene
        self.edit_json(s / "scene.json", lambda doc: fn(doc["views"][0]))
        return s

    def config(self, text: str, name: str = "c.yaml") -> Path:
        p = self.root / "cfg" / name
        p.parent.mkdir(exist_ok=True)
        p.write_text(text) if isinstance(text, str) else p.write_bytes(text)
        return p


def run_args(ws: WS, *extra, scene=None) -> list:
    return ["run", scene or ws.scene, "-o", ws.root / "new-out", "--quiet", *extra]


# ----------------------------------------------------------------------------- cases
CASES: dict[str, object] = {}


def case(fn):
    CASES[fn.__name__] = fn
    return fn


# output safety
@case
def out_is_the_scene(ws):
    return ["run", ws.scene, "-o", ws.scene, "--quiet"], "input of this command"


@case
def out_is_the_scene_even_with_overwrite(ws):
    return ["run", ws.scene, "-o", ws.scene, "--quiet", "--overwrite"], "input of this command"


@case
def out_inside_the_scene(ws):
    return ["run", ws.scene, "-o", ws.scene / "out", "--quiet", "--overwrite"], "input of this command"


@case
def out_contains_the_scene(ws):
    proj = ws.root / "proj"
    shutil.copytree(ws.base / "scene", proj / "scene")
    return ["run", proj / "scene", "-o", proj, "--quiet", "--overwrite"], "input of this command"


@case
def out_is_a_user_folder(ws):
    return run_args(ws)[:3] + [ws.user_folder(), "--quiet"], "not a graphseg run output"


@case
def out_is_cwd(ws):
    os.chdir(ws.user_folder())
    return ["run", ws.scene, "-o", ".", "--quiet"], "output"


@case
def out_is_symlink_to_user_folder(ws):
    link = ws.root / "link"
    link.symlink_to(ws.user_folder(), target_is_directory=True)
    return ["run", ws.scene, "-o", link, "--quiet", "--overwrite"], "symbolic link"


@case
def out_is_a_file(ws):
    f = ws.root / "notes.txt"
    f.write_text("mine")
    return ["run", ws.scene, "-o", f, "--quiet", "--overwrite"], "not a folder"


@case
def out_under_a_file(ws):
    f = ws.root / "notes.txt"
    f.write_text("mine")
    return ["run", ws.scene, "-o", f / "x", "--quiet"], "output"


@case
def out_is_other_kind_of_output(ws):
    d = ws.root / "synth-out"
    d.mkdir()
    (d / ".graphseg-output").write_text('{"kind": "synth", "version": 1}')
    (d / "scene.json").write_text("{}")
    return ["run", ws.scene, "-o", d, "--quiet"], "synth output"


@case
def out_has_a_fake_marker(ws):
    d = ws.user_folder()
    (d / ".graphseg-output").write_text("not json")
    return ["run", ws.scene, "-o", d, "--quiet"], "not a graphseg run output"


@case
def out_is_the_masks_folder(ws):
    m = ws.root / "masks"
    m.mkdir()
    return ["run", ws.scene, "-o", m, "--masks", m, "--quiet", "--overwrite"], "input of this command"


@case
def out_contains_the_config(ws):
    cfg = ws.config("seed: 1\n")
    return ["run", ws.scene, "-o", cfg.parent, "--config", cfg, "--quiet", "--overwrite"], "input of this command"


@case
def synth_out_is_a_user_folder(ws):
    return ["synth", "-o", ws.user_folder(), "--views", "2"], "not a graphseg synth output"


@case
def synth_out_is_a_symlink(ws):
    link = ws.root / "link"
    link.symlink_to(ws.user_folder(), target_is_directory=True)
    return ["synth", "-o", link, "--overwrite"], "symbolic link"


@case
def demo_out_is_a_user_folder(ws):
    return ["demo", "-o", ws.user_folder(), "--views", "2"], "not a graphseg demo output"


@case
def export_graphml_over_a_user_file(ws):
    f = ws.root / "g.graphml"
    f.write_text("mine")
    return ["export", ws.out, "--graphml", f], "--overwrite"


@case
def export_graphml_into_the_output(ws):
    return ["export", ws.out, "--graphml", ws.out / "g.graphml", "--overwrite"], "input of this command"


@case
def export_ply_over_a_user_folder(ws):
    return ["export", ws.out, "--ply", ws.user_folder()], "not a graphseg export output"


@case
def eval_json_over_a_user_file(ws):
    f = ws.root / "m.json"
    f.write_text("mine")
    return ["eval", ws.out, "--scene", ws.scene, "--json", f], "--overwrite"


# input confinement
@case
def rgb_absolute_path(ws):
    outside = ws.root / "outside.png"
    shutil.copy(ws.scene / "rgb" / "000.png", outside)
    return run_args(ws, scene=ws.view(lambda v: v.update(rgb=str(outside)))), "views[0].rgb: absolute paths"


@case
def rgb_dotdot_escape(ws):
    shutil.copy(ws.scene / "rgb" / "000.png", ws.root / "outside.png")
    return run_args(ws, scene=ws.view(lambda v: v.update(rgb="../outside.png"))), "views[0].rgb: path leaves the scene folder"


@case
def rgb_symlink_leaving_the_folder(ws):
    s = ws.scene
    shutil.copy(s / "rgb" / "000.png", ws.root / "outside.png")
    (s / "rgb" / "000.png").unlink()
    (s / "rgb" / "000.png").symlink_to(ws.root / "outside.png")
    return run_args(ws), "views[0].rgb: path leaves the scene folder"


@case
def depth_dotdot_escape(ws):
    return run_args(ws, scene=ws.view(lambda v: v.update(depth="depth/../../x.png"))), "views[0].depth: path leaves"


@case
def instances_absolute(ws):
    return run_args(ws, scene=ws.view(lambda v: v.update(instances="/etc/passwd"))), "views[0].instances: absolute"


@case
def rgb_not_a_string(ws):
    return run_args(ws, scene=ws.view(lambda v: v.update(rgb=7))), "views[0].rgb"


@case
def plain_images_with_symlink_out(ws):
    d = ws.root / "imgs"
    d.mkdir()
    shutil.copy(ws.base / "scene" / "rgb" / "000.png", ws.root / "outside.png")
    (d / "a.png").symlink_to(ws.root / "outside.png")
    return ["run", d, "-o", ws.root / "new-out", "--quiet"], "path leaves the scene folder"


# malformed scene.json
@case
def scene_json_invalid(ws):
    (ws.scene / "scene.json").write_text("{")
    return run_args(ws), "scene.json: invalid JSON"


@case
def scene_json_deeply_nested(ws):
    (ws.scene / "scene.json").write_text("[" * 100000 + "]" * 100000)
    return run_args(ws), "scene.json"


@case
def scene_json_not_utf8(ws):
    (ws.scene / "scene.json").write_bytes(b"\xff\xfe{\x00")
    return run_args(ws), "scene.json"


@case
def scene_json_a_list(ws):
    (ws.scene / "scene.json").write_text("[]")
    return run_args(ws), "expected a JSON object"


@case
def scene_wrong_version(ws):
    ws.edit_json(ws.scene / "scene.json", lambda d: d.update(version=9))
    return run_args(ws), "version"


@case
def depth_scale_zero(ws):
    ws.edit_json(ws.scene / "scene.json", lambda d: d.update(depth_scale=0))
    return run_args(ws), "depth_scale"


@case
def depth_scale_string(ws):
    ws.edit_json(ws.scene / "scene.json", lambda d: d.update(depth_scale="1000"))
    return run_args(ws), "depth_scale"


@case
def views_empty(ws):
    ws.edit_json(ws.scene / "scene.json", lambda d: d.update(views=[]))
    return run_args(ws), "views: expected a non-empty list"


@case
def view_not_an_object(ws):
    ws.edit_json(ws.scene / "scene.json", lambda d: d["views"].__setitem__(1, 5))
    return run_args(ws), "views[1]"


@case
def duplicate_view_names(ws):
    ws.edit_json(ws.scene / "scene.json", lambda d: d["views"][1].update(name="000"))
    return run_args(ws), "unique"


@case
def focal_length_zero(ws):
    return run_args(ws, scene=ws.view(lambda v: v["K"][0].__setitem__(0, 0.0))), "views[0].K: focal lengths"


@case
def K_with_strings(ws):
    return run_args(ws, scene=ws.view(lambda v: v.update(K=[["a", 0, 0], [0, 1, 0], [0, 0, 1]]))), "views[0].K"


@case
def pose_not_rigid(ws):
    return run_args(ws, scene=ws.view(lambda v: v.update(cam_to_world=np.diag([1.0, 2, 1, 1]).tolist()))), "views[0].cam_to_world"


@case
def objects_malformed(ws):
    ws.edit_json(ws.scene / "scene.json", lambda d: d.update(objects=[{"id": "x"}]))
    return run_args(ws), "objects[0]"


@case
def rgb_corrupt(ws):
    (ws.scene / "rgb" / "001.png").write_bytes(b"\x89PNG\r\n\x1a\ngarbage")
    return run_args(ws), "views[1].rgb: cannot decode"


@case
def rgb_empty_file(ws):
    (ws.scene / "rgb" / "002.png").write_bytes(b"")
    return run_args(ws), "views[2].rgb"


@case
def rgb_truncated_before_iend(ws):
    p = ws.scene / "rgb" / "000.png"
    p.write_bytes(p.read_bytes()[:-12])  # libpng prints "libpng error: ..." on fd 2 for this one
    return run_args(ws), "views[0].rgb: cannot decode image (corrupt, truncated"


@case
def rgb_truncated_to_200_bytes(ws):
    p = ws.scene / "rgb" / "001.png"
    p.write_bytes(p.read_bytes()[:200])
    return run_args(ws), "views[1].rgb: cannot decode"


@case
def depth_truncated(ws):
    p = ws.scene / "depth" / "002.png"
    p.write_bytes(p.read_bytes()[:-12])
    return run_args(ws), "views[2].depth: cannot decode"


@case
def info_on_a_scene_with_a_truncated_png(ws):
    p = ws.scene / "rgb" / "000.png"
    p.write_bytes(p.read_bytes()[:-12])
    return ["info", ws.scene], "views[0].rgb: cannot decode"


@case
def rgb_above_pixel_budget(ws):
    head = b"\x89PNG\r\n\x1a\n" + struct.pack(">I", 13) + b"IHDR" + struct.pack(">IIBBBBB", 100_000, 100_000, 8, 2, 0, 0, 0) + b"\0\0\0\0"
    (ws.scene / "rgb" / "000.png").write_bytes(head)
    return run_args(ws), "above the budget"


@case
def depth_8bit(ws):
    write_png(ws.scene / "depth" / "001.png", np.zeros(SHAPE, np.uint8))
    return run_args(ws), "views[1].depth"


@case
def instances_size_mismatch(ws):
    write_png(ws.scene / "instances" / "001.png", np.zeros((10, 10), np.uint16))
    return run_args(ws), "views[1].instances"


# command-line arguments
@case
def seed_negative(ws):
    return run_args(ws, "--seed", "-1"), "--seed"


@case
def views_unknown_index(ws):
    return run_args(ws, "--views", "0,7"), "unknown view 7"


@case
def views_unknown_name(ws):
    return run_args(ws, "--views", "000,cat"), "unknown view 'cat'"


@case
def views_only_commas(ws):
    return run_args(ws, "--views", ",,"), "--views"


@case
def views_twice(ws):
    return run_args(ws, "--views", "0,000"), "twice"


@case
def step_zero(ws):
    return run_args(ws, "--step", "0"), "--step"


@case
def num_views_zero(ws):
    return run_args(ws, "--num-views", "0"), "--num-views"


@case
def unknown_segmenter(ws):
    return run_args(ws, "--segmenter", "sam9"), "unknown segmenter 'sam9'"


@case
def unknown_segmenter_is_reported_before_any_image_is_read(ws):
    (ws.scene / "rgb" / "000.png").write_bytes(b"corrupt")
    return run_args(ws, "--segmenter", "sam9"), "unknown segmenter 'sam9'"


@case
def unknown_matcher(ws):
    return run_args(ws, "--matcher", "nope"), "unknown matcher 'nope'"


@case
def unknown_lifter(ws):
    return run_args(ws, "--lifter", "nope"), "unknown lifter 'nope'"


@case
def backend_option_syntax(ws):
    return run_args(ws, "--backend-option", "geometric=3"), "NAME.KEY=VALUE"


@case
def backend_option_rejected(ws):
    return run_args(ws, "--backend-option", "reprojection.bogus=1"), "backends.options.reprojection"


@case
def parts_zero(ws):
    return run_args(ws, "--segmenter", "oracle-parts", "--parts", "0"), "--parts"


@case
def masks_folder_missing(ws):
    return run_args(ws, "--masks", ws.root / "nope"), "masks: no such folder"


@case
def masks_with_other_segmenter(ws):
    m = ws.root / "masks"
    m.mkdir()
    return run_args(ws, "--masks", m, "--segmenter", "geometric"), "precomputed"


# config files
@case
def config_alias_bomb(ws):
    lines = ['a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    for i in range(1, 9):
        prev, cur = chr(96 + i), chr(97 + i)
        lines.append(f"{cur}: &{cur} [" + ",".join([f"*{prev}"] * 9) + "]")
    return run_args(ws, "--config", ws.config("\n".join(lines) + "\n")), "aliases expand"


@case
def config_negative_tau(ws):
    return run_args(ws, "--config", ws.config("chamfer_3d:\n  tau: -1\n")), "chamfer_3d: option 'tau'"


@case
def config_negative_pixel_tau(ws):
    return run_args(ws, "--config", ws.config("pixel_match:\n  tau: -0.5\n")), "pixel_match: option 'tau'"


@case
def backend_option_unknown_backend(ws):
    return run_args(ws, "--backend-option", "nosuch.k=1"), "unknown backend 'nosuch'"


@case
def backend_option_unknown_key(ws):
    return run_args(ws, "--backend-option", "geometric.bogus=3"), "unknown option 'bogus'"


@case
def config_stage_negative_tau(ws):
    return run_args(ws, "--config", ws.config("stages:\n  - [pixel_match]\n  - [{chamfer_3d: {tau: -1}}]\n")), "chamfer_3d: option 'tau'"


@case
def config_stage_misspelt_option(ws):
    return run_args(ws, "--config", ws.config("stages:\n  - [{pixel_match: {taus: 0.3}}]\n")), "unknown option 'taus'"


@case
def config_stage_unknown_criterion(ws):
    return run_args(ws, "--config", ws.config("stages:\n  - [pixel_matsh]\n")), "pixel_matsh"


@case
def config_negative_voxel(ws):
    return run_args(ws, "--config", ws.config("output:\n  voxel_size: -0.01\n")), "output.voxel_size"


@case
def config_negative_seed(ws):
    return run_args(ws, "--config", ws.config("seed: -1\n")), "seed"


@case
def config_unknown_key(ws):
    return run_args(ws, "--config", ws.config("pixel_mach:\n  tau: 0.3\n")), "pixel_mach"


@case
def config_top_level_list(ws):
    return run_args(ws, "--config", ws.config("- 1\n- 2\n")), "mapping"


@case
def config_binary(ws):
    return run_args(ws, "--config", ws.config(b"\xff\xfe\x00garbage")), "config"


@case
def config_missing(ws):
    return run_args(ws, "--config", ws.root / "none.yaml"), "config: file not found"


@case
def config_infinite_stage_tau(ws):
    return run_args(ws, "--config", ws.config("stages:\n  - [pixel_match]\n  - [{chamfer_3d: {tau: .inf}}]\n")), "stages.1.0: chamfer_3d: option 'tau': expected a finite number (got inf)"


@case
def config_infinite_legacy_tau(ws):
    return run_args(ws, "--config", ws.config("chamfer_3d:\n  tau: .inf\n")), "chamfer_3d: option 'tau': expected a finite number (got inf)"


@case
def config_nan_plane_tolerance(ws):
    return run_args(ws, "--config", ws.config("background:\n  plane_tolerance: .nan\n")), "background.plane_tolerance: Input should be a finite number (got nan)"


@case
def config_infinite_max_distance(ws):
    return run_args(ws, "--config", ws.config("background:\n  max_distance: .inf\n")), "background.max_distance: Input should be a finite number (got inf)"


@case
def config_infinite_translation(ws):
    return run_args(ws, "--config", ws.config("pairs:\n  max_translation: .inf\n")), "pairs.max_translation: Input should be a finite number (got inf)"


@case
def config_infinite_backend_option(ws):
    return run_args(ws, "--config", ws.config("backends:\n  options:\n    geometric: {min_area: .inf}\n")), "backends.options: geometric.min_area: expected a finite number (got inf)"


@case
def backend_option_infinite(ws):
    return run_args(ws, "--backend-option", "geometric.min_area=.inf"), "--backend-option: geometric.min_area: expected a finite number"


@case
def config_json_syntax(ws):
    return run_args(ws, "--config", ws.config('{"seed": 3,\n  "masks": {"min_area": 5,}}', name="c.json")), "config: line 2, column 27: Expecting property name"


@case
def config_yaml_syntax(ws):
    return run_args(ws, "--config", ws.config("background:\n  plane: true\n - x\n")), "config: line 3, column 2: expected <block end>"


@case
def config_misspelt_section_key(ws):
    return run_args(ws, "--config", ws.config("background:\n  plane_tolerence: 0.02\n")), "background.plane_tolerence: unknown key 'plane_tolerence'; did you mean 'plane_tolerance'?"


# precomputed masks
def _masks(ws):
    m = ws.root / "masks"
    m.mkdir()
    for n in ("000", "001", "002"):
        write_png(m / f"{n}.png", np.zeros(SHAPE, np.uint16))
    return m


@case
def masks_npz_corrupt(ws):
    m = _masks(ws)
    (m / "000.png").unlink()
    (m / "000.npz").write_bytes(b"PK\x03\x04 not a zip")
    return run_args(ws, "--masks", m), "masks"


@case
def masks_npz_without_key(ws):
    m = _masks(ws)
    (m / "000.png").unlink()
    np.savez(m / "000.npz", other=np.zeros((1, *SHAPE), bool))
    return run_args(ws, "--masks", m), "masks"


@case
def masks_wrong_size(ws):
    m = _masks(ws)
    write_png(m / "001.png", np.zeros((5, 5), np.uint16))
    return run_args(ws, "--masks", m), "masks"


# tampered result files
def _rewrite_member(npz: Path, member: str, data: bytes) -> None:
    src = npz.read_bytes()
    with zipfile.ZipFile(io.BytesIO(src)) as zin, zipfile.ZipFile(npz, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            zout.writestr(item.filename, data if item.filename == member else zin.read(item.filename))


@case
def result_truncated(ws):
    p = ws.out / "result.npz"
    p.write_bytes(p.read_bytes()[:300])
    return ["export", ws.out, "--ply", ws.root / "ply"], "result.npz"


@case
def result_declares_huge_array(ws):
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False, "shape": (2**31, 16)})
    _rewrite_member(ws.out / "result.npz", "arrays/object_points.npy", buf.getvalue() + b"\0" * 64)
    return ["info", ws.out], "result.npz"


@case
def result_wrong_kind(ws):
    with zipfile.ZipFile(ws.out / "result.npz") as z:
        header = json.loads(bytes(np.load(io.BytesIO(z.read("__header__.npy")))).decode())
    header["meta"]["kind"] = "other"
    buf = io.BytesIO()
    np.save(buf, np.frombuffer(json.dumps(header).encode(), np.uint8))
    _rewrite_member(ws.out / "result.npz", "__header__.npy", buf.getvalue())
    return ["export", ws.out, "--ply", ws.root / "ply"], "kind"


@case
def result_ptr_tampered(ws):
    buf = io.BytesIO()
    np.save(buf, np.array([0, 5, 3], np.int64))
    _rewrite_member(ws.out / "result.npz", "arrays/object_ptr.npy", buf.getvalue())
    return ["export", ws.out, "--ply", ws.root / "ply"], "object_ptr"


@case
def run_json_invalid(ws):
    (ws.out / "run.json").write_text("{nope")
    return ["eval", ws.out], "run.json"


@case
def eval_not_an_output(ws):
    return ["eval", ws.user_folder()], "not a graphseg output folder"


@case
def eval_scene_with_other_views(ws):
    ws.edit_json(ws.scene / "scene.json", lambda d: [v.update(name="x" + v["name"]) for v in d["views"]])
    return ["eval", ws.out, "--scene", ws.scene], "views"


@case
def export_stage_out_of_range(ws):
    return ["export", ws.out, "--graphml", ws.root / "g.graphml", "--stage", "5"], "--stage"


@case
def export_nothing(ws):
    return ["export", ws.out], "name at least one"


# datasets
def _ycbv_meta(ws, **changes):
    d = ws.copy("ycbv")
    from scipy.io import loadmat

    m = {k: v for k, v in loadmat(d / "000001-meta.mat").items() if not k.startswith("__")}
    m.update(changes)
    savemat(d / "000001-meta.mat", m)
    return d


@case
def ycbv_factor_depth_zero(ws):
    return run_args(ws, scene=_ycbv_meta(ws, factor_depth=np.array([[0]]))), "factor_depth"


@case
def ycbv_fx_zero(ws):
    return run_args(ws, scene=_ycbv_meta(ws, intrinsic_matrix=np.diag([0.0, 50, 1]))), "intrinsic_matrix: focal lengths"


@case
def ycbv_K_nan(ws):
    return run_args(ws, scene=_ycbv_meta(ws, intrinsic_matrix=np.full((3, 3), np.nan))), "intrinsic_matrix"


@case
def ycbv_pose_not_rigid(ws):
    return run_args(ws, scene=_ycbv_meta(ws, rotation_translation_matrix=np.ones((3, 4)))), "rotation_translation_matrix"


@case
def ycbv_pose_wrong_shape(ws):
    return run_args(ws, scene=_ycbv_meta(ws, rotation_translation_matrix=np.ones((2, 2)))), "rotation_translation_matrix"


@case
def ycbv_factor_depth_text(ws):
    return run_args(ws, scene=_ycbv_meta(ws, factor_depth="abc")), "factor_depth"


def _bop_cam(ws, fn):
    d = ws.copy("bop")
    ws.edit_json(d / "scene_camera.json", lambda doc: fn(doc["0"]))
    return d


@case
def bop_cam_K_zero(ws):
    return run_args(ws, scene=_bop_cam(ws, lambda c: c.update(cam_K=[0] * 9))), "cam_K"


@case
def bop_cam_K_short(ws):
    return run_args(ws, scene=_bop_cam(ws, lambda c: c.update(cam_K=[1, 2, 3]))), "cam_K"


@case
def bop_rotation_not_rigid(ws):
    return run_args(ws, scene=_bop_cam(ws, lambda c: c.update(cam_R_w2c=[2, 0, 0, 0, 1, 0, 0, 0, 1]))), "cam_R_w2c"


@case
def bop_depth_scale_negative(ws):
    return run_args(ws, scene=_bop_cam(ws, lambda c: c.update(depth_scale=-1))), "depth_scale"


@case
def bop_scene_camera_bad_key(ws):
    d = ws.copy("bop")
    ws.edit_json(d / "scene_camera.json", lambda doc: doc.update(abc=doc["0"]))
    return run_args(ws, scene=d), "scene_camera"


@case
def bop_gt_obj_id_missing(ws):
    d = ws.copy("bop")
    ws.edit_json(d / "scene_gt.json", lambda doc: doc["0"][0].pop("obj_id"))
    return run_args(ws, scene=d), "obj_id"


@case
def graspnet_poses_wrong_shape(ws):
    d = ws.copy("graspnet")
    np.save(d / "realsense" / "camera_poses.npy", np.zeros((2, 3, 3)))
    return run_args(ws, scene=d), "camera_poses"


@case
def graspnet_poses_not_rigid(ws):
    d = ws.copy("graspnet")
    np.save(d / "realsense" / "camera_poses.npy", np.ones((2, 4, 4)))
    return run_args(ws, scene=d), "camera_poses"


@case
def graspnet_poses_corrupt(ws):
    d = ws.copy("graspnet")
    (d / "realsense" / "camera_poses.npy").write_bytes(b"\x93NUMPY garbage")
    return run_args(ws, scene=d), "camera_poses"


@case
def graspnet_factor_depth_zero(ws):
    d = ws.copy("graspnet")
    savemat(d / "realsense" / "meta" / "0000.mat", {"intrinsic_matrix": np.eye(3), "factor_depth": np.array([[0.0]])})
    return run_args(ws, scene=d), "factor_depth"


# synth / demo arguments (rejected before pybullet is needed)
@case
def synth_zero_views(ws):
    return ["synth", "-o", ws.root / "s", "--views", "0"], "--views"


@case
def synth_too_many_objects(ws):
    return ["synth", "-o", ws.root / "s", "--objects", "99"], "--objects"


@case
def synth_negative_seed(ws):
    return ["synth", "-o", ws.root / "s", "--seed", "-1"], "--seed"


@case
def synth_tiny_size(ws):
    return ["synth", "-o", ws.root / "s", "--size", "10x10"], "--size"


@case
def demo_zero_views(ws):
    return ["demo", "-o", ws.root / "d", "--views", "0"], "--views"


# ----------------------------------------------------------------------------- the test
def snapshot(root: Path) -> dict[str, str]:
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            p = Path(dirpath) / name
            rel = str(p.relative_to(root))
            if p.is_symlink():
                out[rel] = "link:" + os.readlink(p)
            elif p.is_dir():
                out[rel] = "dir"
            else:
                out[rel] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def test_enough_cases():
    assert len(CASES) >= 60


@pytest.mark.parametrize("name", sorted(CASES))
def test_hostile(name, base, tmp_path, capfd, monkeypatch):
    ws_root = tmp_path / "ws"
    ws_root.mkdir()
    (ws_root / "cwd").mkdir()
    monkeypatch.chdir(ws_root / "cwd")
    ws = WS(ws_root, base)
    argv, fragment = CASES[name](ws)
    before = snapshot(ws_root)
    code = main([str(a) for a in argv])
    err = capfd.readouterr().err  # fd level: native library lines would show here too
    lines = err.strip().splitlines()
    assert code == 2, err
    assert len(lines) == 1 and lines[0].startswith("graphseg: error: "), err
    assert "Traceback" not in err
    assert fragment in lines[0], (fragment, lines[0])
    assert snapshot(ws_root) == before  # nothing written, nothing left behind, inputs unchanged


# ----------------------------------------------------------------------------- library boundaries
def test_graphml_declaring_a_huge_shape_is_refused_before_allocating(tmp_path):
    from graphseg.graphs import GraphValidationError, read_graphml

    schema = json.dumps({"level": "mask", "node": {"bbox": {"dtype": "<i8", "shape": [10**6, 10**6]}}, "edge": {}, "meta": {}})
    text = (
        '<?xml version="1.0" encoding="utf-8"?><graphml xmlns="http://graphml.graphdrawing.org/xmlns">'
        '<key id="d0" for="graph" attr.name="graphseg_schema" attr.type="string"/>'
        f'<graph edgedefault="undirected"><data key="d0">{schema.replace("<", "&lt;").replace(chr(34), "&quot;")}</data>'
        '<node id="0"/><node id="1"/></graph></graphml>'
    )
    p = tmp_path / "bomb.graphml"
    p.write_text(text)
    assert p.stat().st_size < 1000
    with pytest.raises(GraphValidationError, match="more than the file can hold"):
        read_graphml(p)


def test_npz_declared_sizes_are_checked(tmp_path):
    from graphseg.graphs import GraphValidationError
    from graphseg.graphs.native import check_npz_sizes, load_native

    np.savez_compressed(tmp_path / "a.npz", x=np.zeros(1000))
    assert check_npz_sizes(tmp_path / "a.npz")["x"][0] == (1000,)
    with pytest.raises(GraphValidationError, match="limit"):
        check_npz_sizes(tmp_path / "a.npz", limit=100)
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False, "shape": (10**9,)})
    with zipfile.ZipFile(tmp_path / "b.npz", "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("__header__.npy", buf.getvalue() + b"\0" * 16)
    with pytest.raises(GraphValidationError, match="tampered"):
        load_native(tmp_path / "b.npz")


def test_yaml_alias_bomb_is_bounded_quickly():
    import time

    from graphseg.config import load_yaml_text

    lines = ['a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    for i in range(1, 9):
        prev, cur = chr(96 + i), chr(97 + i)
        lines.append(f"{cur}: &{cur} [" + ",".join([f"*{prev}"] * 9) + "]")
    text = "\n".join(lines)
    assert len(text) < 600
    t = time.perf_counter()
    with pytest.raises(ValueError, match="aliases expand"):
        load_yaml_text(text)
    assert time.perf_counter() - t < 2


def _two_boxes():
    from graphseg.testing.scenes import two_boxes_scene

    return two_boxes_scene(views=3, shape=SHAPE)


def test_segment_validates_the_scene_like_run():
    from graphseg.method.segment import segment
    from graphseg.scene import Scene, SceneError

    scene, masks, matches = _two_boxes()
    dup = Scene([scene.views[0], scene.views[1].replace(name=scene.views[0].name), scene.views[2]])
    with pytest.raises(SceneError, match="unique"):
        segment(dup, masks, matches)
    bad = Scene([scene.views[0].replace(cam_to_world=np.diag([1.0, 2, 1, 1])), *scene.views[1:]])
    with pytest.raises(SceneError, match="rigid"):
        segment(bad, masks, matches)


@pytest.mark.parametrize(
    "mask, expect",
    [
        (np.zeros((5, 5), np.int32), r"expected an int label image \[48, 64\] or a bool stack \[K, 48, 64\] \(got int32 \[5, 5\]\)"),
        (np.zeros(SHAPE, np.float32), r"\(got float32 \[48, 64\]\)"),
        ([np.zeros((3, 3), bool)], r"masks\[0\]: expected a bool mask \[48, 64\] \(got bool \[3, 3\]\)"),
        ("masks.png", r"\(got str\)"),
    ],
)
def test_segment_rejects_wrong_mask_shapes_and_dtypes(mask, expect):
    from graphseg.method.segment import segment
    from graphseg.scene import SceneError

    scene, masks, matches = _two_boxes()
    with pytest.raises(SceneError, match=expect):
        segment(scene, [mask, *masks[1:]], matches)


def test_segment_treats_non_finite_points_as_invalid():
    from graphseg.method.segment import segment
    from graphseg.scene import Scene

    scene, masks, matches = _two_boxes()
    rng = np.random.default_rng(0)
    with_inf, with_nan = [], []
    for v in scene.views:
        hole = rng.random(v.shape) < 0.05
        sign = np.where(rng.random((int(hole.sum()), 1)) < 0.5, np.inf, -np.inf)
        p = v.points.copy()
        p[hole] = sign
        with_inf.append(v.replace(points=p))
        q = v.points.copy()
        q[hole] = np.nan
        with_nan.append(v.replace(points=q))
    before = [v.points.copy() for v in with_inf]
    a = segment(Scene(with_inf, scene.objects), masks, matches)
    b = segment(Scene(with_nan, scene.objects), masks, matches)
    assert a.num_objects == b.num_objects
    assert all(np.array_equal(x, y) for x, y in zip(a.labels, b.labels))  # inf is exactly an invalid pixel
    assert np.isfinite(a.object_points.points).all()
    assert all(np.array_equal(x, v.points, equal_nan=True) for x, v in zip(before, with_inf))  # inputs untouched


def test_segment_degenerate_scenes_give_valid_results():
    from graphseg.method.segment import segment

    scene, masks, matches = _two_boxes()
    r = segment(scene, [np.zeros(SHAPE, np.int32)] * 3, matches)
    assert r.num_objects == 0 and r.info["warnings"] and all((lab == 0).all() for lab in r.labels)
    one = segment(scene.select([0]), masks[:1], {})
    assert one.info["warnings"] == ["only one view: no cross-view evidence, every mask is its own object"]


def test_coarsen_rejects_bad_cluster_vectors():
    from graphseg.graphs import CorrespondenceGraph, GraphValidationError, coarsen

    g = CorrespondenceGraph(3, edge_index=[[0], [1]])
    with pytest.raises(GraphValidationError, match="in \\[0, 3\\)"):
        coarsen(g, np.array([0, 1, 5]))
    with pytest.raises(GraphValidationError, match="canonical"):
        coarsen(g, np.array([0, 2, 2]))  # id 1 unused: would make an empty node
    with pytest.raises(GraphValidationError, match="canonical"):
        coarsen(g, np.array([1, 0, 0]))
    assert coarsen(CorrespondenceGraph(0), np.zeros(0, np.int64)).num_nodes == 0


def test_pixel_budget_is_overridable(tmp_path, monkeypatch):
    from graphseg.io.images import read_rgb
    from graphseg.scene import SceneError

    write_png(tmp_path / "a.png", np.zeros((40, 50, 3), np.uint8))
    monkeypatch.setenv("GRAPHSEG_MAX_PIXELS", "1000")
    with pytest.raises(SceneError, match="50x40 .* above the budget"):
        read_rgb(tmp_path / "a.png")
    monkeypatch.setenv("GRAPHSEG_MAX_PIXELS", "2000")
    assert read_rgb(tmp_path / "a.png").shape == (40, 50, 3)


def test_memory_estimate_stops_a_run_before_it_starts(monkeypatch, tmp_path):
    import graphseg.job as job
    from graphseg.scene import SceneError

    monkeypatch.setattr(job, "available_memory", lambda: 10_000)
    with pytest.raises(SceneError, match="memory: 3 views of 64x48 need about"):
        run_job(box_scene(TWO_BOXES, views=3, shape=SHAPE), tmp_path / "o")
    assert not (tmp_path / "o").exists()


# ----------------------------------------------------------------------------- zip bombs (issue 19)
def _write_npz_with_bomb(npz: Path, member: str, shape: tuple[int, ...], dtype: str = "<u2", src: bytes | None = None) -> int:
    """Write ``npz`` (the members of ``src``, if given) with ``member`` replaced by zeros of ``shape``, streamed through deflate.

    Nothing of the array's size is allocated: a 70 MB entry costs 8 MiB of memory
    and about 70 KB of file. Returns the declared size in bytes.
    """
    head = io.BytesIO()
    np.lib.format.write_array_header_1_0(head, {"descr": dtype, "fortran_order": False, "shape": shape})
    nbytes = int(np.prod(shape)) * np.dtype(dtype).itemsize
    chunk = bytes(8 * 2**20)
    others = {}
    if src is not None:
        with zipfile.ZipFile(io.BytesIO(src)) as zin:
            others = {i.filename: zin.read(i.filename) for i in zin.infolist() if i.filename != member}
    with zipfile.ZipFile(npz, "w", zipfile.ZIP_DEFLATED) as zout:
        for name, data in others.items():
            zout.writestr(name, data)
        info = zipfile.ZipInfo(member)
        info.compress_type = zipfile.ZIP_DEFLATED
        with zout.open(info, "w", force_zip64=True) as f:
            f.write(head.getvalue())
            left = nbytes
            while left:
                f.write(chunk[: min(left, len(chunk))])
                left -= min(left, len(chunk))
    return nbytes + len(head.getvalue())


def test_npz_zip_bomb_is_refused_before_decompressing(tmp_path, monkeypatch):
    import time
    import tracemalloc

    from graphseg.graphs import GraphValidationError
    from graphseg.graphs.native import BOMB_MIN_BYTES, BOMB_RATIO, bomb_limit, check_npz_sizes

    monkeypatch.setenv("GRAPHSEG_MAX_PIXELS", "1000000")  # the bomb limit drops to its floor, 64 MiB
    assert bomb_limit() == BOMB_MIN_BYTES
    t = time.perf_counter()
    size = _write_npz_with_bomb(tmp_path / "bomb.npz", "x.npy", (6000, 6000))  # 72 MB of zeros, 70 KB on disk
    assert size > BOMB_MIN_BYTES and (tmp_path / "bomb.npz").stat().st_size * BOMB_RATIO < size
    tracemalloc.start()
    try:
        with pytest.raises(GraphValidationError, match=r"bomb.npz: x: 68\.7 MiB compressed into .* KiB \(10\d\d:1\); refused as a zip bomb before decompressing"):
            check_npz_sizes(tmp_path / "bomb.npz")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 8 * 2**20  # nothing of the 72 MB was allocated
    assert time.perf_counter() - t < 5
    # below the size floor the same ratio is fine: an all-zero label image of a real view
    np.savez_compressed(tmp_path / "zeros.npz", labels=np.zeros((480, 640), np.uint16))
    assert check_npz_sizes(tmp_path / "zeros.npz")["labels"][0] == (480, 640)


def test_real_outputs_are_far_from_the_bomb_rule(base):
    from graphseg.graphs.native import BOMB_RATIO, bomb_limit

    with zipfile.ZipFile(base / "out" / "result.npz") as z:
        worst = max(i.file_size / max(i.compress_size, 1) for i in z.infolist())
        largest = max(i.file_size for i in z.infolist())
    assert worst < BOMB_RATIO and largest < bomb_limit()


@pytest.mark.parametrize("command", ["info", "eval"])
def test_result_zip_bomb_exits_2_naming_the_entry(command, base, tmp_path, capfd, monkeypatch):
    monkeypatch.setenv("GRAPHSEG_MAX_PIXELS", "1000000")
    out = tmp_path / "out"
    shutil.copytree(base / "out", out)
    npz = out / "result.npz"
    _write_npz_with_bomb(npz, "arrays/labels_0.npy", (6000, 6000), src=npz.read_bytes())
    code = main([command, str(out)])
    lines = capfd.readouterr().err.strip().splitlines()
    assert code == 2 and len(lines) == 1, lines
    assert lines[0].startswith(f"graphseg: error: {npz}: arrays/labels_0: 68.7 MiB compressed into "), lines[0]
    assert "refused as a zip bomb before decompressing" in lines[0]


def test_truncated_png_gives_exactly_one_line_in_a_fresh_process(base, tmp_path):
    """libpng writes its own error line to fd 2; a fresh process sees it exactly as a user does."""
    import subprocess
    import sys

    scene = tmp_path / "scene"
    shutil.copytree(base / "scene", scene)
    png = scene / "rgb" / "000.png"
    png.write_bytes(png.read_bytes()[:-12])
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    entry = "import sys\nfrom graphseg.cli import main\nsys.exit(main(sys.argv[1:]))"
    for args in (["info", scene], ["run", scene, "-o", tmp_path / "o"]):
        r = subprocess.run([sys.executable, "-c", entry, *map(str, args)], capture_output=True, text=True, env=env, timeout=120)
        assert r.returncode == 2 and r.stderr.splitlines() == [f"graphseg: error: {png}: views[0].rgb: cannot decode image (corrupt, truncated or not an image)"], r.stderr
    assert not (tmp_path / "o").exists()

