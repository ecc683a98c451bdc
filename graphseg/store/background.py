"""The store's background rule: every view's background from that view alone.

:func:`graphseg.method.segment.segment` fits one table plane, one distance
limit and one table outline on a random sample of the points of *all* views,
so adding a view changes the background of every other view a little (a few
pixels in ten thousand on YCB-Video, see ``docs/store.md``), and with it their
masks, nodes and edges. A store that grows view by view cannot afford that, so
it applies the same rule (:func:`graphseg.method.background.background_masks`,
same options) to each view's own points, with a random seed drawn from the
view's content. A view's background then depends on nothing but the view:
adding views in any order gives every view the same background, and a batch
run with this rule (:func:`per_view_background`, the signature of
``background_masks``) gives the same result as the store.

Examples
--------
>>> import numpy as np
>>> ys, xs = np.mgrid[0:20, 0:20] / 20.0
>>> table = np.dstack([xs, ys, np.zeros_like(xs)]).astype(np.float32)
>>> table[8:12, 8:12, 2] = 0.1                       # a small box on the table
>>> bg, info = view_background(table, np.array([0.5, 0.5, 1.0]))
>>> bool(bg[0, 0]), bool(bg[10, 10]), info["plane"] is not None
(True, False, True)
>>> [m.tolist() for m in per_view_background([table], [np.array([0.5, 0.5, 1.0])])[0]] == [bg.tolist()]
True
"""

from __future__ import annotations

import zlib
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..config import BackgroundConfig
from ..method.background import BackgroundInfo, background_masks

__all__ = ["view_seed", "view_background", "per_view_background"]


def view_seed(points: np.ndarray, seed: int | None = 0) -> list[int] | None:
    """The random seed of one view's background fit: ``[seed, crc32(points)]`` (None: fresh entropy).

    Drawn from the view's content, not from its position in the scene, so a
    view gets the same background whatever views come before it.

    Examples
    --------
    >>> p = np.zeros((2, 2, 3), np.float32)
    >>> view_seed(p) == view_seed(p.copy()), view_seed(p, None)
    (True, None)
    """
    if seed is None:
        return None
    data = np.ascontiguousarray(np.asarray(points, np.float32))
    return [int(seed), zlib.crc32(data.tobytes())]


def view_background(
    points: np.ndarray,
    center: np.ndarray | None,
    config: BackgroundConfig | None = None,
    *,
    seed: int | None = 0,
) -> tuple[np.ndarray, dict[str, Any]]:
    """The background of one view, fitted on that view's points only.

    Parameters
    ----------
    points : float ``[H, W, 3]``
        World points (NaN = invalid).
    center : float ``[3]`` or None
        The camera centre (None: no distance rule, no plane orientation).
    config : BackgroundConfig, optional
    seed : int or None, keyword-only
        Combined with the view's content by :func:`view_seed`.

    Returns
    -------
    background : bool ``[H, W]``
    info : dict
        ``plane`` (``[nx, ny, nz, d]`` or None), ``max_distance`` and
        ``fraction`` (the share of background pixels).

    Notes
    -----
    The cost of :func:`~graphseg.method.background.background_masks` on one
    view: a RANSAC fit on at most ``ransac_sample`` points and O(H W).
    """
    cfg = config or BackgroundConfig()
    centers = None if center is None else [np.asarray(center, np.float64)]
    masks, info = background_masks([points], centers, cfg, rng=view_seed(points, seed))
    plane = None if info.plane is None else [float(x) for x in info.plane]
    return masks[0], {"plane": plane, "max_distance": info.max_distance, "fraction": float(masks[0].mean()) if masks[0].size else 0.0}


def per_view_background(
    points: Sequence[np.ndarray],
    cam_centers: Sequence[np.ndarray] | None,
    config: BackgroundConfig | None = None,
    *,
    rng: Any = None,
    seed: int | None = 0,
) -> tuple[list[np.ndarray], BackgroundInfo]:
    """:func:`view_background` of every view, with the signature of ``background_masks``.

    ``rng`` is accepted and ignored (each view's seed comes from ``seed`` and
    its content), so this function can stand in for
    :func:`graphseg.method.background.background_masks` in a batch run that
    should match a store.

    Returns
    -------
    masks : list of bool ``[H, W]``
    info : BackgroundInfo
        ``plane`` and ``max_distance`` of the first view, ``fraction`` of every view.
    """
    out: list[np.ndarray] = []
    infos: list[dict[str, Any]] = []
    for v, p in enumerate(points):
        c = None if cam_centers is None else cam_centers[v]
        b, i = view_background(p, c, config, seed=seed)
        out.append(b)
        infos.append(i)
    first = infos[0] if infos else {"plane": None, "max_distance": None}
    plane = None if first["plane"] is None else tuple(first["plane"])
    return out, BackgroundInfo(plane=plane, max_distance=first["max_distance"], fraction=[i["fraction"] for i in infos])
