"""Alignment: Umeyama similarity, global alignment of pairwise point maps, metric scale.

Pairwise 3D models (DUSt3R, MASt3R) predict, for an image pair ``(i, j)``, both
views' point maps in the camera frame of ``i`` with an unknown scale per pair.
:func:`global_align` puts all views into one world frame as DUSt3R's global
aligner does, with graphseg's own code (numpy/scipy):

1. Initialisation: the maximum spanning tree of the view graph weighted by the
   pair confidence (``scipy.sparse.csgraph.minimum_spanning_tree`` on the
   negated weight); the strongest pair fixes the world frame, and every other
   view is placed along the tree by a confidence-weighted similarity
   (:func:`umeyama`) between the points the tree edge shares with the placed view.
2. Refinement (``iterations`` rounds, on a fixed random subsample of ``sample``
   pixels): every pair gets the similarity that best maps its two point maps onto
   the current world points, and every view's world points become the
   confidence-weighted mean of its pairs' mapped points (block-coordinate descent
   on DUSt3R's objective ``sum_e sum_v c * ||X_v - s_e P_e X^e_v||^2``), with the
   gauge fixed on the root view. The dense world point maps are then the
   confidence-weighted means of all pairs' maps under the final similarities.
3. Cameras: each view's pose is the similarity that maps its own camera-frame
   point map (from a pair where it comes first) onto its world point map; its
   focal length is the least-squares fit of that map's projections to the pixel
   grid (principal point at the image centre).

Metric scale (:func:`metric_scale`): known camera poses (a robot's) give a
similarity from the predicted to the known cameras (Umeyama on the camera
centres, or with fewer than three non-collinear centres the mean rotation of the
orientations and the ratio of baselines), as the original GraphSeg code
calibrates DUSt3R. Without known poses the reconstruction is scaled so that the
median camera-to-point distance equals :data:`NOMINAL_WORKING_DISTANCE` (metres),
so thresholds given in metres apply. Either way ``scene.meta["scale"]`` records
``{"metric": bool, "factor": float, "method": str}``.

Examples
--------
>>> import numpy as np
>>> src = np.random.default_rng(0).normal(size=(10, 3))
>>> s, R, t = umeyama(src, 2.0 * src + [1.0, 0, 0])
>>> round(s, 6), np.allclose(R, np.eye(3)), np.allclose(t, [1, 0, 0])
(2.0, True, True)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...scene import Scene

__all__ = [
    "umeyama",
    "PairPointMaps",
    "Alignment",
    "global_align",
    "estimate_focal",
    "similarity_to_known_poses",
    "apply_similarity",
    "metric_scale",
    "NOMINAL_WORKING_DISTANCE",
    "finish_lift",
    "lift_from_alignment",
]

#: Median camera-to-point distance (metres) a reconstruction of unknown scale is given: a
#: tabletop seen from a robot's wrist or head camera at arm's length.
NOMINAL_WORKING_DISTANCE = 0.6


def umeyama(src: np.ndarray, dst: np.ndarray, *, with_scale: bool = True) -> tuple[float, np.ndarray, np.ndarray]:
    """The similarity ``dst ≈ s R src + t`` minimising the squared error (Umeyama 1991).

    Parameters
    ----------
    src, dst : float ``[N, 3]``
        Corresponding points, ``N >= 3`` (not all collinear for a unique rotation).
    with_scale : bool
        False fixes ``s = 1`` (a rigid transform).

    Returns
    -------
    s : float
    R : float64 ``[3, 3]``, a rotation (det +1)
    t : float64 ``[3]``

    Notes
    -----
    O(N): one 3x3 covariance and its SVD.

    Examples
    --------
    >>> import numpy as np
    >>> R0 = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])
    >>> src = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> s, R, t = umeyama(src, 3 * src @ R0.T + 1)
    >>> round(s, 6), np.allclose(R, R0), np.allclose(t, 1)
    (3.0, True, True)
    """
    return _weighted_umeyama(src, dst, None, with_scale=with_scale)


def _weighted_umeyama(src: np.ndarray, dst: np.ndarray, w: np.ndarray | None, *, with_scale: bool = True) -> tuple[float, np.ndarray, np.ndarray]:
    src = np.asarray(src, np.float64)
    dst = np.asarray(dst, np.float64)
    if src.ndim != 2 or src.shape[1] != 3 or dst.shape != src.shape:
        raise ValueError(f"expected src and dst of shape [N, 3] (got {list(src.shape)} and {list(dst.shape)})")
    if len(src) < 3:
        raise ValueError(f"expected at least 3 point pairs (got {len(src)})")
    if not (np.isfinite(src).all() and np.isfinite(dst).all()):
        raise ValueError("expected finite src and dst (got NaN or inf)")
    w = np.ones(len(src)) if w is None else np.asarray(w, np.float64)
    w = w / w.sum()
    mu_s, mu_d = w @ src, w @ dst
    a, b = src - mu_s, dst - mu_d
    cov = (b * w[:, None]).T @ a
    U, D, Vt = np.linalg.svd(cov)
    S = np.eye(3)
    if np.linalg.det(U) * np.linalg.det(Vt) < 0:
        S[2, 2] = -1
    R = U @ S @ Vt
    var = float(w @ (a * a).sum(1))
    s = float(np.trace(np.diag(D) @ S) / var) if with_scale and var > 0 else 1.0
    t = mu_d - s * R @ mu_s
    return s, R, t


# ----------------------------------------------------------------------------- global alignment
@dataclass
class PairPointMaps:
    """One pairwise prediction: both views' point maps in the camera frame of view ``i``.

    Attributes
    ----------
    i, j : int
    pts_i, pts_j : float ``[H, W, 3]`` (NaN = invalid)
    conf_i, conf_j : float ``[H, W]``, >= 0
    """

    i: int
    j: int
    pts_i: np.ndarray
    pts_j: np.ndarray
    conf_i: np.ndarray
    conf_j: np.ndarray

    def of(self, v: int) -> tuple[np.ndarray, np.ndarray]:
        """``(points, confidence)`` of view ``v`` (one of ``i``, ``j``)."""
        return (self.pts_i, self.conf_i) if v == self.i else (self.pts_j, self.conf_j)


@dataclass
class Alignment:
    """The output of :func:`global_align`.

    Attributes
    ----------
    points : list of float32 ``[H, W, 3]`` world point maps (NaN = invalid)
    confidence : list of float32 ``[H, W]`` (max over the view's pairs)
    cam_to_world : float64 ``[N, 4, 4]``
    K : float64 ``[N, 3, 3]``
    info : dict (tree edges, residuals per round)
    """

    points: list[np.ndarray]
    confidence: list[np.ndarray]
    cam_to_world: np.ndarray
    K: np.ndarray
    info: dict[str, Any] = field(default_factory=dict)


def _sample(valid_w: np.ndarray, n: int, gen: np.random.Generator) -> np.ndarray:
    idx = np.flatnonzero(valid_w > 0)
    if len(idx) > n:
        idx = idx[gen.integers(0, len(idx), n)]  # with replacement: O(n), harmless for a fit
    return idx


def _apply(sim: tuple[float, np.ndarray, np.ndarray], pts: np.ndarray) -> np.ndarray:
    s, R, t = sim
    return np.asarray(pts, np.float32) @ (s * R.T).astype(np.float32) + t.astype(np.float32)


def _compose(a: tuple[float, np.ndarray, np.ndarray], b: tuple[float, np.ndarray, np.ndarray]) -> tuple[float, np.ndarray, np.ndarray]:
    """``a`` after ``b``."""
    return a[0] * b[0], a[1] @ b[1], a[0] * a[1] @ b[2] + a[2]


def _flat(p: np.ndarray, c: np.ndarray, min_conf: float) -> tuple[np.ndarray, np.ndarray]:
    p = np.asarray(p, np.float32).reshape(-1, 3)
    c = np.asarray(c, np.float32).reshape(-1).copy()
    c[~np.isfinite(p).all(1) | ~(c >= min_conf)] = 0
    return p, c


def estimate_focal(points_cam: np.ndarray, confidence: np.ndarray | None = None, *, min_conf: float = 0.0) -> float:
    """Focal length (pixels) of a camera-frame point map ``[H, W, 3]``, principal point at the centre.

    Least squares of ``f (X/Z, Y/Z) = (u - cx, v - cy)`` weighted by confidence; O(H W).

    Examples
    --------
    >>> from graphseg.scene import backproject
    >>> K = np.array([[50.0, 0, 15.5], [0, 50, 11.5], [0, 0, 1]])
    >>> round(estimate_focal(backproject(np.full((24, 32), 2.0), K)), 6)
    50.0
    """
    P = np.asarray(points_cam, np.float64)
    h, w = P.shape[:2]
    c = np.ones((h, w)) if confidence is None else np.asarray(confidence, np.float64)
    u, v = np.meshgrid(np.arange(w) - (w - 1) / 2, np.arange(h) - (h - 1) / 2)
    z = P[..., 2]
    ok = np.isfinite(P).all(-1) & (z > 1e-9) & (c > min_conf)
    if not ok.any():
        return float(max(h, w))
    px, py = P[..., 0][ok] / z[ok], P[..., 1][ok] / z[ok]
    wt = c[ok]
    num = (wt * (px * u[ok] + py * v[ok])).sum()
    den = (wt * (px * px + py * py)).sum()
    return float(num / den) if den > 0 and num > 0 else float(max(h, w))


def global_align(
    pairs: Sequence[PairPointMaps],
    num_views: int,
    *,
    iterations: int = 10,
    min_conf: float = 0.0,
    sample: int = 20_000,
    rng: Any = None,
) -> Alignment:
    """Align pairwise point maps into one world frame (see the module docstring).

    Parameters
    ----------
    pairs : list of PairPointMaps
        Ordered pairs; every view must occur in the pair graph, which must be
        connected, and every view must come first in at least one pair (its own
        camera frame gives its pose; DUSt3R's symmetrised pairs do).
    num_views : int
    iterations : int
        Refinement rounds (0 = the spanning-tree initialisation only).
    min_conf : float
        Pixels with a lower confidence are ignored.
    sample : int
        Pixels per point map drawn (uniformly among the valid ones) to fit each similarity.
    rng : seed or Generator

    Returns
    -------
    Alignment
        World frame = the camera frame of the first view of the strongest pair,
        at that pair's scale.

    Notes
    -----
    O(E H W + iterations * E * sample) for E pairs of H x W point maps.
    """
    gen = np.random.default_rng(rng)
    if not pairs:
        raise ValueError("expected at least one pair of point maps")
    shape = np.asarray(pairs[0].pts_i).shape[:2]
    for p in pairs:
        if not (0 <= p.i < num_views and 0 <= p.j < num_views) or p.i == p.j:
            raise ValueError(f"expected pairs of distinct views in [0, {num_views}) (got {(p.i, p.j)})")
        for arr, want in ((p.pts_i, (*shape, 3)), (p.pts_j, (*shape, 3)), (p.conf_i, shape), (p.conf_j, shape)):
            if np.shape(arr) != want:
                raise ValueError(f"expected point maps [H, W, 3] and confidences [H, W] of one size {list(shape)} (got {list(np.shape(arr))} in pair {(p.i, p.j)})")
    firsts = {p.i for p in pairs}
    if firsts != set(range(num_views)):
        raise ValueError(f"every view must come first in some pair (missing: {sorted(set(range(num_views)) - firsts)})")
    flat = [(_flat(p.pts_i, p.conf_i, min_conf), _flat(p.pts_j, p.conf_j, min_conf)) for p in pairs]
    score = np.array([float(a[1].mean() * b[1].mean()) for a, b in flat])

    # 1. maximum-confidence spanning tree over views (strongest of (i, j) / (j, i) per edge)
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import breadth_first_order, minimum_spanning_tree

    best: dict[tuple[int, int], int] = {}
    for e, p in enumerate(pairs):
        key = (min(p.i, p.j), max(p.i, p.j))
        if key not in best or score[e] > score[best[key]]:
            best[key] = e
    keys = list(best)
    wts = np.array([-(score[best[k]] + 1e-12) for k in keys])
    g = coo_matrix((wts, ([k[0] for k in keys], [k[1] for k in keys])), shape=(num_views, num_views)).tocsr()
    tree = minimum_spanning_tree(g)
    tree = tree + tree.T
    root_edge = best[keys[int(np.argmin(wts))]]
    root = pairs[root_edge].i
    order, pred = breadth_first_order(tree, root, directed=False)
    if len(order) != num_views:
        raise ValueError(f"the pair graph is not connected (views {sorted(set(range(num_views)) - set(order.tolist()))} unreachable)")
    world: list[np.ndarray | None] = [None] * num_views
    wconf: list[np.ndarray | None] = [None] * num_views
    (pi, ci), (pj, cj) = flat[root_edge]
    r = pairs[root_edge]
    world[r.i], wconf[r.i], world[r.j], wconf[r.j] = pi, ci, pj, cj
    tree_edges = [(r.i, r.j)]
    for v in order:
        if world[v] is not None:
            continue
        u = int(pred[v])
        e = best[(min(u, v), max(u, v))]
        p = pairs[e]
        fu, fv = flat[e] if p.i == u else flat[e][::-1]
        wu = world[u]
        assert wu is not None and wconf[u] is not None
        c = fu[1] * wconf[u]
        idx = _sample(c * np.isfinite(wu).all(1), sample, gen)
        sim = _weighted_umeyama(fu[0][idx], wu[idx], c[idx])
        world[v] = _apply(sim, fv[0])
        wconf[v] = fv[1]
        tree_edges.append((u, int(v)))

    # 2. refinement on a fixed pixel subsample: per-pair similarities <-> per-view weighted means
    hw = shape[0] * shape[1]
    sub = np.sort(gen.choice(hw, size=min(hw, sample), replace=False)) if hw > sample else np.arange(hw)
    wsub = [np.asarray(w)[sub] for w in world]
    csub = [np.asarray(c)[sub] for c in wconf]
    root_ref = wsub[root].copy()
    residuals = []
    sims: list[tuple[float, np.ndarray, np.ndarray]] = []
    for _ in range(iterations):
        acc = [np.zeros((len(sub), 3)) for _ in range(num_views)]
        wsum = [np.zeros(len(sub)) for _ in range(num_views)]
        err = 0.0
        sims = []
        for e, p in enumerate(pairs):
            (pi, ci), (pj, cj) = flat[e]
            src = np.concatenate([pi[sub], pj[sub]])
            dst = np.concatenate([wsub[p.i], wsub[p.j]])
            c = np.concatenate([ci[sub] * csub[p.i], cj[sub] * csub[p.j]])
            ok = c * np.isfinite(dst).all(1) * np.isfinite(src).all(1)
            idx = np.flatnonzero(ok > 0)
            if len(idx) < 3:
                raise ValueError(f"pair {(p.i, p.j)} shares fewer than 3 confident points with the alignment")
            sim = _weighted_umeyama(src[idx], dst[idx], ok[idx])
            sims.append(sim)
            moved = _apply(sim, src)
            err += float(np.sqrt((ok[idx] * ((moved[idx] - dst[idx]) ** 2).sum(1)).sum() / ok[idx].sum()))
            n = len(sub)
            for v, m, cv in ((p.i, moved[:n], ci[sub]), (p.j, moved[n:], cj[sub])):
                good = (cv > 0) & np.isfinite(m).all(1)
                acc[v][good] += cv[good, None] * m[good]
                wsum[v][good] += cv[good]
        residuals.append(err / len(pairs))
        new = []
        for v in range(num_views):
            x = np.full((len(sub), 3), np.nan, np.float32)
            okv = wsum[v] > 0
            x[okv] = (acc[v][okv] / wsum[v][okv, None]).astype(np.float32)
            new.append(x)
        okr = np.isfinite(new[root]).all(1) & np.isfinite(root_ref).all(1)
        gauge = _weighted_umeyama(new[root][okr], root_ref[okr], None)
        wsub = [_apply(gauge, x) for x in new]
        sims = [_compose(gauge, sm) for sm in sims]
    if sims:  # dense world maps: each view's confidence-weighted mean over its pairs
        acc = [np.zeros((hw, 3), np.float32) for _ in range(num_views)]
        wsum = [np.zeros(hw, np.float32) for _ in range(num_views)]
        for e, p in enumerate(pairs):
            for v, (pts_v, cv) in ((p.i, flat[e][0]), (p.j, flat[e][1])):
                m = _apply(sims[e], pts_v)
                good = (cv > 0) & np.isfinite(m).all(1)
                acc[v][good] += cv[good, None] * m[good]
                wsum[v][good] += cv[good]
        world = []
        for v in range(num_views):
            x = np.full((hw, 3), np.nan, np.float32)
            okv = wsum[v] > 0
            x[okv] = acc[v][okv] / wsum[v][okv, None]
            world.append(x)

    # 3. cameras
    conf_out = [np.zeros(shape[0] * shape[1], np.float32) for _ in range(num_views)]
    own: dict[int, tuple[int, float]] = {}
    for e, p in enumerate(pairs):
        (_, ci), (_, cj) = flat[e]
        conf_out[p.i] = np.maximum(conf_out[p.i], ci)
        conf_out[p.j] = np.maximum(conf_out[p.j], cj)
        if p.i not in own or score[e] > own[p.i][1]:
            own[p.i] = (e, float(score[e]))
    c2w = np.tile(np.eye(4), (num_views, 1, 1))
    Ks = np.tile(np.eye(3), (num_views, 1, 1))
    h, w = shape
    for v in range(num_views):
        e = own[v][0]
        (pc, cc), _ = flat[e]
        wv = world[v]
        assert wv is not None
        ok = cc * np.isfinite(wv).all(1)
        idx = _sample(ok, 2 * sample, gen)
        s, R, t = _weighted_umeyama(pc[idx], wv[idx], ok[idx])
        c2w[v, :3, :3], c2w[v, :3, 3] = R, t
        f = estimate_focal(pc.reshape(h, w, 3), cc.reshape(h, w))
        Ks[v] = [[f, 0, (w - 1) / 2], [0, f, (h - 1) / 2], [0, 0, 1]]
    points = []
    for v in range(num_views):
        x = np.asarray(world[v], np.float32).copy()
        x[conf_out[v] <= 0] = np.nan
        points.append(x.reshape(h, w, 3))
    return Alignment(
        points=points,
        confidence=[c.reshape(h, w) for c in conf_out],
        cam_to_world=c2w,
        K=Ks,
        info={"root": int(root), "tree": tree_edges, "residuals": residuals},
    )


# ----------------------------------------------------------------------------- metric scale
def _mean_rotation(Rs: np.ndarray) -> np.ndarray:
    U, _, Vt = np.linalg.svd(Rs.sum(0))
    S = np.diag([1.0, 1.0, float(np.sign(np.linalg.det(U @ Vt)) or 1.0)])
    return U @ S @ Vt


def similarity_to_known_poses(predicted: np.ndarray, known: np.ndarray) -> tuple[float, np.ndarray, np.ndarray, str]:
    """Similarity ``(s, R, t, method)`` taking predicted ``cam_to_world`` ``[N, 4, 4]`` to known ones.

    ``method`` is ``"umeyama"`` (camera centres, N >= 3 not collinear) or
    ``"baseline"`` (rotation = mean of ``R_known R_pred^T``, scale = ratio of
    the summed baselines to the first view, translation from the centroids).

    Examples
    --------
    >>> A = np.tile(np.eye(4), (2, 1, 1)); A[1, 0, 3] = 1.0
    >>> B = A.copy(); B[1, 0, 3] = 0.25
    >>> s, R, t, how = similarity_to_known_poses(A, B)
    >>> round(s, 6), how
    (0.25, 'baseline')
    """
    P = np.asarray(predicted, np.float64)
    Q = np.asarray(known, np.float64)
    if P.shape != Q.shape or P.ndim != 3 or P.shape[1:] != (4, 4) or len(P) < 2:
        raise ValueError(f"expected two [N, 4, 4] pose stacks with N >= 2 (got {list(P.shape)} and {list(Q.shape)})")
    cp, cq = P[:, :3, 3], Q[:, :3, 3]
    spread = np.linalg.svd(cp - cp.mean(0), compute_uv=False)
    if len(P) >= 3 and spread[0] > 0 and spread[1] > 1e-3 * spread[0]:
        s, R, t = umeyama(cp, cq)
        return s, R, t, "umeyama"
    R = _mean_rotation(Q[:, :3, :3] @ np.transpose(P[:, :3, :3], (0, 2, 1)))
    dp = np.linalg.norm(cp[1:] - cp[0], axis=1).sum()
    dq = np.linalg.norm(cq[1:] - cq[0], axis=1).sum()
    s = float(dq / dp) if dp > 0 else 1.0
    t = cq.mean(0) - s * R @ cp.mean(0)
    return s, R, t, "baseline"


def apply_similarity(scene: Scene, s: float, R: np.ndarray, t: np.ndarray) -> Scene:
    """The scene with points and camera poses mapped by ``x -> s R x + t`` (intrinsics unchanged)."""
    R = np.asarray(R, np.float64)
    t = np.asarray(t, np.float64)
    views = []
    for v in scene.views:
        changes: dict[str, Any] = {}
        if v.points is not None:
            changes["points"] = (s * np.asarray(v.points, np.float64) @ R.T + t).astype(np.float32)
        if v.cam_to_world is not None:
            T = np.asarray(v.cam_to_world, np.float64)
            new = np.eye(4)
            new[:3, :3] = R @ T[:3, :3]
            new[:3, 3] = s * R @ T[:3, 3] + t
            changes["cam_to_world"] = new
        if v.depth is not None:
            changes["depth"] = (np.asarray(v.depth, np.float32) * np.float32(s)).astype(np.float32)
        views.append(v.replace(**changes))
    return Scene(views, dict(scene.objects), scene.name, dict(scene.meta))


def _median_distance(scene: Scene) -> float:
    meds = []
    for v in scene.views:
        if v.points is None or v.cam_to_world is None:
            continue
        q = np.asarray(v.points, np.float32).reshape(-1, 3)[::7]
        q = q[np.isfinite(q).all(1)]
        if len(q):
            meds.append(float(np.median(np.linalg.norm(q - np.asarray(v.cam_to_world, np.float32)[:3, 3], axis=1))))
    return float(np.median(meds)) if meds else 0.0


def metric_scale(scene: Scene, known_cam_to_world: Sequence[np.ndarray] | np.ndarray | None = None, *, working_distance: float = NOMINAL_WORKING_DISTANCE) -> Scene:
    """Bring a lifted scene of unknown scale to metres (see the module docstring).

    Parameters
    ----------
    scene : Scene
        Views with ``points`` and predicted ``cam_to_world``.
    known_cam_to_world : ``[N, 4, 4]``, optional
        The true camera poses (for example from the robot's kinematics). The
        result then lives in their frame.
    working_distance : float
        Metres; the median camera-to-point distance given to a scene without known poses.

    Returns
    -------
    Scene
        ``meta["scale"] = {"metric", "factor", "method"}``.

    Examples
    --------
    >>> from graphseg.scene import View
    >>> v = View("a", np.zeros((1, 1, 3), np.uint8), points=np.array([[[0, 0, 2.0]]], np.float32), cam_to_world=np.eye(4))
    >>> out = metric_scale(Scene([v]))
    >>> out.meta["scale"]["method"], round(float(out.views[0].points[0, 0, 2]), 6)
    ('nominal-distance', 0.6)
    """
    if known_cam_to_world is not None and len(known_cam_to_world) >= 2:
        pred = np.stack([np.asarray(v.cam_to_world, np.float64) for v in scene.views])
        s, R, t, how = similarity_to_known_poses(pred, np.asarray(known_cam_to_world, np.float64))
        out = apply_similarity(scene, s, R, t)
        out.meta["scale"] = {"metric": True, "factor": float(s), "method": f"known-poses-{how}"}
        return out
    d = _median_distance(scene)
    s = working_distance / d if d > 0 else 1.0
    out = apply_similarity(scene, s, np.eye(3), np.zeros(3))
    out.meta["scale"] = {"metric": False, "factor": float(s), "method": "nominal-distance"}
    return out


def finish_lift(
    scene: Scene,
    points: Sequence[np.ndarray],
    confidence: Sequence[np.ndarray],
    cam_to_world: np.ndarray,
    K: np.ndarray,
    *,
    scale: str = "auto",
    lifter: str = "",
) -> Scene:
    """The lifted scene from predicted world point maps and cameras, brought to metres.

    Parameters
    ----------
    points, confidence : per view ``[H, W, 3]`` / ``[H, W]`` at the image size
    cam_to_world : ``[N, 4, 4]`` predicted; K : ``[N, 3, 3]`` predicted (a view's own ``K`` wins)
    scale : {"auto", "nominal", "none"}
        ``auto``: :func:`metric_scale` with the scene's poses when every view has
        one (they are then the world frame), else the nominal working distance;
        ``nominal``: always the nominal distance; ``none``: left as predicted.
    """
    if scale not in ("auto", "nominal", "none"):
        raise ValueError(f"unknown scale mode {scale!r}; choose 'auto', 'nominal' or 'none'")
    known = [v.cam_to_world for v in scene.views]
    views = [
        v.replace(
            points=np.asarray(p, np.float32),
            confidence=np.asarray(c, np.float32),
            cam_to_world=np.asarray(T, np.float64),
            K=np.asarray(v.K if v.K is not None else k, np.float64),
        )
        for v, p, c, T, k in zip(scene.views, points, confidence, cam_to_world, K)
    ]
    out = Scene(views, dict(scene.objects), scene.name, dict(scene.meta))
    if scale == "none":
        out.meta["scale"] = {"metric": False, "factor": 1.0, "method": "none"}
    else:
        use_known = scale == "auto" and all(T is not None for T in known) and len(known) >= 2
        out = metric_scale(out, np.stack([np.asarray(T, np.float64) for T in known]) if use_known else None)
    if lifter:
        out.meta["lifter"] = lifter
    return out


def lift_from_alignment(scene: Scene, alignment: Alignment, model_hw: tuple[int, int], *, scale: str = "auto", lifter: str = "") -> Scene:
    """:func:`finish_lift` after resizing model-resolution maps to the images (nearest, centre-aligned; K scaled)."""
    from ...io.precomputed import resize_nearest, scale_intrinsics

    shape = scene.views[0].shape
    pts = [np.ascontiguousarray(resize_nearest(p, shape)) for p in alignment.points]
    conf = [np.ascontiguousarray(resize_nearest(c, shape)) for c in alignment.confidence]
    K = np.stack([scale_intrinsics(k, model_hw, shape) for k in alignment.K])
    return finish_lift(scene, pts, conf, alignment.cam_to_world, K, scale=scale, lifter=lifter)
