"""The ``precomputed`` segmenter: masks made elsewhere (for example SAM run on a GPU machine).

Per-view label PNGs or NPZ stacks of boolean masks in a folder (format:
:func:`graphseg.io.precomputed.read_masks`). ``save_precomputed`` /
``load_precomputed`` are the io functions' old names, kept for one release.

Examples
--------
>>> import tempfile, numpy as np
>>> from graphseg.scene import View
>>> from graphseg.io.precomputed import write_masks
>>> with tempfile.TemporaryDirectory() as d:
...     _ = write_masks(d, "a", np.array([[0, 1], [2, 2]], np.int32))
...     lab = PrecomputedSegmenter(d)(View("a", np.zeros((2, 2, 3), np.uint8)))
>>> lab.tolist()
[[0, 1], [2, 2]]
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from ...io.precomputed import read_masks, write_masks
from ...scene import SceneError, View
from ..options import Backend

__all__ = ["PrecomputedSegmenter", "save_precomputed", "load_precomputed"]

#: The mask files are an io format (:mod:`graphseg.io.precomputed`); these names stay for one release.
save_precomputed = write_masks
load_precomputed = read_masks


class PrecomputedSegmenter(Backend):
    """Masks read from ``folder`` by view name (see :func:`graphseg.io.precomputed.read_masks`).

    Built as ``PrecomputedSegmenter(folder=PATH)``, or with the folder as the
    one positional argument (``PrecomputedSegmenter(PATH)``).
    """

    name = "precomputed"

    class Options(BaseModel):
        model_config = ConfigDict(extra="forbid")
        folder: str | None = Field(None, description="the masks folder (required)")

    def __init__(self, options: Any = None, /, **kwargs: Any) -> None:
        if isinstance(options, (str, os.PathLike)):  # PrecomputedSegmenter(PATH)
            options, kwargs = None, {**kwargs, "folder": options}
        super().__init__(options, **kwargs)
        if self.options.folder is None:
            raise ValueError("the precomputed segmenter needs folder=PATH (options: {'precomputed': {'folder': ...}})")
        self.folder = Path(self.options.folder)

    def __call__(self, view: View) -> np.ndarray | list[np.ndarray]:
        masks = read_masks(self.folder, view.name)
        shape = masks.shape if isinstance(masks, np.ndarray) else (masks[0].shape if masks else view.shape)
        if tuple(shape) != view.shape:
            raise SceneError(f"masks are {list(shape)} but the image is {list(view.shape)}", where=str(self.folder / view.name), field="masks")
        return masks
