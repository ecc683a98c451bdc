"""The ``oracle-parts`` segmenter (EVALUATION ONLY) and the straight cuts it makes.

It needs ground-truth instances: every object's mask is cut into ``parts``
pieces by random straight cuts (:func:`split_mask`, also used by the test
scenes), so the graph stage can be measured apart from the segmenter.

Examples
--------
>>> import numpy as np
>>> m = np.zeros((4, 8), bool); m[:, 2:6] = True
>>> parts = split_mask(m, 2, rng=0)
>>> [int(p.sum()) for p in parts], bool((parts[0] & parts[1]).any())
([8, 8], False)
"""

from __future__ import annotations

import zlib
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from ...scene import SceneError, View
from ..options import Backend

__all__ = ["split_mask", "OraclePartsSegmenter"]


def split_mask(mask: np.ndarray, k: int, *, rng: Any = None, angle: float | None = None) -> list[np.ndarray]:
    """Cut ``mask`` into ``k`` parts of (nearly) equal area by parallel straight cuts.

    Parameters
    ----------
    mask : bool ``[H, W]``
    k : int
        Number of parts (>= 1); fewer come back if the mask has fewer pixels.
    rng : seed or Generator, keyword-only
        Draws the cut direction when ``angle`` is None.
    angle : float, optional
        Cut-normal direction in radians (0 = cuts are vertical lines).

    Returns
    -------
    list of bool ``[H, W]``
        Disjoint parts whose union is ``mask``; empty parts are omitted.
    """
    if k < 1:
        raise ValueError(f"expected k >= 1 (got {k})")
    mask = np.asarray(mask, bool)
    ys, xs = np.nonzero(mask)
    if k == 1 or xs.size <= 1:
        return [mask.copy()] if xs.size else []
    theta = float(np.random.default_rng(rng).uniform(0, np.pi)) if angle is None else angle
    proj = xs * np.cos(theta) + ys * np.sin(theta)
    order = np.argsort(proj, kind="stable")
    part = np.empty(xs.size, np.int64)
    part[order] = (np.arange(xs.size) * k) // xs.size
    out = []
    for p in range(k):
        m = np.zeros_like(mask)
        sel = part == p
        if sel.any():
            m[ys[sel], xs[sel]] = True
            out.append(m)
    return out


class OraclePartsSegmenter(Backend):
    """EVALUATION ONLY (needs ground-truth instances): each object cut into ``parts`` random pieces."""
    parallel = True  # weight-free: views (pairs) may run in worker processes

    name = "oracle-parts"

    class Options(BaseModel):
        model_config = ConfigDict(extra="forbid")
        parts: int = Field(2, ge=1, description="pieces per object")
        seed: int | None = Field(0, ge=0, description="the random cuts, per view (None: fresh entropy)")

    def __call__(self, view: View) -> list[np.ndarray]:
        if view.instances is None:
            raise SceneError("oracle-parts needs ground-truth instances (it is for evaluation only)", where=view.name, field="instances")
        seed = self.options.seed
        gen = np.random.default_rng(None if seed is None else [seed, zlib.crc32(view.name.encode())])
        masks: list[np.ndarray] = []
        inst = np.asarray(view.instances)
        for k in np.unique(inst):
            if k != 0:
                masks += split_mask(inst == k, self.options.parts, rng=gen)
        return masks
