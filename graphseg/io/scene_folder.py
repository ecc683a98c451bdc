"""The native scene folder, format versions 1 and 2.

::

    SCENE/
      scene.json
      rgb/000.png          8-bit RGB (PNG or JPEG), any file names listed in scene.json
      depth/000.png        optional, 16-bit PNG, metres = value / depth_scale, 0 = invalid
      instances/000.png    optional ground truth, 16-bit PNG, 0 = background, ids consistent across views
      points/000.npz       version 2 only, optional: world point map (graphseg.io.precomputed format:
                           points [H, W, 3] float32, NaN = invalid, optional confidence [H, W])

``scene.json``::

    {"format": "graphseg-scene", "version": 1, "depth_scale": 1000.0,
     "views": [{"name": "000", "rgb": "rgb/000.png", "depth": "depth/000.png",
                "instances": "instances/000.png", "K": [[fx, 0, cx], [0, fy, cy], [0, 0, 1]],
                "cam_to_world": [[...], [...], [...], [0, 0, 0, 1]]}],
     "objects": [{"id": 1, "name": "mug"}]}

Cameras use OpenCV axes; ``cam_to_world`` maps camera to world coordinates in
metres. ``depth``, ``instances``, ``objects`` and each view's ``K`` /
``cam_to_world`` are optional. A folder of plain images with no
``scene.json`` is a valid RGB-only scene.

Version 2 adds the optional per-view ``"points": "points/000.npz"`` entry (for
scenes lifted by a learned model, which have point maps but no depth). The
writer writes version 2 only when some view has a point map and no depth
(otherwise version 1, readable by older graphseg); the reader reads both.

Every problem raises :class:`~graphseg.scene.SceneError` naming the file and
the field.

Examples
--------
>>> import tempfile, os, numpy as np
>>> from graphseg.scene import Scene, View
>>> v = View("a", np.zeros((4, 5, 3), np.uint8), depth=np.full((4, 5), 0.5, np.float32),
...          K=np.eye(3), cam_to_world=np.eye(4))
>>> with tempfile.TemporaryDirectory() as d:
...     _ = write_scene_folder(Scene([v]), os.path.join(d, "s"))
...     back = read_scene_folder(os.path.join(d, "s"))
>>> back.views[0].name, float(back.views[0].depth[0, 0])
('a', 0.5)
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..scene import Scene, SceneError, View, is_rigid
from .files import read_json
from .images import (
    check_size,
    confine,
    read_label,
    read_rgb,
    read_uint16,
    unique_file_names,
    write_png,
    write_rgb,
)
from .select import select_indices

__all__ = ["read_scene_folder", "write_scene_folder", "fill_scene_folder", "FORMAT", "VERSION", "IMAGE_SUFFIXES"]

FORMAT = "graphseg-scene"
VERSION = 1
VERSIONS = (1, 2)  # read; the writer picks the lowest that holds the scene (_version_for)
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg")


def _matrix(value: Any, shape: tuple[int, int], where: str, field: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise SceneError(f"expected a {shape[0]}x{shape[1]} matrix of numbers", where=where, field=field) from err
    if arr.shape != shape:
        raise SceneError(f"expected a {shape[0]}x{shape[1]} matrix (got shape {list(arr.shape)})", where=where, field=field)
    if not np.isfinite(arr).all():
        raise SceneError("contains NaN or inf", where=where, field=field)
    return arr


def _rgb_only(root: Path, views: Any, step: Any, num_views: Any) -> Scene:
    files = sorted(p for p in root.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES and not p.name.startswith("."))
    for p in files:
        confine(root, p.name, where=str(root), field=p.name)
    if not files:
        raise SceneError("no scene.json and no images (an empty scene)", where=str(root), field="views")
    names = [p.stem for p in files]
    idx = select_indices(len(files), views=views, step=step, num_views=num_views, names=names, where=str(root))
    out = [View(files[i].stem, read_rgb(files[i])) for i in idx]
    _check_sizes(out, root)
    return Scene(out, name=root.name, meta={"source": str(root), "format": "images"})


def _check_sizes(views: Sequence[View], root: Path) -> None:
    for v in views:
        if v.shape != views[0].shape:
            (h0, w0), (h, w) = views[0].shape, v.shape
            raise SceneError(
                f"all images must have one size: {views[0].name} is {w0}x{h0} but {v.name} is {w}x{h}; resize {v.name} to {w0}x{h0} or remove it",
                where=str(root),
                field="rgb",
            )


def read_scene_folder(
    path: str | os.PathLike[str],
    *,
    views: Sequence[int | str] | None = None,
    step: int | None = None,
    num_views: int | None = None,
) -> Scene:
    """Read a scene folder (format v1, or plain images).

    Parameters
    ----------
    path : path-like
    views, step, num_views : optional
        View selection (see :func:`graphseg.io.select.select_indices`); images of
        unselected views are never read.

    Raises
    ------
    SceneError
        Naming the file and the field for every malformed input.
    """
    root = Path(path)
    if not root.exists():
        raise SceneError("no such file or folder", where=str(root), field="path")
    if not root.is_dir():
        raise SceneError("expected a scene folder", where=str(root), field="path")
    sj = root / "scene.json"
    if not sj.exists():
        return _rgb_only(root, views, step, num_views)
    where = str(sj)
    doc = read_json(sj, field="scene.json")
    if not isinstance(doc, dict):
        raise SceneError("expected a JSON object", where=where, field="scene.json")
    if doc.get("format") != FORMAT:
        raise SceneError(f"expected {FORMAT!r} (got {doc.get('format')!r})", where=where, field="format")
    if doc.get("version") not in VERSIONS or isinstance(doc.get("version"), bool):
        raise SceneError(f"unsupported version {doc.get('version')!r} (this reader knows {', '.join(map(str, VERSIONS))})", where=where, field="version")
    scale = doc.get("depth_scale", 1000.0)
    if not isinstance(scale, (int, float)) or isinstance(scale, bool) or not scale > 0:
        raise SceneError(f"expected a positive number (got {scale!r})", where=where, field="depth_scale")
    vlist = doc.get("views")
    if not isinstance(vlist, list) or not vlist:
        raise SceneError("expected a non-empty list", where=where, field="views")
    names = []
    for k, vd in enumerate(vlist):
        if not isinstance(vd, dict):
            raise SceneError("expected an object", where=where, field=f"views[{k}]")
        for req in ("name", "rgb"):
            if not isinstance(vd.get(req), str) or not vd.get(req):
                raise SceneError("missing or not a string", where=where, field=f"views[{k}].{req}")
        names.append(vd["name"])
    if len(set(names)) != len(names):
        raise SceneError("view names must be unique", where=where, field="views[].name")
    objects: dict[int, str] = {}
    if not isinstance(doc.get("objects") or [], list):
        raise SceneError("expected a list of {\"id\": int, \"name\": str}", where=where, field="objects")
    for k, od in enumerate(doc.get("objects") or []):
        if not isinstance(od, dict) or not isinstance(od.get("id"), int) or isinstance(od.get("id"), bool):
            raise SceneError("expected {\"id\": int, \"name\": str}", where=where, field=f"objects[{k}]")
        objects[int(od["id"])] = str(od.get("name", od["id"]))
    idx = select_indices(len(vlist), views=views, step=step, num_views=num_views, names=names, where=where)
    out = []
    for k in idx:
        vd = vlist[k]
        f = f"views[{k}]"
        paths = {key: confine(root, vd[key], where=where, field=f"{f}.{key}") for key in ("rgb", "depth", "instances") if vd.get(key) is not None}
        rgb = read_rgb(paths["rgb"], field=f"{f}.rgb")
        depth = inst = K = T = None
        if "depth" in paths:
            raw = check_size(read_uint16(paths["depth"], field=f"{f}.depth"), rgb, paths["depth"], f"{f}.depth")
            depth = raw.astype(np.float32) / np.float32(scale)
        if "instances" in paths:
            inst = check_size(read_label(paths["instances"], field=f"{f}.instances"), rgb, paths["instances"], f"{f}.instances")
        if vd.get("K") is not None:
            K = _matrix(vd["K"], (3, 3), where, f"{f}.K")
            if K[0, 0] <= 0 or K[1, 1] <= 0:
                raise SceneError("focal lengths must be positive", where=where, field=f"{f}.K")
        if vd.get("cam_to_world") is not None:
            T = _matrix(vd["cam_to_world"], (4, 4), where, f"{f}.cam_to_world")
            if not is_rigid(T):
                raise SceneError("not a rigid transform (rotation must be orthonormal with det +1, last row 0 0 0 1)", where=where, field=f"{f}.cam_to_world")
        view = View(vd["name"], rgb, depth=depth, K=K, cam_to_world=T, instances=inst)
        out.append(_read_points_entry(root, vd, view, doc["version"], where, f))
    _check_sizes(out, root)
    return Scene(out, objects, name=root.name, meta={"source": str(root), "format": FORMAT})


def write_scene_folder(scene: Scene, path: str | os.PathLike[str], *, depth_scale: float = 1000.0, overwrite: bool = False) -> Path:
    """Write ``scene`` as a format-v1 folder, v2 when a view has points but no depth (via a temporary sibling, then renamed).

    Depth is stored as ``round(depth * depth_scale)`` in 16 bits (0 = invalid);
    values beyond 65535 / depth_scale metres become invalid. File names come
    from the view names, made safe and unique (:func:`~graphseg.io.images.unique_file_names`).
    An existing ``path`` is replaced only with ``overwrite=True`` (and only
    after the new folder is complete).
    """
    dest = Path(path)
    if dest.is_symlink():
        raise FileExistsError(f"{dest} is a symbolic link")
    if dest.exists() and not overwrite:
        raise FileExistsError(f"{dest} exists (pass overwrite=True)")
    dest.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{dest.name}.", dir=dest.parent))
    try:
        fill_scene_folder(scene, tmp, depth_scale=depth_scale)
        if dest.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{dest.name}.old-", dir=dest.parent))
            os.replace(dest, old / "x")
            os.replace(tmp, dest)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, dest)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return dest


def fill_scene_folder(scene: Scene, folder: str | os.PathLike[str], *, depth_scale: float = 1000.0) -> None:
    """Write the files of a scene (format v1, or v2 when a view has points but no depth) into the existing (empty) ``folder``."""
    tmp = Path(folder)
    tmp.mkdir(parents=True, exist_ok=True)
    views = []
    files = unique_file_names([v.name for v in scene.views])
    for v, stem in zip(scene.views, files):
        entry: dict[str, Any] = {"name": v.name, "rgb": f"rgb/{stem}.png"}
        (tmp / "rgb").mkdir(exist_ok=True)
        write_rgb(tmp / entry["rgb"], v.rgb)
        if v.depth is not None:
            (tmp / "depth").mkdir(exist_ok=True)
            d = np.nan_to_num(np.asarray(v.depth, np.float64), nan=0.0) * depth_scale
            d = np.where((d > 0) & (d <= 65535), np.rint(d), 0).astype(np.uint16)
            entry["depth"] = f"depth/{stem}.png"
            write_png(tmp / entry["depth"], d)
        if v.instances is not None:
            (tmp / "instances").mkdir(exist_ok=True)
            entry["instances"] = f"instances/{stem}.png"
            write_png(tmp / entry["instances"], np.asarray(v.instances).astype(np.uint16))
        _write_points_entry(tmp, v, entry)
        if v.K is not None:
            entry["K"] = np.asarray(v.K, np.float64).tolist()
        if v.cam_to_world is not None:
            entry["cam_to_world"] = np.asarray(v.cam_to_world, np.float64).tolist()
        views.append(entry)
    doc = {
        "format": FORMAT,
        "version": _version_for(scene),
        "depth_scale": float(depth_scale),
        "views": views,
        "objects": [{"id": int(k), "name": str(n)} for k, n in sorted(scene.objects.items())],
    }
    (tmp / "scene.json").write_text(json.dumps(doc, indent=1), encoding="utf-8")


# ----------------------------------------------------------------------------- version 2: point maps
def _version_for(scene: Scene) -> int:
    """2 when some view has a point map and no depth (the point map must be stored), else 1."""
    return 2 if any(v.points is not None and v.depth is None for v in scene.views) else 1


def _write_points_entry(tmp: Path, view: View, entry: dict[str, Any]) -> None:
    """Store a point map a view cannot recompute from depth as ``points/NAME.npz``."""
    if view.points is None or view.depth is not None:
        return
    from .precomputed import write_point_map

    path = write_point_map(tmp / "points", view.name, view.points, view.confidence)
    entry["points"] = f"points/{path.name}"


def _read_points_entry(root: Path, vd: dict[str, Any], view: View, version: int, where: str, field: str) -> View:
    """The view with the point map of a v2 ``"points"`` entry (same size as the image)."""
    rel = vd.get("points")
    if rel is None:
        return view
    if version < 2:
        raise SceneError("point maps need format version 2", where=where, field=f"{field}.points")
    if not isinstance(rel, str) or not rel.endswith(".npz"):
        raise SceneError(f"expected a path to an .npz file (got {rel!r})", where=where, field=f"{field}.points")
    from .precomputed import read_point_map_file

    path = confine(root, rel, where=where, field=f"{field}.points")
    pm = read_point_map_file(path, view.shape)
    if pm.source_shape != view.shape:
        (h, w), (ph, pw) = view.shape, pm.source_shape
        raise SceneError(f"the point map is {pw}x{ph} but the rgb image is {w}x{h}; compute it at {w}x{h} or remove the view from the scene", where=str(path), field="points")
    return view.replace(points=pm.points, confidence=pm.confidence)

