"""Scene readers as plugins: each format is a class with ``name``, ``detect`` and ``read``.

The registry :data:`scene_formats` (entry-point group ``graphseg.scene_formats``)
holds the built-ins ``native``, ``ycbv``, ``bop`` and ``graspnet``; a
third-party package adds a reader by pointing an entry point at its class::

    [project.entry-points."graphseg.scene_formats"]
    my_format = "my_pkg:MyFormat"

:func:`detect_format` asks every reader's ``detect(path)`` (plugins before the
built-in ``native`` fallback, which also reads a folder of plain images).

Examples
--------
>>> "native" in scene_formats.names() and "ycbv" in scene_formats.names()
True
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any, ClassVar

from ..registry import Registry
from ..scene import Scene, SceneError

__all__ = ["SceneFormat", "scene_formats", "detect_format", "read_with_format"]


class SceneFormat:
    """Base class of scene readers.

    Subclasses set ``name`` and implement :meth:`detect` and :meth:`read`.
    """

    name: ClassVar[str] = ""

    def detect(self, path: Path) -> bool:  # pragma: no cover - abstract
        """Whether the folder ``path`` is in this format (cheap: look at names only)."""
        raise NotImplementedError

    def read(
        self,
        path: Path,
        *,
        views: Sequence[int | str] | None = None,
        step: int | None = None,
        num_views: int | None = None,
    ) -> Scene:  # pragma: no cover - abstract
        """Read the scene, with optional view selection."""
        raise NotImplementedError


class _Builtin(SceneFormat):
    _detect: ClassVar[str] = ""
    _read: ClassVar[str] = ""

    def detect(self, path: Path) -> bool:
        from importlib import import_module

        mod, _, fn = self._detect.partition(":")
        return bool(getattr(import_module(mod), fn)(path))

    def read(self, path: Path, **kwargs: Any) -> Scene:
        from importlib import import_module

        mod, _, fn = self._read.partition(":")
        return getattr(import_module(mod), fn)(path, **kwargs)


class NativeFormat(_Builtin):
    """graphseg's own scene folder (``scene.json``), or a folder of plain images."""

    name = "native"
    _read = "graphseg.io.scene_folder:read_scene_folder"

    def detect(self, path: Path) -> bool:
        return (Path(path) / "scene.json").exists()


class YcbvFormat(_Builtin):
    """A YCB-Video video folder."""

    name = "ycbv"
    _detect = "graphseg.io.ycbv:is_ycbv"
    _read = "graphseg.io.ycbv:read_ycbv"


class BopFormat(_Builtin):
    """A BOP scene folder."""

    name = "bop"
    _detect = "graphseg.io.bop:is_bop"
    _read = "graphseg.io.bop:read_bop"


class GraspNetFormat(_Builtin):
    """A GraspNet-1Billion scene."""

    name = "graspnet"
    _detect = "graphseg.io.graspnet:is_graspnet"
    _read = "graphseg.io.graspnet:read_graspnet"


scene_formats = Registry("scene format", group="graphseg.scene_formats")
scene_formats.register("native", NativeFormat)
scene_formats.register("bop", BopFormat)
scene_formats.register("graspnet", GraspNetFormat)
scene_formats.register("ycbv", YcbvFormat)


def detect_format(path: str | os.PathLike[str]) -> str:
    """The name of the format of the scene folder ``path``.

    ``native`` when ``scene.json`` exists; else the first built-in, then plugin,
    reader whose ``detect`` says yes; else ``native`` (a folder of images).
    """
    p = Path(path)
    if not p.exists():
        raise SceneError("no such file or folder", where=str(p), field="path")
    if not p.is_dir():
        raise SceneError("expected a scene folder", where=str(p), field="path")
    for name in scene_formats.names():
        try:
            reader = scene_formats.resolve(name)
        except LookupError:  # a broken plugin warned already; skip it
            continue
        if reader.detect(p):
            return name
    return "native"


def read_with_format(path: str | os.PathLike[str], fmt: str, **kwargs: Any) -> Scene:
    """Read ``path`` with the reader registered as ``fmt``."""
    if fmt not in scene_formats:
        raise SceneError(
            f"unknown scene format {fmt!r}; choose one of {', '.join(scene_formats.available())}", where=str(path), field="format"
        )
    return scene_formats.resolve(fmt).read(Path(path), **kwargs)
