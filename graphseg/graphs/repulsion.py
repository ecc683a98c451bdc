"""Repulsive evidence: masks of one view that meet at a depth discontinuity are different objects.

The ``depth_repulsion`` criterion looks at every pair of nodes that touch in
some view (pixels at most ``reach`` apart along a row or column) and measures
the 3D distance across their shared boundary. Where most of the boundary is a
jump of more than ``jump`` metres, the segmenter separated two surfaces, not
two parts of one surface: the pair gets a *cannot-link* edge (``sign = -1``)
that a signed contractor (:mod:`graphseg.graphs.signed`) honours. Plain
components contraction ignores these edges (``segment`` drops them for
contractors that take no edge attributes).

Examples
--------
>>> import numpy as np
>>> lab = np.array([[0, 0, 1, 1]])
>>> pts = np.zeros((1, 4, 3), np.float32); pts[0, 2:, 2] = 0.1   # 10 cm step between the masks
>>> depth_jump_cannot_links([lab], [pts], 2, DepthRepulsion.Options(min_pairs=1)).edge_index.tolist()  # the defaults live in Options
[[0], [1]]
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from ..geometry import point_normals
from .coalesce import coalesce
from .criterion import Criterion
from .evidence import EdgeSet, Evidence
from .graph import CorrespondenceGraph

__all__ = ["boundary_jumps", "boundary_separation", "depth_jump_cannot_links", "DepthRepulsion"]


def boundary_jumps(
    labels: np.ndarray, points: np.ndarray, num_nodes: int, *, reach: int, normals: np.ndarray | None = None, colors: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Node pairs touching in one view and the 3D distances across their boundary.

    Parameters
    ----------
    labels : int ``[H, W]``
        Pixel -> node (-1 = none).
    points : float ``[H, W, 3]``
        World points (NaN = invalid).
    num_nodes : int
    reach : int
        Pixel offsets ``1..reach`` along rows and columns are compared (masks
        often leave a thin unlabelled seam at a depth edge).
    normals : float ``[H, W, 3]``, optional
        Unit normals pointing toward the camera; enables ``convexity``.
    colors : float ``[H, W, C]``, optional
        Per-pixel colour coordinates; enables ``color_dist``.

    Returns
    -------
    lo, hi : int64 ``[P]``
        Node pairs (``lo < hi``), one entry per compared pixel pair.
    dist : float64 ``[P]``
        3D distance between the two pixels' points (metres).
    convexity : float64 ``[P]``
        ``(n_p - n_q) . (x_p - x_q) / |x_p - x_q|`` (LCCP's test): positive
        across a convex edge (a ridge), negative across a concave one (where
        two objects meet), about 0 on a smooth surface; NaN without normals.
    color_dist : float64 ``[P]``
        Euclidean distance of the two pixels' ``colors``; NaN without colours.

    Notes
    -----
    O(reach H W), vectorised.

    Examples
    --------
    >>> lo, hi, d, c, _ = boundary_jumps(np.array([[0, 1]]), np.zeros((1, 2, 3)), 2, reach=1)
    >>> lo.tolist(), hi.tolist(), d.tolist()
    ([0], [1], [0.0])
    """
    lab = np.asarray(labels)
    pts = np.asarray(points)
    if pts.shape != (*lab.shape, 3):
        raise ValueError(f"expected points of shape [{lab.shape[0]}, {lab.shape[1]}, 3] (got {list(pts.shape)})")
    h, w = lab.shape
    nrm = None if normals is None else np.asarray(normals, np.float32).reshape(-1, 3)
    col = None if colors is None else np.asarray(colors, np.float64)
    if col is not None and (col.ndim != 3 or col.shape[:2] != lab.shape):
        raise ValueError(f"expected colors of shape [{h}, {w}, C] (got {list(col.shape)})")
    flat_lab, flat_pts = lab.reshape(-1), pts.reshape(-1, 3)
    flat_col = None if col is None else col.reshape(h * w, -1)
    los, his, ds, cs, ks = [], [], [], [], []
    for d in range(1, int(reach) + 1):
        for a, b, step in ((lab[:, :-d], lab[:, d:], d), (lab[:-d, :], lab[d:, :], d * w)):
            rows, cols = np.nonzero((a >= 0) & (b >= 0) & (a != b))
            if rows.size == 0:
                continue
            p = rows * w + cols  # flat index of the first pixel of each pair; the second is p + step
            q = p + step
            diff = flat_pts[p].astype(np.float64) - flat_pts[q]
            dist = np.linalg.norm(diff, axis=1)
            fin = np.isfinite(dist)
            p, q, diff, dist = p[fin], q[fin], diff[fin], dist[fin]
            x, y = flat_lab[p].astype(np.int64), flat_lab[q].astype(np.int64)
            los.append(np.minimum(x, y))
            his.append(np.maximum(x, y))
            ds.append(dist)
            if nrm is None:
                cs.append(np.full(p.size, np.nan))
            else:
                with np.errstate(invalid="ignore", divide="ignore"):
                    cs.append(np.einsum("ij,ij->i", nrm[p].astype(np.float64) - nrm[q], diff) / dist)
            ks.append(np.full(p.size, np.nan) if flat_col is None else np.linalg.norm(flat_col[p] - flat_col[q], axis=1))
    if not los:
        z = np.zeros(0, np.int64)
        return z, z, np.zeros(0), np.zeros(0), np.zeros(0)
    return np.concatenate(los), np.concatenate(his), np.concatenate(ds), np.concatenate(cs), np.concatenate(ks)


