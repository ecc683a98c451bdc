"""YCB-Video reader.

Layout: ``data/VVVV/NNNNNN-{color.png, depth.png, label.png, meta.mat}``.
``meta.mat`` holds ``intrinsic_matrix``, ``factor_depth`` (depth = value /
factor_depth metres) and ``rotation_translation_matrix``, the world-to-camera
``[R|t]`` (``x_cam = R x_world + t``). The label is a class id, which is also
the instance id within a video. ``classes.txt`` next to the video folders (if
present) names the classes.
"""

from __future__ import annotations

import os
import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..scene import Scene, SceneError, View
from .images import check_size, read_label, read_rgb, read_uint16, require_folder
from .select import select_indices

__all__ = ["read_ycbv", "is_ycbv"]

_FRAME = re.compile(r"^(\d+)-color\.png$")


def is_ycbv(path: str | os.PathLike[str]) -> bool:
    p = Path(path)
    return p.is_dir() and any(_FRAME.match(f.name) for f in p.iterdir()) and any(f.name.endswith("-meta.mat") for f in p.iterdir())


def _meta(path: Path) -> dict[str, np.ndarray]:
    from scipy.io import loadmat

    if not path.is_file():
        raise SceneError("file not found", where=str(path), field="meta")
    try:
        m = loadmat(str(path))
    except Exception as err:  # scipy raises several types for corrupt files
        raise SceneError(f"cannot read .mat ({err})", where=str(path), field="meta") from err
    for key in ("intrinsic_matrix", "factor_depth", "rotation_translation_matrix"):
        if key not in m:
            raise SceneError("missing", where=str(path), field=key)
    return m


def read_ycbv(
    path: str | os.PathLike[str],
    *,
    views: Sequence[int | str] | None = None,
    step: int | None = None,
    num_views: int | None = None,
) -> Scene:
    """Read one YCB-Video video folder as a :class:`Scene` (views named by frame number)."""
    root = require_folder(path)
    frames = sorted(m.group(1) for f in root.iterdir() if (m := _FRAME.match(f.name)))
    if not frames:
        raise SceneError("no NNNNNN-color.png frames", where=str(root), field="views")
    idx = select_indices(len(frames), views=views, step=step, num_views=num_views, names=frames, where=str(root))
    out = []
    for i in idx:
        fr = frames[i]
        meta = _meta(root / f"{fr}-meta.mat")
        rgb = read_rgb(root / f"{fr}-color.png")
        raw = check_size(read_uint16(root / f"{fr}-depth.png"), rgb, root / f"{fr}-depth.png", "depth")
        depth = raw.astype(np.float32) / np.float32(float(np.asarray(meta["factor_depth"]).ravel()[0]))
        K = np.asarray(meta["intrinsic_matrix"], np.float64)
        Rt = np.asarray(meta["rotation_translation_matrix"], np.float64)
        if Rt.shape != (3, 4) or K.shape != (3, 3):
            raise SceneError(f"expected K 3x3 and [R|t] 3x4 (got {list(K.shape)}, {list(Rt.shape)})", where=str(root / f"{fr}-meta.mat"), field="rotation_translation_matrix")
        w2c = np.eye(4)
        w2c[:3] = Rt
        T = np.linalg.inv(w2c)
        lab_path = root / f"{fr}-label.png"
        inst = read_label(lab_path) if lab_path.exists() else None
        out.append(View(fr, rgb, depth=depth, K=K, cam_to_world=T, instances=inst))
    objects: dict[int, str] = {}
    classes = root.parent / "classes.txt"
    if classes.is_file():
        names = [ln.strip() for ln in classes.read_text().splitlines() if ln.strip()]
        present = set().union(*(set(np.unique(v.instances).tolist()) for v in out if v.instances is not None))
        objects = {k: names[k - 1] for k in sorted(present) if 0 < k <= len(names)}
    return Scene(out, objects, name=f"ycbv-{root.name}", meta={"source": str(root), "format": "ycbv"})
