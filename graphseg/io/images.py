"""Image IO with checks: every failure names the file and the field.

Examples
--------
>>> import tempfile, os, numpy as np
>>> with tempfile.TemporaryDirectory() as d:
...     p = os.path.join(d, "x.png")
...     write_png(p, np.full((2, 3), 7, np.uint16))
...     read_uint16(p, field="depth").tolist()
[[7, 7, 7], [7, 7, 7]]
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..scene import SceneError

__all__ = ["read_rgb", "read_uint16", "read_label", "write_png", "write_rgb", "require_folder", "check_size"]


def _imread(path: str | os.PathLike[str], flags: int, field: str) -> np.ndarray:
    import cv2

    p = Path(path)
    if not p.is_file():
        raise SceneError("file not found", where=str(p), field=field)
    data = np.fromfile(str(p), dtype=np.uint8)
    img = cv2.imdecode(data, flags) if data.size else None
    if img is None:
        raise SceneError("cannot decode image (corrupt or not an image)", where=str(p), field=field)
    return img


def read_rgb(path: str | os.PathLike[str], field: str = "rgb") -> np.ndarray:
    """uint8 ``[H, W, 3]`` RGB from an 8-bit PNG/JPEG (grey images are expanded)."""
    import cv2

    img = _imread(path, cv2.IMREAD_UNCHANGED, field)
    if img.dtype != np.uint8:
        raise SceneError(f"expected an 8-bit image (got {img.dtype})", where=str(path), field=field)
    if img.ndim == 2:
        img = np.repeat(img[..., None], 3, axis=2)
    elif img.shape[2] == 4:
        img = cv2.cvtColor(img, cv2.COLOR_BGRA2RGB)
    else:
        img = cv2.cvtColor(img, cv2.COLOR_BGR2RGB)
    return np.ascontiguousarray(img)


def read_uint16(path: str | os.PathLike[str], field: str = "depth") -> np.ndarray:
    """A single-channel 16-bit PNG as uint16 ``[H, W]``."""
    import cv2

    img = _imread(path, cv2.IMREAD_UNCHANGED, field)
    if img.ndim != 2:
        raise SceneError(f"expected a single-channel image (got {img.shape[2]} channels)", where=str(path), field=field)
    if img.dtype != np.uint16:
        raise SceneError(f"expected a 16-bit PNG (got {img.dtype})", where=str(path), field=field)
    return img


def read_label(path: str | os.PathLike[str], field: str = "instances") -> np.ndarray:
    """A single-channel 8- or 16-bit label PNG as int32 ``[H, W]``."""
    import cv2

    img = _imread(path, cv2.IMREAD_UNCHANGED, field)
    if img.ndim == 3:  # some datasets store labels as 3 equal channels
        if not (np.array_equal(img[..., 0], img[..., 1]) and np.array_equal(img[..., 0], img[..., 2])):
            raise SceneError("expected a single-channel label image", where=str(path), field=field)
        img = img[..., 0]
    if img.dtype not in (np.uint8, np.uint16):
        raise SceneError(f"expected an 8- or 16-bit label image (got {img.dtype})", where=str(path), field=field)
    return img.astype(np.int32)


def write_png(path: str | os.PathLike[str], img: np.ndarray) -> None:
    """Write a uint8 / uint16 single-channel image (or uint8 RGB, given in RGB order)."""
    import cv2

    arr = np.asarray(img)
    if arr.ndim == 3:
        arr = cv2.cvtColor(np.ascontiguousarray(arr), cv2.COLOR_RGB2BGR)
    ok, buf = cv2.imencode(".png", arr)
    if not ok:  # pragma: no cover
        raise OSError(f"could not encode {path}")
    Path(path).write_bytes(buf.tobytes())


def write_rgb(path: str | os.PathLike[str], rgb: np.ndarray) -> None:
    """Write uint8 RGB ``[H, W, 3]`` as PNG or JPEG (by extension)."""
    import cv2

    bgr = cv2.cvtColor(np.ascontiguousarray(rgb), cv2.COLOR_RGB2BGR)
    ext = Path(path).suffix.lower() or ".png"
    ok, buf = cv2.imencode(ext, bgr)
    if not ok:  # pragma: no cover
        raise OSError(f"could not encode {path}")
    Path(path).write_bytes(buf.tobytes())


def require_folder(path: str | os.PathLike[str]) -> Path:
    """``Path(path)`` if it is an existing folder, else :class:`SceneError` on field ``path``."""
    root = Path(path)
    if not root.is_dir():
        raise SceneError("no such folder", where=str(root), field="path")
    return root


def check_size(img: np.ndarray, rgb: np.ndarray, where: str | os.PathLike[str], field: str) -> np.ndarray:
    """Return ``img`` if it has the image size of ``rgb``, else raise naming both sizes."""
    if img.shape[:2] != rgb.shape[:2]:
        raise SceneError(f"{field.split('.')[-1]} is {list(img.shape[:2])} but rgb is {list(rgb.shape[:2])}", where=str(where), field=field)
    return img