def boundary_separation(
    node_labels: Sequence[np.ndarray],
    points: Sequence[np.ndarray | None],
    num_nodes: int,
    options: Any,
    *,
    rgb: Sequence[np.ndarray] | None = None,
    drop_unknown: bool = False,
    normals: Sequence[np.ndarray | None] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Node pairs that touch in some view, with their boundary length and the share of it that separates them.

    Parameters
    ----------
    node_labels, points : per view ``[H, W]`` (-1 = none) and ``[H, W, 3]`` (NaN = invalid; None: view skipped)
    num_nodes : int
    options : DepthRepulsion.Options, SmoothAdjacency.Options or any object with these attributes
        The boundary tests, read as attributes (a criterion's ``Options``: the
        defaults live there):

    jump : float, optional
        Metres; a boundary pixel pair farther apart is a separation (a depth jump).
    concave : float, optional
        A boundary pixel pair whose convexity (see :func:`boundary_jumps`) is
        below ``-concave`` is a separation: objects that touch (a box on a
        box, a can against a block) meet at a concave crease without a depth
        jump. Normals are those of :func:`graphseg.geometry.point_normals`
        negated, i.e. facing the camera for point maps in the OpenCV camera
        convention (x right, y down).
    reach : int
        See :func:`boundary_jumps`.
    normal_step : int
        Pixel step of the normals' central differences.
    color : float, optional (an absent attribute is None)
        With ``rgb``: a boundary pixel pair whose CIE a*b* chromaticity
        (OpenCV's 8-bit scale, blurred with sigma 1 px) differs by more than
        this is a separation too: the boundary is a colour edge.
    rgb : list of uint8 ``[H, W, 3]``, optional, keyword-only
    drop_unknown : bool, keyword-only
        With ``concave``: leave out boundary pixel pairs whose convexity is
        unknown (normals are NaN within ``normal_step`` px of an invalid point
        and at the image border). Attractive evidence needs this: a crease
        next to a depth hole is no proof of a smooth surface. Cannot-links
        keep them (as not separated).
    normals : list of float ``[H, W, 3]`` (or None per view), optional
        With ``concave``: the views' :func:`graphseg.geometry.point_normals`
        at ``normal_step`` if already computed (e.g.
        :meth:`graphseg.graphs.Evidence.normals`); default: computed here.

    Returns
    -------
    pairs : int64 ``[2, P]``
        Node pairs ``lo < hi`` that touch, pooled over views.
    count : int64 ``[P]``
        Boundary pixel pairs.
    separated : float64 ``[P]``
        The share of them that are separations.

    Notes
    -----
    O(reach x total pixels) plus one sort of the boundary pixel pairs.

    Examples
    --------
    >>> pts = np.zeros((1, 2, 3)); pts[0, 1, 2] = 0.5
    >>> p, c, s = boundary_separation([np.array([[0, 1]])], [pts], 2, DepthRepulsion.Options(jump=0.02, reach=1))
    >>> p.tolist(), c.tolist(), s.tolist()
    ([[0], [1]], [1], [1.0])
    """
    jump, concave, reach, normal_step = options.jump, options.concave, options.reach, options.normal_step
    color = getattr(options, "color", None)
    use_color = color is not None and rgb is not None
    if use_color and len(rgb) != len(node_labels):  # type: ignore[arg-type]
        raise ValueError(f"expected one rgb image per view ({len(node_labels)}) (got {len(rgb)})")  # type: ignore[arg-type]
    if normals is not None and len(normals) != len(node_labels):
        raise ValueError(f"expected one normal map per view ({len(node_labels)}) (got {len(normals)})")
    los, his, seps = [], [], []
    n = max(int(num_nodes), 1)
    for k, (lab, pts) in enumerate(zip(node_labels, points)):
        if pts is None:
            continue
        nrm = None
        if concave is not None:
            given = None if normals is None else normals[k]
            if given is not None and np.shape(given) != np.shape(pts):
                raise ValueError(f"expected normals[{k}] of shape {list(np.shape(pts))} (got {list(np.shape(given))})")
            nrm = -(point_normals(np.asarray(pts, np.float32), normal_step) if given is None else np.asarray(given, np.float32))
        img = None
        if use_color:
            img = np.asarray(rgb[k])  # type: ignore[index]
            if img.shape != (*np.shape(lab), 3) or img.dtype != np.uint8:
                raise ValueError(f"expected rgb[{k}] of shape [{np.shape(lab)[0]}, {np.shape(lab)[1]}, 3] and dtype uint8 (got {list(img.shape)} {img.dtype})")
        lo, hi, d, conv, cdist = boundary_jumps(lab, pts, num_nodes, reach=reach, normals=nrm, colors=None if img is None else _chromaticity(img))
        sep = np.zeros(d.shape, bool)
        if jump is not None:
            sep |= d > jump
        if concave is not None:
            sep |= conv < -concave
        if img is not None:
            sep |= cdist > color
        if drop_unknown and concave is not None:
            known = np.isfinite(conv)
            lo, hi, sep = lo[known], hi[known], sep[known]
        los.append(lo)
        his.append(hi)
        seps.append(sep)
    if not los or not sum(x.size for x in los):
        return np.zeros((2, 0), np.int64), np.zeros(0, np.int64), np.zeros(0)
    ei, attr, _ = coalesce(np.stack([np.concatenate(los), np.concatenate(his)]), {"sep": np.concatenate(seps).astype(np.float64)}, n, reduce={"sep": "mean"})
    return ei, np.asarray(attr["multiplicity"], np.int64), np.asarray(attr["sep"], np.float64)


def _chromaticity(rgb: np.ndarray) -> np.ndarray:
    """CIE a*, b* (OpenCV's 8-bit scale, blurred with sigma 1 px) as a float64 ``[H, W, 2]`` map."""
    import cv2

    lab = cv2.GaussianBlur(cv2.cvtColor(np.ascontiguousarray(rgb, np.uint8), cv2.COLOR_RGB2LAB).astype(np.float32), (0, 0), 1.0)
    return lab[..., 1:].astype(np.float64)


def depth_jump_cannot_links(
    node_labels: Sequence[np.ndarray],
    points: Sequence[np.ndarray],
    num_nodes: int,
    options: DepthRepulsion.Options,
    *,
    normals: Sequence[np.ndarray | None] | None = None,
) -> EdgeSet:
    """Cannot-link edges between nodes whose shared boundary is mostly a depth jump or a concave crease.

    Parameters
    ----------
    node_labels, points : per view ``[H, W]`` and ``[H, W, 3]``
    num_nodes : int
    options : DepthRepulsion.Options
        Required: the defaults live there. Its fields:

    jump, concave : float, optional
        What separates two nodes across a boundary pixel pair: a 3D step over
        ``jump`` metres, a convexity below ``-concave`` (see
        :func:`boundary_separation`); at least one of the two.
    reach, normal_step : int
        Pixel offsets compared across the boundary; step of the normals.
    fraction : float
        A pair is a cannot-link when at least this fraction of its boundary
        pixel pairs (pooled over views) are separations.
    min_pairs : int
        Pairs with fewer boundary pixel pairs are ignored.
    same_view : bool
        Stricter rule: every two nodes seen in one view are a cannot-link
        unless they touch there along a smooth boundary (at least
        ``min_pairs`` boundary pixel pairs, less than ``fraction`` of them
        separations). Parts of one surface touch smoothly; separate objects
        meet at a jump or not at all.
    normals : list of float ``[H, W, 3]``, optional, keyword-only
        Precomputed normals at ``normal_step`` (see :func:`boundary_separation`).

    Returns
    -------
    EdgeSet
        Columns ``criterion`` ("depth_repulsion"), ``sign`` (-1.0), ``weight``
        (the separated fraction) and ``count`` (boundary pixel pairs).

    Notes
    -----
    O(reach x total pixels) plus one sort of the boundary pairs.
    """
    fraction, min_pairs, same_view = options.fraction, options.min_pairs, options.same_view
    if options.jump is None and options.concave is None:
        raise ValueError("depth_repulsion: jump and concave are both None; give at least one")
    pairs, count, frac = boundary_separation(node_labels, points, num_nodes, options, normals=normals)
    seen = count >= min_pairs
    keep = seen & (frac >= fraction)
    ei, w, c = pairs[:, keep], frac[keep], count[keep]
    if same_view:
        n = max(num_nodes, 1)
        touching = pairs[0, seen] * n + pairs[1, seen]  # smooth contacts and cannot-links already found
        keys = [_pairs_of(np.unique(lab[lab >= 0]).astype(np.int64), num_nodes) for lab in node_labels]
        extra = np.setdiff1d(np.unique(np.concatenate([*keys, np.zeros(0, np.int64)])), touching)
        u, v = np.divmod(extra, n)
        ei = np.concatenate([ei, np.stack([u, v]).astype(np.int64)], axis=1)
        w = np.concatenate([w, np.ones(extra.size)])
        c = np.concatenate([c, np.zeros(extra.size, np.int64)])
    n_edges = ei.shape[1]
    return EdgeSet(ei, {"criterion": np.full(n_edges, "depth_repulsion"), "sign": -np.ones(n_edges), "weight": w, "count": c}, info={"cannot_links": n_edges})


def _pairs_of(nodes: np.ndarray, num_nodes: int) -> np.ndarray:
    """Keys ``lo * N + hi`` of all pairs of the given (sorted, distinct) nodes."""
    a, b = np.triu_indices(nodes.size, 1)
    return nodes[a] * max(num_nodes, 1) + nodes[b]


class DepthRepulsion(Criterion):
    """The ``depth_repulsion`` criterion: :func:`depth_jump_cannot_links` as an edge adder.

    Examples
    --------
    >>> g = CorrespondenceGraph.from_masks([np.array([[1, 1, 2, 2]])])
    >>> pts = np.zeros((1, 4, 3), np.float32); pts[0, 2:, 2] = 0.5
    >>> DepthRepulsion(min_pairs=1)(g, Evidence.for_graph(g, points=[pts])).edge_attr["sign"].tolist()
    [-1.0]
    """

    name = "depth_repulsion"
    requires = frozenset({"node_labels", "points"})
    reduce = {"weight": "max", "count": "sum", "sign": "min"}
    tags = {"dimension": "3d"}

    class Options(BaseModel):
        model_config = ConfigDict(extra="forbid")
        jump: float | None = Field(0.02, gt=0)
        fraction: float = Field(0.5, gt=0, le=1)
        reach: int = Field(3, ge=1)
        min_pairs: int = Field(10, ge=1)
        same_view: bool = False
        concave: float | None = Field(None, gt=0)
        normal_step: int = Field(3, ge=1)

        @model_validator(mode="after")
        def _some_separation(self) -> DepthRepulsion.Options:
            if self.jump is None and self.concave is None:
                raise ValueError("jump and concave are both None; give at least one")
            return self


    def __call__(self, graph: CorrespondenceGraph, evidence: Evidence) -> EdgeSet:
        if evidence.points is None:
            raise ValueError("depth_repulsion needs world points")
        opts = self.options
        normals = evidence.normals(opts.normal_step) if opts.concave is not None else None
        return depth_jump_cannot_links(evidence.node_labels, evidence.points, graph.num_nodes, opts, normals=normals)  # type: ignore[arg-type]
