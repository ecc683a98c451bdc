"""Next-best-view: rank candidate camera poses by what one more photo could settle.

Every candidate pose gets three scores from the current :class:`~graphseg.result.Result`
and the lifted :class:`~graphseg.scene.Scene` it came from; nothing is rendered:

``ambiguity``
    Ambiguous pairs of the graphs. An edge kept close to its criterion's
    threshold (``pixel_match``: ``ratio`` against the stage's ``tau``;
    ``chamfer_3d``: ``distance`` against the edge's or the stage's ``tau``)
    has *closeness* ``max(0, 1 - |log(value / tau)| / log(band))``: 1 at the
    threshold, 0 a factor ``band`` away from it. Final objects whose Chamfer
    distance misses ``tau_3D`` by less than that factor (near misses, read off
    the object clouds) count the same way, and so does every cannot-link
    conflict (a ``sign < 0`` edge inside one object, or an attractive edge
    between two objects) with weight 1. Edges are grouped by the pair of final
    objects they join (a pair ``(k, k)`` for an edge inside object ``k``); a
    group counts once, with its most ambiguous edge: its weight is that
    closeness and its target points are the contact zone of the edge's two
    nodes (their points within ``contact`` of the other node).
``under_seen``
    Objects seen in fewer than two views, and fragments the minimum support
    dropped (object id 0 in the graphs) with enough 3D points to be an object:
    weight ``(2 - views) / 2`` for an object, 1/2 for a fragment; targets are
    their points.
``table``
    Table area not yet seen: a grid of cells on the table plane
    (``result.info["background"]["plane"]``) in a disc around the objects
    (1.3 times their largest horizontal distance from the scene centre); a cell
    is seen when some view's point at its pixel lies at its depth (3 %). The
    raw score is the unseen area (m^2) the candidate sees.

A target counts ``weight x visible fraction x novelty``: the fraction of its
points inside the candidate's image, in front of it and not hidden by the known
surface (a z-buffer of every view's foreground points, at 1/``zcell`` of the
resolution, 3 % depth tolerance); novelty = ``min(1, angle / novelty_deg)``,
the angle at the target's centre between the candidate and the nearest
existing camera. Each term is divided by its largest value over the
candidates (0 when all are 0), so it lies in ``[0, 1]``, and the score is
their weighted sum (:data:`DEFAULT_WEIGHTS`, chosen on the tune half of
``benchmarks/bench_nbv.py``). Equal scores rank by the angle, at the scene
centre, to the nearest camera of the scene (largest first): with nothing to
resolve, the suggestion is the most different viewpoint.

Candidates are given (``cam_to_world [C, 4, 4]``, rendered with the first
view's ``K`` and size) or sampled by :func:`sample_candidates`: rings around the
scene centre (the centre of the objects' bounding box) at the median camera
distance, at the cameras' mean elevation above the table (or the given
elevations), looking at the centre, with the table normal as "up".

Examples
--------
>>> from graphseg.method.segment import segment
>>> from graphseg.testing.scenes import two_boxes_scene
>>> scene, masks, matches = two_boxes_scene()
>>> ranked = suggest_views(scene, segment(scene, masks, matches), num_candidates=8)
>>> len(ranked), sorted(ranked[0].terms), ranked[0].score >= ranked[-1].score
(8, ['ambiguity', 'table', 'under_seen'], True)
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from .geometry import project_points
from .graphs import CorrespondenceGraph, directed_chamfer, node_point_sets
from .result import Result
from .scene import Scene, SceneError, is_rigid
from .sim.boxes import look_at

__all__ = [
    "suggest_views",
    "sample_candidates",
    "closeness",
    "ambiguity_targets",
    "under_seen_targets",
    "unseen_table_cells",
    "Target",
    "ViewScore",
    "NextBestView",
    "TERMS",
    "DEFAULT_WEIGHTS",
]

#: The score terms, in the order of :attr:`ViewScore.terms`.
TERMS = ("ambiguity", "under_seen", "table")
#: Weights of the normalised terms, chosen on the tune half of ``benchmarks/bench_nbv.py``
#: (``benchmarks/results/nbv.tune.json``): of 10 settings, ``under_seen`` alone gave the
#: highest IoU (views used and whole scene, 3-6 views); ``ambiguity`` and ``table`` lowered it.
#: Pass ``weights=`` to use them.
DEFAULT_WEIGHTS: dict[str, float] = {"ambiguity": 0.0, "under_seen": 1.0, "table": 0.0}

# criterion -> (edge column, higher value = stronger edge)
_EDGE_VALUE = {"pixel_match": ("ratio", True), "chamfer_3d": ("distance", False)}


@dataclass
class Target:
    """Something a new view should see: world points ``[P, 3]``, a weight and what it is."""

    points: np.ndarray
    weight: float
    kind: str
    objects: tuple[int, int] = (0, 0)

    @property
    def center(self) -> np.ndarray:
        return np.asarray(self.points, np.float64).mean(0)


@dataclass
class ViewScore:
    """One ranked candidate.

    Attributes
    ----------
    index : int
        Position in the candidate list.
    cam_to_world : float64 ``[4, 4]``
    score : float
        ``sum(weights[t] * terms[t])``.
    terms : dict
        Per term (:data:`TERMS`), the raw value divided by its largest value
        over the candidates, in ``[0, 1]``.
    raw : dict
        Per term, the raw value (``table`` in m^2 of unseen table).
    spread : float
        Degrees, at the scene centre, from the candidate to the nearest camera
        of the scene: among equal scores the larger spread ranks first.
    """

    index: int
    cam_to_world: np.ndarray
    score: float
    terms: dict[str, float]
    raw: dict[str, float] = field(default_factory=dict)
    spread: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: ``index``, ``score``, ``terms``, ``raw``, ``spread``, ``cam_to_world`` (nested lists)."""
        return {
            "index": self.index,
            "score": self.score,
            "terms": dict(self.terms),
            "raw": dict(self.raw),
            "spread": self.spread,
            "cam_to_world": np.asarray(self.cam_to_world, np.float64).tolist(),
        }


