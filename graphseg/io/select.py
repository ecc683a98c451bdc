"""View selection shared by every reader: ``views=[0, 5, 10]``, ``step=26`` or ``num_views=10``.

Examples
--------
>>> select_indices(20, num_views=5)
[0, 5, 10, 14, 19]
>>> select_indices(10, step=4), select_indices(10, views=[2, 7])
([0, 4, 8], [2, 7])
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..scene import SceneError

__all__ = ["select_indices", "parse_views"]


def parse_views(text: str) -> list[int | str]:
    """``"0,5,10"`` -> ``[0, 5, 10]``; entries that are not integers stay names."""
    out: list[int | str] = []
    for part in text.split(","):
        part = part.strip()
        if not part:
            continue
        out.append(int(part) if part.lstrip("-").isdigit() else part)
    return out


def select_indices(
    n: int,
    *,
    views: Sequence[int | str] | None = None,
    step: int | None = None,
    num_views: int | None = None,
    names: Sequence[str] | None = None,
    where: str = "scene",
) -> list[int]:
    """Indices of the chosen views among ``n`` (at most one of the three options)."""
    given = sum(x is not None for x in (views, step, num_views))
    if given > 1:
        raise SceneError("choose at most one of views, step and num_views", where=where, field="views")
    if views is not None:
        out = []
        for v in views:
            if isinstance(v, str):
                if names is None or v not in names:
                    raise SceneError(f"unknown view {v!r}", where=where, field="views")
                out.append(list(names).index(v))
            else:
                if not -n <= v < n:
                    raise SceneError(f"unknown view {v} (the scene has {n} views)", where=where, field="views")
                out.append(v % n)
        if not out:
            raise SceneError("no views selected", where=where, field="views")
        return out
    if step is not None:
        if step < 1:
            raise SceneError(f"step must be >= 1 (got {step})", where=where, field="step")
        return list(range(0, n, step))
    if num_views is not None:
        if num_views < 1:
            raise SceneError(f"num_views must be >= 1 (got {num_views})", where=where, field="num_views")
        if num_views >= n:
            return list(range(n))
        return [int(x) for x in np.round(np.linspace(0, n - 1, num_views)).astype(int)]
    return list(range(n))
