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
from .images import check_size, read_label, read_rgb, read_uint16, require_folder
from .select import select_indices

__all__ = ["read_graspnet", "is_graspnet"]


def _camera_dir(path: Path, camera: str) -> Path:
    if (path / "camera_poses.npy").exists():
        return path
    if (path / camera / "camera_poses.npy").exists():
        return path / camera
    raise SceneError(f"not a GraspNet scene (no camera_poses.npy here or in {camera}/)", where=str(path), field="camera_poses")


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
    poses = np.load(cam / "camera_poses.npy")
    if poses.ndim != 3 or poses.shape[1:] != (4, 4):
        raise SceneError(f"expected [N, 4, 4] (got {list(poses.shape)})", where=str(cam / "camera_poses.npy"), field="camera_poses")
    frames = sorted(p.stem for p in (cam / "rgb").glob("*.png"))
    if not frames:
        raise SceneError("no rgb/*.png frames", where=str(cam), field="views")
    table = np.load(cam / "cam0_wrt_table.npy") if (cam / "cam0_wrt_table.npy").exists() else np.eye(4)
    camK = np.load(cam / "camK.npy") if (cam / "camK.npy").exists() else None
    idx = select_indices(len(frames), views=views, step=step, num_views=num_views, names=frames, where=str(cam))
    out = []
    for i in idx:
        fr = frames[i]
        k = int(fr)
        if k >= len(poses):
            raise SceneError(f"frame {fr} has no pose ({len(poses)} poses)", where=str(cam / "camera_poses.npy"), field="camera_poses")
        meta_path = cam / "meta" / f"{fr}.mat"
        if meta_path.exists():
            meta = loadmat(str(meta_path))
            K = np.asarray(meta["intrinsic_matrix"], np.float64)
            factor = float(np.asarray(meta["factor_depth"]).ravel()[0])
        elif camK is not None:
            K, factor = np.asarray(camK, np.float64), 1000.0
        else:
            raise SceneError("no meta file and no camK.npy", where=str(meta_path), field="intrinsic_matrix")
        rgb = read_rgb(cam / "rgb" / f"{fr}.png")
        raw = check_size(read_uint16(cam / "depth" / f"{fr}.png"), rgb, cam / "depth" / f"{fr}.png", "depth")
        lab_path = cam / "label" / f"{fr}.png"
        inst = read_label(lab_path) if lab_path.exists() else None
        T = table @ poses[k]
        out.append(View(fr, rgb, depth=raw.astype(np.float32) / np.float32(factor), K=K, cam_to_world=T, instances=inst))
    return Scene(out, name=f"graspnet-{root.name}", meta={"source": str(cam), "format": "graspnet"})
