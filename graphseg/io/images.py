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

__all__ = [
    "read_rgb",
    "read_uint16",
    "read_label",
    "write_png",
    "write_rgb",
    "require_folder",
    "check_size",
    "image_size",
    "confine",
    "max_pixels",
    "quiet_opencv",
    "DEFAULT_MAX_PIXELS",
    "unique_file_names",
]

#: Default pixel budget per image (override with ``$GRAPHSEG_MAX_PIXELS``).
DEFAULT_MAX_PIXELS = 40_000_000


def max_pixels() -> int:
    """The pixel budget per image: ``$GRAPHSEG_MAX_PIXELS`` or :data:`DEFAULT_MAX_PIXELS`."""
    try:
        return int(os.environ.get("GRAPHSEG_MAX_PIXELS", DEFAULT_MAX_PIXELS))
    except ValueError:
        return DEFAULT_MAX_PIXELS


def quiet_opencv() -> None:
    """Keep OpenCV's native ``[ WARN:0@...]`` / ``[ERROR:0@...]`` log lines off stderr (graphseg raises its own errors)."""
    import cv2

    try:
        cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)
    except AttributeError:  # pragma: no cover - very old OpenCV
        cv2.setLogLevel(0)  # type: ignore[attr-defined]


def image_size(head: bytes) -> tuple[int, int] | None:
    r"""``(width, height)`` from the first bytes of a PNG or JPEG file, without decoding it.

    Reads the PNG ``IHDR`` chunk or the first JPEG ``SOFn`` segment; None for
    other formats or a truncated header.

    Examples
    --------
    >>> import struct
    >>> image_size(b"\x89PNG\r\n\x1a\n" + struct.pack(">I", 13) + b"IHDR" + struct.pack(">II", 640, 480))
    (640, 480)
    >>> image_size(b"GIF89a") is None
    True
    """
    import struct

    if head[:8] == b"\x89PNG\r\n\x1a\n" and len(head) >= 24 and head[12:16] == b"IHDR":
        w, h = struct.unpack(">II", head[16:24])
        return int(w), int(h)
    if head[:2] == b"\xff\xd8":
        i = 2
        while i + 4 <= len(head):
            if head[i] != 0xFF:
                return None
            marker = head[i + 1]
            if marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7:
                i += 2
                continue
            seg = struct.unpack(">H", head[i + 2 : i + 4])[0]
            if marker in (0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF):
                if i + 9 > len(head):
                    return None
                h, w = struct.unpack(">HH", head[i + 5 : i + 9])
                return int(w), int(h)
            i += 2 + seg
    return None


def confine(root: str | os.PathLike[str], rel: object, *, where: str, field: str) -> Path:
    """``root / rel`` if it stays inside ``root`` (after following symbolic links).

    Raises
    ------
    SceneError
        For a non-string, an absolute path, a ``..`` escape or a link leaving ``root``.

    Examples
    --------
    >>> confine("/data/s", "rgb/0.png", where="scene.json", field="rgb").as_posix()
    '/data/s/rgb/0.png'
    >>> confine("/data/s", "../x.png", where="scene.json", field="views[0].rgb")
    Traceback (most recent call last):
    ...
    graphseg.scene.SceneError: scene.json: views[0].rgb: path leaves the scene folder ('../x.png')
    """
    if not isinstance(rel, (str, os.PathLike)) or not str(rel):
        raise SceneError(f"expected a relative path (got {rel!r})", where=where, field=field)
    text = os.fspath(rel)
    if "\x00" in text:
        raise SceneError("path contains a NUL character", where=where, field=field)
    if os.path.isabs(text):
        raise SceneError(f"absolute paths are not allowed ({text!r}); give a path inside the scene folder", where=where, field=field)
    base = Path(root)
    p = base / text
    try:
        inside = p.resolve().is_relative_to(base.resolve())
    except (OSError, RuntimeError):
        inside = False
    if not inside or ".." in Path(text).parts:
        raise SceneError(f"path leaves the scene folder ({text!r})", where=where, field=field)
    return p


def _imread(path: str | os.PathLike[str], flags: int, field: str) -> np.ndarray:
    import cv2

    quiet_opencv()
    p = Path(path)
    if not p.is_file():
        raise SceneError("file not found", where=str(p), field=field)
    with open(p, "rb") as f:
        head = f.read(65536)
    wh = image_size(head)
    budget = max_pixels()
    if wh is not None and wh[0] * wh[1] > budget:
        raise SceneError(
            f"{wh[0]}x{wh[1]} = {wh[0] * wh[1] / 1e6:.0f} MP is above the budget of {budget / 1e6:.0f} MP per image (raise it with GRAPHSEG_MAX_PIXELS)",
            where=str(p),
            field=field,
        )
    data = np.fromfile(str(p), dtype=np.uint8)
    img = None
    if data.size:
        from ..quiet import native_silence

        with native_silence(fds=(2,)):  # libpng prints "libpng error: ..." on fd 2 for a truncated file
            try:
                img = cv2.imdecode(data, flags)
            except cv2.error:  # OpenCV refuses some damaged headers by raising, not by returning None
                img = None
    if img is None:
        raise SceneError("cannot decode image (corrupt, truncated or not an image)", where=str(p), field=field)
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


def _safe(name: str) -> str:
    return "".join(c if (c.isascii() and c.isalnum()) or c in "-_." else "_" for c in name).lstrip(".") or "view"


def unique_file_names(names: list[str] | tuple[str, ...]) -> list[str]:
    """File-system-safe, pairwise distinct (case-insensitively) stems for ``names``.

    Characters other than ASCII letters, digits, ``-``, ``_`` and ``.`` become
    ``_`` (leading dots are dropped); a stem already taken gets ``-2``, ``-3``, ...

    Examples
    --------
    >>> unique_file_names(["a/b", "a_b", "A_B", "ü", "../x"])
    ['a_b', 'a_b-2', 'A_B-3', '_', '_x']
    """
    out: list[str] = []
    taken: set[str] = set()
    for n in names:
        base = _safe(n)
        cand, k = base, 1
        while cand.lower() in taken:
            k += 1
            cand = f"{base}-{k}"
        taken.add(cand.lower())
        out.append(cand)
    return out


def require_folder(path: str | os.PathLike[str]) -> Path:
    """``Path(path)`` if it is an existing folder, else :class:`SceneError` on field ``path``."""
    root = Path(path)
    if not root.is_dir():
        raise SceneError("no such folder", where=str(root), field="path")
    return root


def check_size(img: np.ndarray, rgb: np.ndarray, where: str | os.PathLike[str], field: str) -> np.ndarray:
    """Return ``img`` if it has the image size of ``rgb``, else raise naming both sizes.

    Sizes are written ``WIDTHxHEIGHT``, like the rest of the command line.

    Examples
    --------
    >>> check_size(np.zeros((48, 64)), np.zeros((480, 640, 3)), "d/0.png", "views[0].depth")
    Traceback (most recent call last):
    ...
    graphseg.scene.SceneError: d/0.png: views[0].depth: the depth image is 64x48 but the rgb image is 640x480; resize it to 640x480 or remove the view from the scene
    """
    if img.shape[:2] != rgb.shape[:2]:
        (h, w), (rh, rw) = img.shape[:2], rgb.shape[:2]
        raise SceneError(
            f"the {field.split('.')[-1]} image is {w}x{h} but the rgb image is {rw}x{rh}; resize it to {rw}x{rh} or remove the view from the scene",
            where=str(where),
            field=field,
        )
    return img
