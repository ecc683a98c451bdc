"""View selection shared by every reader: ``views=[0, 5, 10]``, ``step=26`` or ``num_views=10``.

A string entry of ``views`` is matched against the view names first and, only
if no view has that name, read as an index (so ``"000001"`` on YCB-Video is the
frame named ``000001``, and ``"3"`` on a scene without such a name is index 3).
Integer entries are always indices.

Examples
--------
>>> select_indices(20, num_views=5)
[0, 5, 10, 14, 19]
>>> select_indices(10, step=4), select_indices(10, views=[2, 7])
([0, 4, 8], [2, 7])
>>> select_indices(3, views=["2", "1"], names=["1", "2", "5"])   # names first
[1, 0]
>>> select_indices(3, views=["2"], names=["a", "b", "c"])        # then indices
[2]
>>> select_indices(3, views=["7"], names=["a", "b", "c"])
Traceback (most recent call last):
...
graphseg.scene.SceneError: scene: views: unknown view 7; valid: a, b, c (3 views) or indices 0..2
>>> clamped_num_views(20, 25)   # --num-views 25 on a 20-view scene uses all 20
20
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..scene import SceneError

__all__ = ["select_indices", "parse_views", "clamped_num_views", "describe_views"]


def parse_views(text: str) -> list[int | str]:
    """``"0,5,a"`` -> ``["0", "5", "a"]``: the entries as strings (names first, then indices; see the module docstring).

    Examples
    --------
    >>> parse_views(" 0, 5,,a ")
    ['0', '5', 'a']
    """
    return [part.strip() for part in text.split(",") if part.strip()]


def clamped_num_views(n: int, num_views: int) -> int:
    """The number of views ``num_views=num_views`` selects among ``n``: ``min(n, num_views)``.

    A caller compares it with the request to tell the user that fewer views
    exist than were asked for (``graphseg run --num-views``).

    Examples
    --------
    >>> clamped_num_views(20, 5), clamped_num_views(20, 25)
    (5, 20)
    """
    return min(int(n), int(num_views))


def describe_views(n: int, names: Sequence[str] | None = None, *, show: int = 3) -> str:
    """The valid ``views`` entries of a scene, for error messages.

    Up to ``2 * show`` names are listed in full; longer lists show the first
    ``show`` and the last ``show`` names.

    Examples
    --------
    >>> describe_views(20, [f"{i:06d}" for i in range(1, 21)])
    'valid: 000001, 000002, 000003, ..., 000018, 000019, 000020 (20 views) or indices 0..19'
    >>> describe_views(4)
    'valid: indices 0..3 (4 views)'
    >>> describe_views(0)
    'the scene has no views'
    """
    if n <= 0:
        return "the scene has no views"
    indices = f"indices 0..{n - 1}"
    if not names:
        return f"valid: {indices} ({n} view{'s' if n != 1 else ''})"
    shown = list(names) if len(names) <= 2 * show else [*names[:show], "...", *names[-show:]]
    return f"valid: {', '.join(shown)} ({n} view{'s' if n != 1 else ''}) or {indices}"


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
        name_list = list(names) if names is not None else []
        for v in views:
            if isinstance(v, str):
                if v in name_list:
                    out.append(name_list.index(v))
                    continue
                if not v.lstrip("-").isdigit():
                    raise SceneError(f"unknown view {v!r} (no view has that name); {describe_views(n, name_list)}", where=where, field="views")
                v = int(v)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
                raise SceneError(f"expected view names or indices (got {v!r})", where=where, field="views")
            if not -n <= v < n:
                raise SceneError(f"unknown view {v}; {describe_views(n, name_list)}", where=where, field="views")
            out.append(int(v) % n)
        if not out:
            raise SceneError("no views selected", where=where, field="views")
        if len(set(out)) != len(out):
            raise SceneError("a view is selected twice", where=where, field="views")
        return out
    if step is not None:
        if step < 1:
            raise SceneError(f"step must be >= 1 (got {step})", where=where, field="step")
        return list(range(0, n, step))
    if num_views is not None:
        if num_views < 1:
            raise SceneError(f"num_views must be >= 1 (got {num_views})", where=where, field="num_views")
        if clamped_num_views(n, num_views) == n:
            return list(range(n))
        return [int(x) for x in np.round(np.linspace(0, n - 1, num_views)).astype(int)]
    return list(range(n))
