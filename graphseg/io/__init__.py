"""Scene readers and writers, image and point-cloud IO.

:func:`load_scene` recognises the layout: a native scene folder (``scene.json``)
or a folder of plain images, a YCB-Video video folder, a BOP scene or a
GraspNet-1Billion scene.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from ..scene import Scene, SceneError
from .bop import is_bop, read_bop
from .graspnet import is_graspnet, read_graspnet
from .ply import read_ply, write_ply
from .scene_folder import read_scene_folder, write_scene_folder
from .select import parse_views, select_indices
from .ycbv import is_ycbv, read_ycbv

__all__ = [
    "load_scene",
    "detect_format",
    "read_scene_folder",
    "write_scene_folder",
    "read_ycbv",
    "read_graspnet",
    "read_bop",
    "write_ply",
    "read_ply",
    "parse_views",
    "select_indices",
]


def detect_format(path: str | os.PathLike[str]) -> str:
    """``"native"``, ``"ycbv"``, ``"bop"`` or ``"graspnet"``."""
    p = Path(path)
    if not p.exists():
        raise SceneError("no such file or folder", where=str(p), field="path")
    if not p.is_dir():
        raise SceneError("expected a scene folder", where=str(p), field="path")
    if (p / "scene.json").exists():
        return "native"
    if is_bop(p):
        return "bop"
    if is_graspnet(p):
        return "graspnet"
    if is_ycbv(p):
        return "ycbv"
    return "native"


def load_scene(
    path: str | os.PathLike[str],
    *,
    format: str | None = None,
    views: Sequence[int | str] | None = None,
    step: int | None = None,
    num_views: int | None = None,
) -> Scene:
    """Read a scene in any supported layout, with optional view selection."""
    fmt = format or detect_format(path)
    readers = {"native": read_scene_folder, "ycbv": read_ycbv, "bop": read_bop, "graspnet": read_graspnet}
    if fmt not in readers:
        raise SceneError(f"unknown scene format {fmt!r}; choose one of {', '.join(readers)}", where=str(path), field="format")
    return readers[fmt](path, views=views, step=step, num_views=num_views)
