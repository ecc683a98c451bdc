"""Pair selection: which views are matched against each other.

Mode ``pose`` keeps pairs whose camera poses are close: the rotation angle
between them is ``<= max_rotation`` (radians; default 1.2) and the distance
between the camera centres is ``<= max_translation`` (default: the scene scale,
i.e. the median camera-to-scene distance, times ``translation_scale``). The
official code compared a pose with itself, so its translation term was always
0; here both terms count. Mode ``all`` keeps every pair (meant for N <= 8);
mode ``auto`` (the default) is ``all`` for N <= ``auto_max_views`` (8) views
and ``pose`` above.

Examples
--------
>>> import numpy as np
>>> a = np.eye(4); b = np.eye(4); b[0, 3] = 0.5
>>> pose_distance(a, b)
(0.0, 0.5)
>>> select_pairs([a, b], max_translation=0.4), select_pairs([a, b], max_translation=0.6)
([], [(0, 1)])
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["pose_distance", "select_pairs", "scene_scale"]


def pose_distance(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """Rotation angle (rad) and translation distance between two ``cam_to_world`` poses."""
    a = np.asarray(a, np.float64)
    b = np.asarray(b, np.float64)
    r = a[:3, :3].T @ b[:3, :3]
    cos = np.clip((np.trace(r) - 1) / 2, -1.0, 1.0)
    return float(np.arccos(cos)), float(np.linalg.norm(a[:3, 3] - b[:3, 3]))


def scene_scale(points: Sequence[np.ndarray | None], cam_to_world: Sequence[np.ndarray | None]) -> float:
    """Median over views of the median distance from the camera to its valid points (metres).

    Falls back to the median distance between camera centres (or 1.0) without points.
    """
    meds = []
    for p, T in zip(points, cam_to_world):
        if p is None:
            continue
        q = np.asarray(p, np.float32).reshape(-1, 3)[::7]
        q = q[np.isfinite(q).all(1)]
        if len(q):
            meds.append(float(np.median(np.linalg.norm(q - np.asarray(T, np.float32)[:3, 3], axis=1))))
    if meds:
        return float(np.median(meds))
    c = np.array([np.asarray(T)[:3, 3] for T in cam_to_world])
    if len(c) > 1:
        d = np.linalg.norm(c[:, None] - c[None], axis=-1)
        return float(np.median(d[np.triu_indices(len(c), 1)])) or 1.0
    return 1.0


def select_pairs(
    cam_to_world: Sequence[np.ndarray | None],
    *,
    mode: str = "pose",
    max_rotation: float = 1.2,
    max_translation: float | None = None,
    translation_scale: float = 1.0,
    scale: float | None = None,
    auto_max_views: int = 8,
) -> list[tuple[int, int]]:
    """View pairs ``(i, j)``, ``i < j``, to match.

    Parameters
    ----------
    cam_to_world : list of ``[4, 4]`` (or None when unknown)
    mode : {"pose", "all", "auto"}
        Without poses every pair is returned whatever the mode. ``auto``:
        ``all`` up to ``auto_max_views`` views, else ``pose``.
    max_rotation : float
        Radians.
    max_translation : float, optional
        Metres; default ``translation_scale * scale``.
    scale : float, optional
        Scene scale (see :func:`scene_scale`); 1.0 when not given.

    Notes
    -----
    O(N^2) pose comparisons.
    """
    n = len(cam_to_world)
    everything = [(i, j) for i in range(n) for j in range(i + 1, n)]
    if mode not in ("pose", "all", "auto"):
        raise ValueError(f"unknown pair mode {mode!r}; choose 'pose', 'all' or 'auto'")
    if mode == "auto":
        mode = "all" if n <= auto_max_views else "pose"
    if mode == "all" or any(T is None for T in cam_to_world):
        return everything
    t_max = max_translation if max_translation is not None else translation_scale * (scale if scale is not None else 1.0)
    out = []
    for i, j in everything:
        rot, trans = pose_distance(cam_to_world[i], cam_to_world[j])  # type: ignore[arg-type]
        if rot <= max_rotation and trans <= t_max:
            out.append((i, j))
    return out
