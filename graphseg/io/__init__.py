"""Scene readers and writers, image and point-cloud IO.

:func:`load_scene` recognises the layout: a native scene folder (``scene.json``)
or a folder of plain images, a YCB-Video video folder, a BOP scene or a
GraspNet-1Billion scene. Readers are plugins (:mod:`graphseg.io.formats`,
entry-point group ``graphseg.scene_formats``).
"""

from __future__ import annotations

import os
from collections.abc import Sequence

from ..scene import Scene
from .bop import read_bop
from .formats import SceneFormat, detect_format, read_with_format, scene_formats
from .graspnet import read_graspnet
from .ply import read_ply, write_ply
from .scene_folder import read_scene_folder, write_scene_folder
from .select import parse_views, select_indices
from .ycbv import read_ycbv

__all__ = [
    "load_scene",
    "detect_format",
    "scene_formats",
    "SceneFormat",
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


def load_scene(
    path: str | os.PathLike[str],
    *,
    format: str | None = None,
    views: Sequence[int | str] | None = None,
    step: int | None = None,
    num_views: int | None = None,
) -> Scene:
    """Read a scene in any registered format (detected unless given), with optional view selection."""
    fmt = format or detect_format(path)
    return read_with_format(path, fmt, views=views, step=step, num_views=num_views)
