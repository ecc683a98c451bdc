"""Backends that read model outputs computed elsewhere (formats: :mod:`graphseg.io.precomputed`).

``precomputed-points`` lifter (CLI ``--points DIR``)
    World point maps (and confidences, cameras) from ``folder/VIEW.npz``.
``precomputed-matches`` matcher (CLI ``--matches DIR``)
    Pixel matches from ``folder/VIEWI__VIEWJ.npz``; a pair with no file gets no
    matches (``missing="empty"``) or fails (``missing="error"``).

Examples
--------
>>> import tempfile, numpy as np
>>> from graphseg.scene import Scene, View
>>> from graphseg.io.precomputed import write_point_map
>>> with tempfile.TemporaryDirectory() as d:
...     _ = write_point_map(d, "a", np.ones((2, 2, 3), np.float32))
...     lifted = PrecomputedLifter(folder=d)(Scene([View("a", np.zeros((4, 4, 3), np.uint8))]))
>>> lifted.views[0].points.shape
(4, 4, 3)
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from ..io.precomputed import apply_point_maps, pair_file_name, peek_pair_names, read_pair_matches
from ..scene import Matches, Scene, SceneError, View
from .options import Backend

__all__ = ["PrecomputedLifter", "PrecomputedMatcher", "precomputed_choice"]

#: CLI flag -> (backend kind, registry name) of the backend that reads that folder.
FLAGS = {"points": ("lifter", "precomputed-points"), "matches": ("matcher", "precomputed-matches")}


def _folder(folder: str | os.PathLike[str] | None, backend: str, field: str) -> Path:
    if folder is None:
        raise SceneError(
            f"the precomputed {backend} needs a folder: --{field} DIR (or --backend-option {FLAGS[field][1]}.folder=DIR)",
            where=FLAGS[field][1],
            field="folder",
        )
    root = Path(folder)
    if not root.is_dir():
        raise SceneError("no such folder", where=str(root), field=field)
    return root


class PrecomputedLifter(Backend):
    """The ``precomputed-points`` lifter: point maps read from ``folder`` (see :func:`~graphseg.io.precomputed.read_point_map`)."""

    name = "precomputed-points"

    class Options(BaseModel):
        model_config = ConfigDict(extra="forbid")
        folder: str | None = Field(None, description="the point-map folder (required)")

    def __init__(self, options: Any = None, /, **kwargs: Any) -> None:
        super().__init__(options, **kwargs)
        self.folder = _folder(self.options.folder, "lifter", "points")

    def __call__(self, scene: Scene) -> Scene:
        return apply_point_maps(scene, self.folder)


class PrecomputedMatcher(Backend):
    """The ``precomputed-matches`` matcher: ``folder/VIEWI__VIEWJ.npz`` (either order) per pair."""

    name = "precomputed-matches"

    class Options(BaseModel):
        model_config = ConfigDict(extra="forbid")
        folder: str | None = Field(None, description="the matches folder (required)")
        missing: Literal["empty", "error"] = Field("empty", description="a pair without a file: no matches ('empty') or an error")
        num_matches: int | None = Field(None, ge=1, description="matches kept per pair, most certain first (None: all; filled from the config)")

    def __init__(self, options: Any = None, /, **kwargs: Any) -> None:
        super().__init__(options, **kwargs)
        self.folder = _folder(self.options.folder, "matcher", "matches")
        self._index: dict[tuple[str, str], Path] | None = None

    def _files(self) -> dict[tuple[str, str], Path]:
        """``(view_i, view_j) -> file``, from the names stored in the files or their file names (scanned once)."""
        if self._index is None:
            index: dict[tuple[str, str], Path] = {}
            for path in sorted(self.folder.glob("*.npz")):
                key = peek_pair_names(path)
                if key in index or key[::-1] in index:
                    raise SceneError(f"a second file for the pair {key} (first: {(index.get(key) or index[key[::-1]]).name})", where=str(path), field="name")
                index[key] = path
            self._index = index
        return self._index

    def __call__(self, view_i: View, view_j: View) -> Matches:
        files = self._files()
        fwd, bwd = files.get((view_i.name, view_j.name)), files.get((view_j.name, view_i.name))
        if fwd is not None:
            _, _, m = read_pair_matches(fwd, (view_i.shape, view_j.shape))
        elif bwd is not None:
            _, _, r = read_pair_matches(bwd, (view_j.shape, view_i.shape))
            m = Matches(r.xy_j, r.xy_i, r.certainty)
        elif self.options.missing == "error":
            fname = self.folder / pair_file_name(view_i.name, view_j.name)
            raise SceneError(f"no matches for the pair ({view_i.name!r}, {view_j.name!r})", where=str(fname), field="matches")
        else:
            m = Matches(np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0))
        return m.top(self.options.num_matches)


def precomputed_choice(flag: str, folder: str | os.PathLike[str], chosen: str | None) -> tuple[str, dict[str, str]]:
    """Backend name and options for the CLI's ``--points DIR`` / ``--matches DIR``.

    Raises :class:`SceneError` when the folder is missing or ``chosen`` (the
    ``--lifter`` / ``--matcher`` given too) names another backend.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as d:
    ...     precomputed_choice("points", d, None)[0]
    'precomputed-points'
    """
    kind, name = FLAGS[flag]
    root = Path(folder)
    if not root.is_dir():
        raise SceneError("no such folder", where=str(root), field=flag)
    if chosen not in (None, name):
        raise SceneError(f"--{flag} needs the {name} {kind} (got --{kind} {chosen})", where=str(root), field=flag)
    return name, {"folder": str(root.resolve())}