# ----------------------------------------------------------------------------- geometry
def _zbuffer(points: np.ndarray, K: np.ndarray, T: np.ndarray, shape: tuple[int, int], cell: int) -> np.ndarray:
    """Nearest depth per ``cell x cell`` block of the image (inf where no point lands)."""
    h, w = shape
    gh, gw = -(-h // cell), -(-w // cell)
    zb = np.full(gh * gw, np.inf)
    if len(points):
        u, v, z, ok = project_points(points, K, T, shape)
        np.minimum.at(zb, (v[ok] // cell) * gw + u[ok] // cell, z[ok])
    return zb.reshape(gh, gw)


def _visible(points: np.ndarray, K: np.ndarray, T: np.ndarray, shape: tuple[int, int], zb: np.ndarray, cell: int, tol: float = 0.03) -> np.ndarray:
    """Which world points ``[N, 3]`` a camera sees: inside its image and not behind the z-buffer (bool ``[N]``)."""
    u, v, z, ok = project_points(points, K, T, shape)
    out = np.zeros(len(z), bool)
    out[ok] = z[ok] <= zb[v[ok] // cell, u[ok] // cell] * (1 + tol)
    return out


def _angle_to_nearest(center: np.ndarray, cam: np.ndarray, existing: np.ndarray) -> float:
    """Degrees, at ``center``, between ``cam`` and the nearest of the ``existing`` cameras ``[V, 3]`` (180 without any)."""
    if len(existing) == 0:
        return 180.0
    a = cam - center
    b = existing - center
    cos = (b @ a) / np.maximum(np.linalg.norm(b, axis=1) * np.linalg.norm(a), 1e-12)
    return float(np.degrees(np.arccos(np.clip(cos.max(), -1.0, 1.0))))


def _novelty(center: np.ndarray, cam: np.ndarray, existing: np.ndarray, angle_deg: float) -> float:
    """``min(1, angle / angle_deg)``: the angle at ``center`` between ``cam`` and the nearest of the ``existing`` cameras ``[V, 3]``."""
    return min(1.0, _angle_to_nearest(center, cam, existing) / angle_deg)


def closeness(value: Any, tau: float, higher_is_stronger: bool, band: float) -> np.ndarray:
    """How close edge evidence lies to its threshold: 1 at ``tau``, 0 a factor ``band`` or more away.

    ``max(0, 1 - |log(value / tau)| / log(band))``; 0 where ``value`` or ``tau``
    is not a positive finite number. ``higher_is_stronger`` only names the
    direction (the measure is symmetric in the log ratio).

    Parameters
    ----------
    value : float array ``[E]``
    tau : float
    higher_is_stronger : bool
    band : float
        ``> 1``.

    Returns
    -------
    float64 ``[E]``

    Examples
    --------
    >>> closeness([0.3, 0.45, 0.6, 1.0], 0.3, True, 2.0).round(3).tolist()
    [1.0, 0.415, 0.0, 0.0]
    >>> closeness([5e-5, 2.5e-5, 1e-4], 5e-5, False, 4.0).round(3).tolist()
    [1.0, 0.5, 0.5]
    """
    if not band > 1:
        raise ValueError(f"band: expected a number > 1 (got {band!r})")
    x = np.asarray(value, np.float64).reshape(-1)
    out = np.zeros(x.shape)
    if not (np.isfinite(tau) and tau > 0):
        return out
    ok = np.isfinite(x) & (x > 0)
    r = np.log(x[ok] / tau) if higher_is_stronger else np.log(tau / x[ok])
    out[ok] = np.maximum(0.0, 1.0 - np.abs(r) / np.log(band))
    return out


# ----------------------------------------------------------------------------- inputs
def _check(scene: Scene, result: Result) -> None:
    names = [v.name for v in scene.views]
    if names != list(result.view_names):
        raise ValueError(f"scene and result differ in views: scene {names[:5]}{'...' if len(names) > 5 else ''}, result {list(result.view_names)[:5]}")
    for v in scene.views:
        if v.K is None or v.cam_to_world is None:
            raise SceneError("next-best-view needs K and cam_to_world for every view", where=v.name, field="cam_to_world" if v.K is not None else "K")
        if v.points is None:
            raise SceneError("no 3D point map; lift the scene first (graphseg.pipeline.lift)", where=v.name, field="points")


def _points(scene: Scene) -> list[np.ndarray]:
    return [np.asarray(v.points, np.float32) for v in scene.views]


def _plane(result: Result) -> tuple[np.ndarray, float] | None:
    p = (result.info.get("background") or {}).get("plane")
    if p is None or len(p) != 4 or not np.isfinite(p).all():
        return None
    n = np.asarray(p[:3], np.float64)
    norm = float(np.linalg.norm(n))
    return (n / norm, float(p[3]) / norm) if norm > 0 else None


def _frame(scene: Scene, result: Result) -> dict[str, Any]:
    """Scene centre, up direction, working distance and mean camera elevation (radians)."""
    cams = np.array([v.camera_center for v in scene.views])
    plane = _plane(result)
    if plane is not None:
        up = plane[0]
    else:  # the image's "up" (-y in OpenCV axes), averaged over the views
        up = -np.mean([np.asarray(v.cam_to_world, np.float64)[:3, 1] for v in scene.views], 0)
        up /= max(float(np.linalg.norm(up)), 1e-12)
    pts = result.object_points.points
    if len(pts):
        center = 0.5 * (pts.min(0) + pts.max(0))
    else:  # where the optical axes meet (least squares), else the mean of the valid points
        A, b = np.zeros((3, 3)), np.zeros(3)
        for v in scene.views:
            d = np.asarray(v.cam_to_world, np.float64)[:3, 2]
            M = np.eye(3) - np.outer(d, d)
            A += M
            b += M @ v.camera_center
        if np.linalg.cond(A) < 1e8:
            center = np.linalg.solve(A, b)
        else:
            allp = np.concatenate([p.reshape(-1, 3) for p in _points(scene)])
            allp = allp[np.isfinite(allp).all(1)]
            center = allp.mean(0) if len(allp) else cams.mean(0) + np.asarray(scene.views[0].cam_to_world)[:3, 2]
    rel = cams - center
    dist = np.linalg.norm(rel, axis=1)
    elev = np.arcsin(np.clip((rel @ up) / np.maximum(dist, 1e-12), -1, 1))
    return {"center": center, "up": up, "distance": float(np.median(dist)), "elevation": float(np.mean(elev)), "plane": plane, "cams": cams}


def sample_candidates(
    scene: Scene,
    result: Result,
    *,
    num: int = 24,
    elevations: Sequence[float] | None = None,
    rng: Any = None,
) -> np.ndarray:
    """Candidate poses on rings around the scene centre, looking at it.

    Parameters
    ----------
    scene : Scene
        Lifted views with poses (their centres give the working distance and elevation).
    result : Result
        Gives the centre (objects' bounding box) and the table normal ("up").
    num : int, keyword-only
        Candidates per ring (24: one every 15 degrees).
    elevations : sequence of float, optional, keyword-only
        Degrees above the table, one ring each; default: the views' mean elevation.
    rng : None, int or Generator, keyword-only
        None: the first ring starts at the first view's azimuth; else a random start.

    Returns
    -------
    float64 ``[num * rings, 4, 4]``
        ``cam_to_world`` (OpenCV axes), ring by ring, azimuth increasing.

    Notes
    -----
    O(num * rings).

    Examples
    --------
    >>> from graphseg.method.segment import segment
    >>> from graphseg.testing.scenes import two_boxes_scene
    >>> scene, masks, matches = two_boxes_scene()
    >>> sample_candidates(scene, segment(scene, masks, matches), num=6, elevations=[30, 60]).shape
    (12, 4, 4)
    """
    if not isinstance(num, (int, np.integer)) or num < 1:
        raise ValueError(f"num: expected an integer >= 1 (got {num!r})")
    _check(scene, result)
    f = _frame(scene, result)
    c, up, dist = f["center"], f["up"], f["distance"]
    e1 = f["cams"][0] - c
    e1 = e1 - (e1 @ up) * up
    if np.linalg.norm(e1) < 1e-9:
        e1 = np.cross(up, np.eye(3)[int(np.argmin(np.abs(up)))])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(up, e1)
    elevs = [float(f["elevation"])] if elevations is None else [float(np.radians(e)) for e in elevations]
    for e in elevs:
        if not -np.pi / 2 < e < np.pi / 2:
            raise ValueError(f"elevations: expected degrees in (-90, 90) (got {np.degrees(e):g})")
    start = 0.0 if rng is None else float(np.random.default_rng(rng).uniform(0, 2 * np.pi))
    out = []
    for e in elevs:
        for k in range(num):
            a = start + 2 * np.pi * k / num
            eye = c + dist * (np.cos(e) * (np.cos(a) * e1 + np.sin(a) * e2) + np.sin(e) * up)
            out.append(look_at(eye, c, up))
    return np.array(out)


def _as_poses(candidates: Any) -> np.ndarray:
    T = np.asarray(candidates, np.float64)
    if T.ndim == 2 and T.shape == (4, 4):
        T = T[None]
    if T.ndim != 3 or T.shape[1:] != (4, 4):
        raise ValueError(f"candidates: expected cam_to_world poses [C, 4, 4] (got {list(T.shape)})")
    for i, t in enumerate(T):
        if not is_rigid(t):
            raise ValueError(f"candidates[{i}]: not a rigid transform (rotation must be orthonormal with det +1)")
    return T


# ----------------------------------------------------------------------------- targets
def _contact(a: np.ndarray, b: np.ndarray, radius: float, cap: int) -> np.ndarray:
    """Points of ``a`` within ``radius`` of ``b`` and of ``b`` within ``radius`` of ``a`` (all of both if none), at most ``cap``."""
    if len(a) and len(b):
        da, _ = cKDTree(b).query(a, distance_upper_bound=radius)
        db, _ = cKDTree(a).query(b, distance_upper_bound=radius)
        near = np.concatenate([a[np.isfinite(da)], b[np.isfinite(db)]])
    else:
        near = np.zeros((0, 3))
    pts = near if len(near) else np.concatenate([a, b])
    return pts[:: max(1, len(pts) // cap)]


def _stage_tau(result: Result, stage: int, name: str) -> float:
    stages = result.info.get("stages") or []
    if stage < len(stages):
        t = ((stages[stage].get("adders") or {}).get(name) or {}).get("tau")
        if isinstance(t, (int, float)):
            return float(t)
    opts = result.config.criterion_options(name) if name in {s.name for st in result.config.edge_stages for s in st} else {}
    t = opts.get("tau")
    return float(t) if isinstance(t, (int, float)) else float("nan")


def ambiguity_targets(
    scene: Scene,
    result: Result,
    *,
    band: float = 2.0,
    contact: float | None = None,
    stride: int = 2,
    cap: int = 300,
) -> list[Target]:
    """The ambiguous object pairs of ``result`` as :class:`Target` s (see the module docstring).

    Parameters
    ----------
    scene, result
        The lifted scene and its result.
    band : float, keyword-only
        Factor around a threshold within which evidence counts as ambiguous (> 1).
    contact : float, optional, keyword-only
        Radius of the contact zone (m); default 2 % of the working distance.
    stride : int, keyword-only
        Pixel stride when gathering node points.
    cap : int, keyword-only
        Most points per target.

    Returns
    -------
    list of Target
        ``kind`` ``"edge"`` (near-threshold edge), ``"near_miss"`` (objects that
        almost met ``tau_3D``) or ``"conflict"``; ``objects`` the object pair.

    Notes
    -----
    O(total pixels / stride^2) to gather node points, plus k-d tree queries per
    group and one Chamfer query per pair of objects whose boxes are close.
    """
    _check(scene, result)
    points = _points(scene)
    radius = 0.02 * _frame(scene, result)["distance"] if contact is None else float(contact)
    best: dict[tuple[int, int], tuple[float, str, Any]] = {}  # object pair -> (weight, kind, how to get the points)

    def offer(key: tuple[int, int], w: float, kind: str, where: Any) -> None:
        if w > 0 and (key not in best or w > best[key][0]):
            best[key] = (w, kind, where)

    sets: dict[int, Any] = {}
    for s, g in enumerate(result.graphs):
        if g.num_edges == 0 or "object" not in g.node_attr:
            continue
        obj = np.asarray(g.node_attr["object"], np.int64)
        u, v = g.edge_index
        crit = np.asarray(g.edge_attr.get("criterion", np.full(g.num_edges, "")))
        sign = np.asarray(g.edge_attr["sign"], np.float64) if "sign" in g.edge_attr else np.zeros(g.num_edges)
        w = np.zeros(g.num_edges)
        kinds = np.full(g.num_edges, "edge", dtype=object)
        for name, (col, higher) in _EDGE_VALUE.items():
            sel = (crit == name) & ~(sign < 0)
            if not sel.any() or col not in g.edge_attr:
                continue
            tau = np.full(int(sel.sum()), _stage_tau(result, s, name))
            if "tau" in g.edge_attr:  # per-edge thresholds (spacing-aware Chamfer)
                te = np.asarray(g.edge_attr["tau"], np.float64)[sel]
                tau = np.where(np.isfinite(te) & (te > 0), te, tau)
            vals = np.asarray(g.edge_attr[col], np.float64)[sel]
            w[sel] = [closeness([x], t, higher, band)[0] for x, t in zip(vals, tau)]
        ou, ov = obj[u], obj[v]
        both = (ou > 0) & (ov > 0)
        conflict = both & (((sign < 0) & (ou == ov)) | (~(sign < 0) & (ou != ov)))
        w[conflict] = 1.0
        kinds[conflict] = "conflict"
        w[~both | ((sign < 0) & ~conflict)] = 0.0
        for e in np.flatnonzero(w > 0):
            key = (int(min(ou[e], ov[e])), int(max(ou[e], ov[e])))
            offer(key, float(w[e]), str(kinds[e]), (s, int(u[e]), int(v[e])))
    # near misses of the 3D criterion between final objects
    crit_names = {spec.name for st in result.config.edge_stages for spec in st}
    if "chamfer_3d" in crit_names and result.num_objects > 1:
        stage = next(s for s, st in enumerate(result.config.edge_stages) if any(spec.name == "chamfer_3d" for spec in st))
        tau3 = _stage_tau(result, stage, "chamfer_3d")
        ps = result.object_points
        if np.isfinite(tau3) and tau3 > 0:
            lo = np.array([ps[k].min(0) if len(ps[k]) else np.full(3, np.inf) for k in range(ps.num_nodes)])
            hi = np.array([ps[k].max(0) if len(ps[k]) else np.full(3, -np.inf) for k in range(ps.num_nodes)])
            reach = np.sqrt(band * tau3)
            for a in range(ps.num_nodes):
                for b in range(a + 1, ps.num_nodes):
                    gap = np.maximum(0, np.maximum(lo[a] - hi[b], lo[b] - hi[a]))
                    if not np.isfinite(gap).all() or np.linalg.norm(gap) > reach:
                        continue
                    d = min(directed_chamfer(ps[a], ps[b]), directed_chamfer(ps[b], ps[a]))
                    if d > tau3:
                        offer((a + 1, b + 1), float(closeness([d], tau3, False, band)[0]), "near_miss", ("objects", a, b))
    out = []
    for key, (wt, kind, where) in sorted(best.items()):
        if where[0] == "objects":
            a_pts, b_pts = result.object_points[where[1]], result.object_points[where[2]]
        else:
            s, a, b = where
            if s not in sets:
                g = result.graphs[s]
                sets[s] = node_point_sets(g.node_labels(), points, g.num_nodes, stride=stride) if g.masks is not None else None
            if sets[s] is None:  # no masks stored: the nodes' 3D centroids
                c3 = np.asarray(result.graphs[s].node_attr.get("centroid_3d", np.zeros((result.graphs[s].num_nodes, 3))), np.float64)
                a_pts, b_pts = c3[[a]], c3[[b]]
            else:
                a_pts, b_pts = sets[s][a], sets[s][b]
        pts = _contact(np.asarray(a_pts, np.float64), np.asarray(b_pts, np.float64), radius, cap)
        pts = pts[np.isfinite(pts).all(1)]
        if len(pts):
            out.append(Target(pts, wt, kind, key))
    return out


def _graph_views(g: CorrespondenceGraph) -> np.ndarray:
    """Number of distinct views among the base masks of every node ``[N]``."""
    mem = g.members
    if mem["node"].size == 0:
        return np.zeros(g.num_nodes, np.int64)
    pairs = np.unique(np.stack([mem["node"], mem["view"]]), axis=1)
    return np.bincount(pairs[0], minlength=g.num_nodes)


def under_seen_targets(scene: Scene, result: Result, *, stride: int = 2, cap: int = 300) -> list[Target]:
    """Objects seen in fewer than two views and dropped fragments with enough points, as :class:`Target` s.

    An object ``k`` seen in ``n < 2`` views (views whose label image holds
    ``k``) gets weight ``(2 - n) / 2``; a node of the last stage graph with
    object id 0 (dropped by the minimum support) and at least the minimum
    support's points gets 1/2. Targets hold at most ``cap`` of their points.

    Notes
    -----
    O(total pixels / stride^2).

    Examples
    --------
    >>> from graphseg.method.segment import segment
    >>> from graphseg.testing.scenes import two_boxes_scene
    >>> scene, masks, matches = two_boxes_scene()
    >>> under_seen_targets(scene, segment(scene, masks, matches))   # both boxes are seen in 3 views
    []
    """
    _check(scene, result)
    out = []
    views = np.zeros(result.num_objects + 1, np.int64)
    for lab in result.labels:
        views[np.unique(lab)] += 1
    for k in range(1, result.num_objects + 1):
        if views[k] < 2 and len(result.object_points[k - 1]):
            pts = result.object_points[k - 1]
            out.append(Target(pts[:: max(1, len(pts) // cap)], (2 - int(views[k])) / 2, "object", (k, k)))
    g = result.graphs[-1] if result.graphs else None
    if g is not None and g.masks is not None and "object" in g.node_attr:
        dropped = np.flatnonzero(np.asarray(g.node_attr["object"]) == 0)
        if dropped.size:
            h, w = scene.views[0].shape
            min_points = max(1, int(np.ceil(result.config.objects.min_point_fraction * h * w)))
            sets = node_point_sets(g.node_labels(), _points(scene), g.num_nodes, stride=stride)
            nviews = _graph_views(g)
            for n in dropped:
                pts = sets[int(n)]
                if len(pts) * stride * stride >= min_points and nviews[n] < 2:
                    out.append(Target(pts[:: max(1, len(pts) // cap)], 0.5, "fragment", (0, 0)))
    return out


def unseen_table_cells(scene: Scene, result: Result, *, cells: int = 30, tol: float = 0.03) -> tuple[np.ndarray, float]:
    """Centres ``[U, 3]`` of the table cells no view has seen, and the area of one cell (m^2).

    The grid has ``cells`` cells across the disc on the table plane around the
    scene centre's foot, of radius 1.3 times the objects' largest distance from
    it along the plane (at least 20 % of the working distance). A cell is seen
    when some view's point at the cell centre's pixel lies at the cell's depth
    (within ``tol`` of it). Without a table plane: no cells.

    Notes
    -----
    O(cells^2 * views).

    Examples
    --------
    >>> from graphseg.method.segment import segment
    >>> from graphseg.testing.scenes import two_boxes_scene
    >>> scene, masks, matches = two_boxes_scene()
    >>> c, area = unseen_table_cells(scene, segment(scene, masks, matches))
    >>> c.shape[1], area > 0
    (3, True)
    """
    _check(scene, result)
    f = _frame(scene, result)
    if f["plane"] is None:
        return np.zeros((0, 3)), 0.0
    n, d = f["plane"]
    foot = f["center"] - (f["center"] @ n + d) * n
    a = np.cross(n, np.eye(3)[int(np.argmin(np.abs(n)))])
    a /= np.linalg.norm(a)
    b = np.cross(n, a)
    pts = result.object_points.points
    rel = pts - foot
    rel = rel - np.outer(rel @ n, n)
    radius = max(1.3 * float(np.linalg.norm(rel, axis=1).max()) if len(rel) else 0.0, 0.2 * f["distance"])
    step = 2 * radius / cells
    g = (np.arange(cells) + 0.5) * step - radius
    gx, gy = np.meshgrid(g, g)
    inside = gx**2 + gy**2 <= radius**2
    centres = foot + gx[inside][:, None] * a + gy[inside][:, None] * b
    seen = np.zeros(len(centres), bool)
    for v in scene.views:
        u, r, _, ok = project_points(centres, np.asarray(v.K, np.float64), np.asarray(v.cam_to_world, np.float64), v.shape)
        if not ok.any():
            continue
        cam = v.camera_center
        p = np.asarray(v.points, np.float64)[r[ok], u[ok]]
        dc = np.linalg.norm(centres[ok] - cam, axis=1)
        with np.errstate(invalid="ignore"):
            hit = np.abs(np.linalg.norm(p - cam, axis=1) - dc) <= tol * dc
        seen[np.flatnonzero(ok)[hit]] = True
    return centres[~seen], step * step


def _foreground(scene: Scene, result: Result, stride: int) -> np.ndarray:
    """Valid non-background points of every view ``[M, 3]`` (every ``stride``-th pixel): the known surface."""
    out = []
    for v, p in enumerate(_points(scene)):
        q = p[::stride, ::stride].reshape(-1, 3)
        keep = np.isfinite(q).all(1)
        if result.background is not None:
            keep &= ~np.asarray(result.background[v], bool)[::stride, ::stride].reshape(-1)
        out.append(q[keep])
    return np.concatenate(out).astype(np.float64) if out else np.zeros((0, 3))


# ----------------------------------------------------------------------------- ranking
def suggest_views(
    scene: Scene,
    result: Result,
    candidates: Any = None,
    *,
    num_candidates: int = 24,
    elevations: Sequence[float] | None = None,
    weights: Mapping[str, float] | None = None,
    band: float = 2.0,
    novelty_deg: float = 30.0,
    zcell: int = 4,
    seed: Any = None,
) -> list[ViewScore]:
    """Rank candidate camera poses by the expected gain of one more view (best first).

    Parameters
    ----------
    scene : Scene
        The lifted scene of ``result`` (world ``points``, ``K`` and ``cam_to_world`` per view).
    result : Result
        Its segmentation.
    candidates : array_like ``[C, 4, 4]``, optional
        ``cam_to_world`` poses (OpenCV axes), seen with the first view's ``K``
        and image size; default :func:`sample_candidates`.
    num_candidates : int, keyword-only
        Candidates per ring when sampling.
    elevations : sequence of float, optional, keyword-only
        Ring elevations (degrees) when sampling.
    weights : mapping, optional, keyword-only
        Weight per term (:data:`TERMS`); missing terms take :data:`DEFAULT_WEIGHTS`.
    band : float, keyword-only
        Ambiguity band around a threshold (see :func:`closeness`).
    novelty_deg : float, keyword-only
        Angle from the nearest existing camera at which a target counts fully.
    zcell : int, keyword-only
        Pixel block of the occlusion z-buffer.
    seed : None, int or Generator, keyword-only
        Random start of the sampled rings (None: aligned with the first view).

    Returns
    -------
    list of ViewScore
        One per candidate, highest score first; equal scores (for example all 0:
        nothing ambiguous, nothing seen once) rank by ``spread``, the angle at the
        scene centre to the nearest camera, largest first, then by index.

    Raises
    ------
    ValueError
        For a scene that does not belong to ``result``, bad candidates or weights.
    SceneError
        For a view without pose, intrinsics or point map.

    Notes
    -----
    O(total pixels) to build the targets and the known surface, plus
    O(C * (M + T)) to score ``C`` candidates against ``M`` surface points and
    ``T`` target points and cells.
    """
    w = dict(DEFAULT_WEIGHTS)
    for k, val in (weights or {}).items():
        if k not in TERMS:
            raise ValueError(f"weights: unknown term {k!r}; choose from {', '.join(TERMS)}")
        if not (isinstance(val, (int, float)) and np.isfinite(val) and val >= 0):
            raise ValueError(f"weights[{k!r}]: expected a finite number >= 0 (got {val!r})")
        w[k] = float(val)
    if not (isinstance(zcell, (int, np.integer)) and zcell >= 1):
        raise ValueError(f"zcell: expected an integer >= 1 (got {zcell!r})")
    if not novelty_deg > 0:
        raise ValueError(f"novelty_deg: expected a number > 0 (got {novelty_deg!r})")
    _check(scene, result)
    poses = sample_candidates(scene, result, num=num_candidates, elevations=elevations, rng=seed) if candidates is None else _as_poses(candidates)
    K = np.asarray(scene.views[0].K, np.float64)
    shape = scene.views[0].shape
    f = _frame(scene, result)
    cams = f["cams"]
    surface = _foreground(scene, result, 2)
    amb = ambiguity_targets(scene, result, band=band)
    under = under_seen_targets(scene, result)
    cells, area = unseen_table_cells(scene, result)
    raw = np.zeros((len(poses), len(TERMS)))
    for c, T in enumerate(poses):
        zb = _zbuffer(surface, K, T, shape, int(zcell))
        eye = T[:3, 3]
        for col, targets in ((0, amb), (1, under)):
            raw[c, col] = sum(t.weight * float(_visible(t.points, K, T, shape, zb, int(zcell)).mean()) * _novelty(t.center, eye, cams, novelty_deg) for t in targets)
        if len(cells):
            raw[c, 2] = area * float(_visible(cells, K, T, shape, zb, int(zcell)).sum())
    top = raw.max(0) if len(poses) else np.zeros(len(TERMS))
    norm = np.divide(raw, top, out=np.zeros_like(raw), where=top > 0)
    wv = np.array([w[t] for t in TERMS])
    score = norm @ wv
    spread = np.array([_angle_to_nearest(f["center"], T[:3, 3], cams) for T in poses])
    order = np.lexsort((np.arange(len(poses)), -spread, -score))
    return [
        ViewScore(
            int(i),
            poses[i].copy(),
            float(score[i]),
            {t: float(norm[i, j]) for j, t in enumerate(TERMS)},
            {t: float(raw[i, j]) for j, t in enumerate(TERMS)},
            float(spread[i]),
        )
        for i in order
    ]


class NextBestView:
    """:func:`suggest_views` with its settings held (a thin class).

    Examples
    --------
    >>> NextBestView(weights={"table": 0.0}).weights["table"]
    0.0
    """

    def __init__(self, *, weights: Mapping[str, float] | None = None, band: float = 2.0, num_candidates: int = 24, elevations: Sequence[float] | None = None, novelty_deg: float = 30.0) -> None:
        self.weights = {**DEFAULT_WEIGHTS, **dict(weights or {})}
        self.band = band
        self.num_candidates = num_candidates
        self.elevations = elevations
        self.novelty_deg = novelty_deg

    def __call__(self, scene: Scene, result: Result, candidates: Any = None, *, seed: Any = None) -> list[ViewScore]:
        return suggest_views(
            scene, result, candidates, num_candidates=self.num_candidates, elevations=self.elevations, weights=self.weights, band=self.band, novelty_deg=self.novelty_deg, seed=seed
        )
