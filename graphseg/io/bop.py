"""BOP scene reader.

Layout: ``SCENE/{rgb,depth,mask_visib}/`` with ``scene_camera.json`` (per image:
``cam_K``, ``cam_R_w2c``, ``cam_t_w2c`` in mm, ``depth_scale``) and
``scene_gt.json``. Instance ``k`` (1-based) is the k-th entry of an image's
``scene_gt`` list, whose order is the same in every image of a scene, and is
named after its ``obj_id``; ``mask_visib/{im:06d}_{k-1:06d}.png`` gives its
visible mask. BOP depth is in units of ``depth_scale`` millimetres.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..scene import Scene, SceneError, View
from .checks import intrinsics, matrix, positive, reading, rigid
from .files import read_json
from .images import check_size, confine, read_label, read_rgb, read_uint16, require_folder
from .select import select_indices

__all__ = ["read_bop", "is_bop"]


def is_bop(path: str | os.PathLike[str]) -> bool:
    return (Path(path) / "scene_camera.json").exists()


def _json(path: Path) -> Any:
    if not path.is_file():
        raise SceneError("file not found", where=str(path), field=path.stem)
    return read_json(path, field=path.stem)


def _image(folder: Path, im: int) -> Path:
    for ext in (".png", ".jpg", ".tif"):
        p = folder / f"{im:06d}{ext}"
        if p.exists():
            return p
    raise SceneError(f"no image {im:06d}", where=str(folder), field=folder.name)


def read_bop(
    path: str | os.PathLike[str],
    *,
    views: Sequence[int | str] | None = None,
    step: int | None = None,
    num_views: int | None = None,
) -> Scene:
    """Read one BOP scene folder."""
    root = require_folder(path)
    cams = _json(root / "scene_camera.json")
    gts = _json(root / "scene_gt.json") if (root / "scene_gt.json").exists() else {}
    cw = str(root / "scene_camera.json")
    if not isinstance(cams, dict):
        raise SceneError("expected a JSON object keyed by image id", where=cw, field="scene_camera")
    if not isinstance(gts, dict):
        raise SceneError("expected a JSON object keyed by image id", where=str(root / "scene_gt.json"), field="scene_gt")
    with reading(cw, "scene_camera"):
        keys = {int(k): k for k in cams}
        ims = sorted(keys)
    if any(im < 0 for im in ims):
        raise SceneError("image ids must be >= 0", where=cw, field="scene_camera")
    if not ims:
        raise SceneError("no images", where=str(root / "scene_camera.json"), field="scene_camera")
    names = [f"{im:06d}" for im in ims]
    idx = select_indices(len(ims), views=views, step=step, num_views=num_views, names=names, where=str(root))
    rgb_dir = root / "rgb" if (root / "rgb").exists() else root / "gray"
    out: list[View] = []
    objects: dict[int, str] = {}
    for i in idx:
        im = ims[i]
        cam = cams[keys[im]]
        where = str(root / "scene_camera.json")
        if not isinstance(cam, dict):
            raise SceneError("expected an object", where=where, field=keys[im])
        if "cam_R_w2c" not in cam or "cam_t_w2c" not in cam:
            raise SceneError(
                f"image {im} has no cam_R_w2c/cam_t_w2c: this BOP scene has no camera poses, which multi-view segmentation needs",
                where=where,
                field="cam_R_w2c",
            )
        f = f"{im}"
        with reading(where, f):
            if not isinstance(cam, dict):
                raise SceneError("expected an object", where=where, field=f)
            K = intrinsics(cam.get("cam_K"), where=where, field=f"{f}.cam_K")
            w2c = np.eye(4)
            w2c[:3, :3] = matrix(cam["cam_R_w2c"], (3, 3), where=where, field=f"{f}.cam_R_w2c")
            w2c[:3, 3] = matrix(cam["cam_t_w2c"], (3,), where=where, field=f"{f}.cam_t_w2c") / 1000.0
            w2c = rigid(w2c, where=where, field=f"{f}.cam_R_w2c")
            T = np.linalg.inv(w2c)
            dscale = positive(cam.get("depth_scale", 1.0), where=where, field=f"{f}.depth_scale")
        rgb = read_rgb(confine(root, _image(rgb_dir, im).relative_to(root), where=str(root), field="rgb"))
        depth = None
        if (root / "depth").exists():
            dpath = confine(root, _image(root / "depth", im).relative_to(root), where=str(root), field="depth")
            raw = check_size(read_uint16(dpath), rgb, dpath, "depth")
            depth = raw.astype(np.float32) * np.float32(dscale / 1000.0)
        inst = None
        entries = gts.get(keys[im], gts.get(str(im), []))
        gw = str(root / "scene_gt.json")
        if not isinstance(entries, list):
            raise SceneError("expected a list", where=gw, field=f)
        if entries and (root / "mask_visib").exists():
            inst = np.zeros(rgb.shape[:2], np.int32)
            for k, e in enumerate(entries):
                mpath = confine(root, f"mask_visib/{im:06d}_{k:06d}.png", where=str(root), field="mask_visib")
                m = check_size(read_label(mpath, field="mask_visib"), rgb, mpath, "mask_visib") > 0
                inst[m] = k + 1
                with reading(gw, f"{f}[{k}].obj_id"):
                    objects.setdefault(k + 1, f"obj_{int(e['obj_id']):06d}")
        out.append(View(f"{im:06d}", rgb, depth=depth, K=K, cam_to_world=T, instances=inst))
    return Scene(out, objects, name=f"bop-{root.name}", meta={"source": str(root), "format": "bop"})
