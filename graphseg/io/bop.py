"""BOP scene reader.

Layout: ``SCENE/{rgb,depth,mask_visib}/`` with ``scene_camera.json`` (per image:
``cam_K``, ``cam_R_w2c``, ``cam_t_w2c`` in mm, ``depth_scale``) and
``scene_gt.json``. Instance ``k`` (1-based) is the k-th entry of an image's
``scene_gt`` list, whose order is the same in every image of a scene, and is
named after its ``obj_id``; ``mask_visib/{im:06d}_{k-1:06d}.png`` gives its
visible mask. BOP depth is in units of ``depth_scale`` millimetres.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..scene import Scene, SceneError, View
from .images import check_size, read_label, read_rgb, read_uint16, require_folder
from .select import select_indices

__all__ = ["read_bop", "is_bop"]


def is_bop(path: str | os.PathLike[str]) -> bool:
    return (Path(path) / "scene_camera.json").exists()


def _json(path: Path) -> Any:
    if not path.is_file():
        raise SceneError("file not found", where=str(path), field=path.stem)
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as err:
        raise SceneError(f"invalid JSON ({err})", where=str(path), field=path.stem) from err


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
    ims = sorted(int(k) for k in cams)
    if not ims:
        raise SceneError("no images", where=str(root / "scene_camera.json"), field="scene_camera")
    names = [f"{im:06d}" for im in ims]
    idx = select_indices(len(ims), views=views, step=step, num_views=num_views, names=names, where=str(root))
    rgb_dir = root / "rgb" if (root / "rgb").exists() else root / "gray"
    out: list[View] = []
    objects: dict[int, str] = {}
    for i in idx:
        im = ims[i]
        cam = cams[str(im)]
        where = str(root / "scene_camera.json")
        if "cam_R_w2c" not in cam or "cam_t_w2c" not in cam:
            raise SceneError(
                f"image {im} has no cam_R_w2c/cam_t_w2c: this BOP scene has no camera poses, which multi-view segmentation needs",
                where=where,
                field="cam_R_w2c",
            )
        K = np.asarray(cam["cam_K"], np.float64).reshape(3, 3)
        w2c = np.eye(4)
        w2c[:3, :3] = np.asarray(cam["cam_R_w2c"], np.float64).reshape(3, 3)
        w2c[:3, 3] = np.asarray(cam["cam_t_w2c"], np.float64).reshape(3) / 1000.0
        rgb = read_rgb(_image(rgb_dir, im))
        depth = None
        if (root / "depth").exists():
            raw = check_size(read_uint16(_image(root / "depth", im)), rgb, root / "depth", "depth")
            depth = raw.astype(np.float32) * np.float32(float(cam.get("depth_scale", 1.0)) / 1000.0)
        inst = None
        entries = gts.get(str(im), [])
        if entries and (root / "mask_visib").exists():
            inst = np.zeros(rgb.shape[:2], np.int32)
            for k, e in enumerate(entries):
                m = read_label(root / "mask_visib" / f"{im:06d}_{k:06d}.png", field="mask_visib") > 0
                inst[m] = k + 1
                objects.setdefault(k + 1, f"obj_{int(e['obj_id']):06d}")
        out.append(View(f"{im:06d}", rgb, depth=depth, K=K, cam_to_world=np.linalg.inv(w2c), instances=inst))
    return Scene(out, objects, name=f"bop-{root.name}", meta={"source": str(root), "format": "bop"})
