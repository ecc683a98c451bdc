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
from .checks import intrinsics, matrix, positive, reading, rigid
from .images import check_size, confine, read_label, read_rgb, read_uint16, require_folder
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
        mpath = confine(root, f"{fr}-meta.mat", where=str(root), field="meta")
        meta = _meta(mpath)
        mw = str(mpath)
        with reading(mw, "meta"):
            factor = positive(meta["factor_depth"], where=mw, field="factor_depth")
            K = intrinsics(meta["intrinsic_matrix"], where=mw, field="intrinsic_matrix")
            Rt = matrix(meta["rotation_translation_matrix"], (3, 4), where=mw, field="rotation_translation_matrix")
            w2c = np.eye(4)
            w2c[:3] = Rt
            w2c = rigid(w2c, where=mw, field="rotation_translation_matrix")
            T = np.linalg.inv(w2c)
        rgb = read_rgb(confine(root, f"{fr}-color.png", where=str(root), field="rgb"))
        dpath = confine(root, f"{fr}-depth.png", where=str(root), field="depth")
        raw = check_size(read_uint16(dpath), rgb, dpath, "depth")
        depth = raw.astype(np.float32) / np.float32(factor)
        lab_path = root / f"{fr}-label.png"
        inst = None
        if lab_path.exists():
            inst = check_size(read_label(confine(root, lab_path.name, where=str(root), field="label")), rgb, lab_path, "label")
        out.append(View(fr, rgb, depth=depth, K=K, cam_to_world=T, instances=inst))
    objects: dict[int, str] = {}
    classes = root.parent / "classes.txt"
    if classes.is_file():
        with reading(str(classes), "classes"):
            names = [ln.strip() for ln in classes.read_text(encoding="utf-8", errors="replace").splitlines() if ln.strip()]
        present = set().union(*(set(np.unique(v.instances).tolist()) for v in out if v.instances is not None))
        objects = {k: names[k - 1] for k in sorted(present) if 0 < k <= len(names)}
    return Scene(out, objects, name=f"ycbv-{root.name}", meta={"source": str(root), "format": "ycbv"})
