"""GraspNet-1Billion reader (the paper's benchmark).

Layout: ``scenes/scene_XXXX/{realsense,kinect}/`` holding ``rgb/NNNN.png``,
``depth/NNNN.png`` (uint16, metres = value / factor_depth), ``label/NNNN.png``
(uint8, 0 = background, object ids), ``meta/NNNN.mat`` (``intrinsic_matrix``,
``factor_depth``), ``camera_poses.npy`` (``[256, 4, 4]``, each camera's pose in
the first camera's frame) and ``camK.npy``. When ``cam0_wrt_table.npy`` is
present, the world frame is the table's; otherwise it is the first camera's.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..scene import Scene, SceneError, View
from .checks import intrinsics, matrix, positive, reading, rigid
from .files import read_npy
from .images import check_size, confine, read_label, read_rgb, read_uint16, require_folder
from .select import select_indices

__all__ = ["read_graspnet", "is_graspnet"]


def _camera_dir(path: Path, camera: str) -> Path:
    if (path / "camera_poses.npy").exists():
        return path
    if (path / camera / "camera_poses.npy").exists():
        return path / camera
    raise SceneError(f"not a GraspNet scene (no camera_poses.npy here or in {camera}/)", where=str(path), field="camera_poses")


def _npy(root: Path, path: Path, field: str) -> np.ndarray:
    """A small numeric ``.npy`` inside ``root`` (no pickle; at most 64 MiB)."""
    p = confine(root, path.relative_to(root), where=str(root), field=field)
    arr = read_npy(p, field=field)
    if arr.dtype.kind not in "fiu":
        raise SceneError("expected a numeric array", where=str(p), field=field)
    return arr


def is_graspnet(path: str | os.PathLike[str]) -> bool:
    p = Path(path)
    return (p / "camera_poses.npy").exists() or any((p / c / "camera_poses.npy").exists() for c in ("realsense", "kinect"))


def read_graspnet(
    path: str | os.PathLike[str],
    *,
    camera: str = "realsense",
    views: Sequence[int | str] | None = None,
    step: int | None = None,
    num_views: int | None = None,
) -> Scene:
    """Read a GraspNet-1Billion scene (``scene_XXXX`` or its camera folder)."""
    from scipy.io import loadmat

    root = require_folder(path)
    cam = _camera_dir(root, camera)
    pw = str(cam / "camera_poses.npy")
    poses = _npy(root, cam / "camera_poses.npy", "camera_poses")
    if poses.ndim != 3 or poses.shape[1:] != (4, 4):
        raise SceneError(f"expected [N, 4, 4] (got {list(poses.shape)})", where=pw, field="camera_poses")
    frames = sorted(p.stem for p in (cam / "rgb").glob("*.png"))
    if not frames:
        raise SceneError("no rgb/*.png frames", where=str(cam), field="views")
    if not all(fr.isdigit() for fr in frames):
        bad = next(fr for fr in frames if not fr.isdigit())
        raise SceneError(f"expected numbered frames NNNN.png (got {bad!r})", where=str(cam / "rgb"), field="views")
    table = np.eye(4)
    if (cam / "cam0_wrt_table.npy").exists():
        table = rigid(_npy(root, cam / "cam0_wrt_table.npy", "cam0_wrt_table"), where=str(cam / "cam0_wrt_table.npy"), field="cam0_wrt_table")
    camK = None
    if (cam / "camK.npy").exists():
        camK = intrinsics(_npy(root, cam / "camK.npy", "camK"), where=str(cam / "camK.npy"), field="camK")
    idx = select_indices(len(frames), views=views, step=step, num_views=num_views, names=frames, where=str(cam))
    out = []
    for i in idx:
        fr = frames[i]
        k = int(fr)
        if k >= len(poses):
            raise SceneError(f"frame {fr} has no pose ({len(poses)} poses)", where=pw, field="camera_poses")
        meta_path = cam / "meta" / f"{fr}.mat"
        if meta_path.exists():
            mw = str(confine(root, meta_path.relative_to(root), where=str(root), field="meta"))
            try:
                meta = loadmat(mw)
            except Exception as err:  # scipy raises several types for corrupt files
                raise SceneError(f"cannot read .mat ({str(err).splitlines()[0] if str(err) else type(err).__name__})", where=mw, field="meta") from err
            with reading(mw, "meta"):
                K = intrinsics(meta["intrinsic_matrix"], where=mw, field="intrinsic_matrix")
                factor = positive(meta["factor_depth"], where=mw, field="factor_depth")
        elif camK is not None:
            K, factor = camK, 1000.0
        else:
            raise SceneError("no meta file and no camK.npy", where=str(meta_path), field="intrinsic_matrix")
        T = rigid(table @ matrix(poses[k], (4, 4), where=pw, field=f"camera_poses[{k}]"), where=pw, field=f"camera_poses[{k}]")
        rgb = read_rgb(confine(root, (cam / "rgb" / f"{fr}.png").relative_to(root), where=str(root), field="rgb"))
        dpath = confine(root, (cam / "depth" / f"{fr}.png").relative_to(root), where=str(root), field="depth")
        raw = check_size(read_uint16(dpath), rgb, dpath, "depth")
        lab_path = cam / "label" / f"{fr}.png"
        inst = None
        if lab_path.exists():
            lp = confine(root, lab_path.relative_to(root), where=str(root), field="label")
            inst = check_size(read_label(lp), rgb, lp, "label")
        out.append(View(fr, rgb, depth=raw.astype(np.float32) / np.float32(factor), K=K, cam_to_world=T, instances=inst))
    return Scene(out, name=f"graspnet-{root.name}", meta={"source": str(cam), "format": "graspnet"})
