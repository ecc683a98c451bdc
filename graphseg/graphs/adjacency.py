"""Attractive evidence: masks of one view that meet along a smooth, convex boundary are parts of one surface.

The ``smooth_adjacency`` criterion is the counterpart of ``depth_repulsion``
(:mod:`graphseg.graphs.repulsion`). It measures the same boundary pixel pairs
(:func:`graphseg.graphs.repulsion.boundary_separation`), and joins two nodes when
their shared boundary is long and almost nowhere a separation: no depth jump,
no concave crease and, with ``color`` (the default), no colour edge. A cut
through one surface where nothing changes (a random part split, a depth
threshold on a steep face) leaves such a boundary. Two objects that touch
meet at a jump, a concave crease or a colour edge instead; where they meet
without any of the three (two flat faces of one colour side by side), this
criterion joins them, so pair it with a contractor that honours cannot-links
(``constrained``).

This evidence joins parts that no other view overlaps, such as the parts of an
object seen in one view only.

Examples
--------
>>> import numpy as np
>>> lab = np.array([[0, 0, 1, 1]])
>>> pts = np.zeros((1, 4, 3), np.float32); pts[0, :, 0] = [0.0, 0.001, 0.002, 0.003]  # one flat surface
>>> opts = SmoothAdjacency.Options(min_pairs=1, concave=None)  # the defaults live in Options
>>> smooth_adjacency_links([lab], [pts], 2, opts).edge_index.tolist()  # one row: no normals
[[0], [1]]
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from .criterion import Criterion
from .evidence import EdgeSet, Evidence
from .graph import CorrespondenceGraph
from .repulsion import boundary_separation

__all__ = ["smooth_adjacency_links", "SmoothAdjacency"]


def smooth_adjacency_links(
    node_labels: Sequence[np.ndarray],
    points: Sequence[np.ndarray | None],
    num_nodes: int,
    options: SmoothAdjacency.Options,
    *,
    rgb: Sequence[np.ndarray] | None = None,
    normals: Sequence[np.ndarray | None] | None = None,
) -> EdgeSet:
    """Attractive edges between nodes that touch along a long, smooth, convex boundary.

    Parameters
    ----------
    node_labels : list of int ``[H, W]``
        Pixel -> node per view (-1 = none).
    points : list of float ``[H, W, 3]`` (or None per view)
        World points, NaN = invalid.
    num_nodes : int
    options : SmoothAdjacency.Options
        Required: the defaults live there. Its fields:

    jump : float, optional
        Metres; a larger 3D step across the boundary is a separation.
    concave : float, optional
        Convexity below ``-concave`` is a separation; boundary pixel pairs
        whose convexity is unknown (next to invalid depth) are left out.
    reach, normal_step : int
        Pixel offsets compared across the boundary; step of the normals.
    color : float, optional
        With ``rgb``: a colour edge (CIE a*b* difference) is a separation. The
        default (:class:`SmoothAdjacency.Options`) was measured: without it, objects that touch along a flat
        contact (a can against a block on YCB-Video 0002) join; 20 is the middle
        of the range (15-25) that leaves YCB unchanged, and above 15 the
        shading of one synthetic object no longer splits it
        (``docs/results.md``). See
        :func:`graphseg.graphs.repulsion.boundary_separation` for all three tests.
    max_separated : float
        A pair is joined when at most this share of its boundary pixel pairs
        are separations.
    min_pairs : int
        ... and it has at least this many boundary pixel pairs (pooled over
        views): a short contact is no evidence.
    rgb : list of uint8 ``[H, W, 3]``, optional, keyword-only
        The views' colours, for ``color``.
    normals : list of float ``[H, W, 3]``, optional, keyword-only
        Precomputed normals at ``normal_step`` (see :func:`graphseg.graphs.repulsion.boundary_separation`).

    Returns
    -------
    EdgeSet
        Columns ``criterion`` ("smooth_adjacency"), ``weight`` (1 - the
        separated share) and ``count`` (boundary pixel pairs).

    Notes
    -----
    O(reach x total pixels) plus one sort of the boundary pixel pairs.
    """
    if options.jump is None and options.concave is None and (options.color is None or rgb is None):
        raise ValueError("smooth_adjacency: no separation test (jump, concave and color are all off); every touching pair would join")
    pairs, count, sep = boundary_separation(node_labels, points, num_nodes, options, rgb=rgb, drop_unknown=True, normals=normals)
    keep = (count >= options.min_pairs) & (sep <= options.max_separated)
    n = int(keep.sum())
    return EdgeSet(pairs[:, keep], {"criterion": np.full(n, "smooth_adjacency"), "weight": 1.0 - sep[keep], "count": count[keep]}, info={"links": n})


class SmoothAdjacency(Criterion):
    """The ``smooth_adjacency`` criterion: :func:`smooth_adjacency_links` as an edge adder.

    Examples
    --------
    >>> g = CorrespondenceGraph.from_masks([np.array([[1, 1, 2, 2]])])
    >>> pts = np.zeros((1, 4, 3), np.float32); pts[0, :, 0] = np.arange(4) * 0.001
    >>> rgb = [np.full((1, 4, 3), 128, np.uint8)]
    >>> SmoothAdjacency(min_pairs=1, concave=None)(g, Evidence.for_graph(g, points=[pts], rgb=rgb)).edge_index.tolist()
    [[0], [1]]
    """

    name = "smooth_adjacency"
    requires = frozenset({"node_labels", "points", "rgb"})
    reduce = {"weight": "max", "count": "sum"}
    tags = {"dimension": "3d"}

    class Options(BaseModel):
        model_config = ConfigDict(extra="forbid")
        jump: float | None = Field(0.02, gt=0)
        concave: float | None = Field(0.2, gt=0)
        max_separated: float = Field(0.1, ge=0, lt=1)
        min_pairs: int = Field(30, ge=1)
        reach: int = Field(3, ge=1)
        normal_step: int = Field(3, ge=1)
        color: float | None = Field(20.0, gt=0)

        @model_validator(mode="after")
        def _some_separation(self) -> SmoothAdjacency.Options:
            if self.jump is None and self.concave is None and self.color is None:
                raise ValueError("jump, concave and color are all None; every touching pair would join")
            return self

    def __call__(self, graph: CorrespondenceGraph, evidence: Evidence) -> EdgeSet:
        if evidence.points is None:
            raise ValueError("smooth_adjacency needs world points")
        opts = self.options
        rgb = evidence.rgb if opts.color is not None else None
        if opts.color is not None and rgb is None:
            raise ValueError("smooth_adjacency with color needs rgb images")
        normals = evidence.normals(opts.normal_step) if opts.concave is not None else None
        return smooth_adjacency_links(evidence.node_labels, evidence.points, graph.num_nodes, opts, rgb=rgb, normals=normals)
