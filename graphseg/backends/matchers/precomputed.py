"""The ``precomputed-matches`` matcher (CLI ``--matches DIR``): pixel matches computed elsewhere.

Matches are read from ``folder/VIEWI__VIEWJ.npz`` (either order; format:
:mod:`graphseg.io.precomputed`); a pair with no file gets no matches
(``missing="empty"``) or fails (``missing="error"``).

Examples
--------
>>> import tempfile, numpy as np
>>> from graphseg.scene import View
>>> a, b = View("a", np.zeros((4, 4, 3), np.uint8)), View("b", np.zeros((4, 4, 3), np.uint8))
>>> with tempfile.TemporaryDirectory() as d:
...     len(PrecomputedMatcher(folder=d)(a, b))          # no file for the pair: no matches
0
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from ...io.precomputed import pair_file_name, peek_pair_names, read_pair_matches
from ...scene import Matches, SceneError, View
from ..options import Backend
from ..precomputed_folders import precomputed_folder

__all__ = ["PrecomputedMatcher"]


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
        self.folder = precomputed_folder(self.options.folder, "matcher", "matches")
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
