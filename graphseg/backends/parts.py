"""Splitting a mask into parts by straight cuts (used by ``oracle-parts`` and test scenes).

Examples
--------
>>> import numpy as np
>>> m = np.zeros((4, 8), bool); m[:, 2:6] = True
>>> parts = split_mask(m, 2, rng=0)
>>> [int(p.sum()) for p in parts], bool((parts[0] & parts[1]).any())
([8, 8], False)
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["split_mask"]


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
