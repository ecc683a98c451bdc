"""Point clouds as binary PLY (float32 xyz, uint8 rgb).

Examples
--------
>>> import tempfile, os, numpy as np
>>> pts = np.array([[0, 0, 0], [1, 2, 3]], np.float32)
>>> with tempfile.TemporaryDirectory() as d:
...     write_ply(os.path.join(d, "a.ply"), pts, np.array([[255, 0, 0], [0, 255, 0]], np.uint8))
...     p, c = read_ply(os.path.join(d, "a.ply"))
>>> p.tolist()[1], c.tolist()[0]
([1.0, 2.0, 3.0], [255, 0, 0])
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

__all__ = ["write_ply", "read_ply"]


def write_ply(path: str | os.PathLike[str], points: np.ndarray, colors: np.ndarray | None = None) -> None:
    """Write ``points`` ``[P, 3]`` (and ``colors`` uint8 ``[P, 3]``) as binary little-endian PLY."""
    pts = np.asarray(points, np.float32).reshape(-1, 3)
    fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
    if colors is not None:
        fields += [("red", "u1"), ("green", "u1"), ("blue", "u1")]
    rec = np.empty(len(pts), dtype=fields)
    rec["x"], rec["y"], rec["z"] = pts.T
    header = ["ply", "format binary_little_endian 1.0", f"element vertex {len(pts)}", "property float x", "property float y", "property float z"]
    if colors is not None:
        c = np.asarray(colors, np.uint8).reshape(-1, 3)
        rec["red"], rec["green"], rec["blue"] = c.T
        header += ["property uchar red", "property uchar green", "property uchar blue"]
    header.append("end_header")
    with open(path, "wb") as f:
        f.write(("\n".join(header) + "\n").encode("ascii"))
        f.write(rec.tobytes())


def read_ply(path: str | os.PathLike[str]) -> tuple[np.ndarray, np.ndarray | None]:
    """Read a PLY written by :func:`write_ply`: points float32 ``[P, 3]`` and colours or None.

    Raises
    ------
    ValueError
        Naming the file, for anything but a well-formed binary little-endian
        PLY of that layout (the vertex count is checked against the file size
        before reading).
    """
    data = Path(path).read_bytes()
    marker = b"end_header\n"
    if not data.startswith(b"ply\n") or marker not in data[:4096]:
        raise ValueError(f"{path}: not a PLY file (no 'ply' / 'end_header' in the first 4 KiB)")
    end = data.index(marker) + len(marker)
    try:
        header = data[:end].decode("ascii").splitlines()
    except UnicodeDecodeError as err:
        raise ValueError(f"{path}: PLY header is not ASCII") from err
    if "format binary_little_endian 1.0" not in header:
        raise ValueError(f"{path}: only binary little-endian PLY is supported")
    counts = [ln.split()[-1] for ln in header if ln.startswith("element vertex")]
    if len(counts) != 1 or not counts[0].isdigit():
        raise ValueError(f"{path}: expected one 'element vertex N' line")
    n = int(counts[0])
    has_color = "property uchar red" in header
    fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")] + ([("red", "u1"), ("green", "u1"), ("blue", "u1")] if has_color else [])
    dtype = np.dtype(fields)
    if n * dtype.itemsize > len(data) - end:
        raise ValueError(f"{path}: declares {n} vertices but holds {(len(data) - end) // dtype.itemsize}")
    rec = np.frombuffer(data[end:], dtype=dtype, count=n)
    pts = np.stack([rec["x"], rec["y"], rec["z"]], 1)
    cols = np.stack([rec["red"], rec["green"], rec["blue"]], 1) if has_color else None
    return pts, cols
