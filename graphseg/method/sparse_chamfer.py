"""The Chamfer test on sparse point sets: a threshold that grows with the point spacing.

Two independent samplings of one surface are not point-to-point aligned: for
uniformly random samples with median nearest-neighbour spacing ``s`` the
directed Chamfer distance (mean squared nearest-neighbour distance) is about
``s^2 / ln 2 ~= 1.44 s^2`` even when the surfaces coincide. With dense
RGB-D points (``s`` ~ 1-3 mm at 0.6 m after 5 mm voxels) this is far below
``tau_3D = 5e-5`` m^2; with the sparse points of structure from motion
(``s`` of centimetres) every pair fails. :func:`spacing_aware_chamfer_edges`
therefore tests each pair against

    ``tau_ij = max(tau, (factor * max(s_i, s_j))^2)``,  ``factor = 1.5`` (2.25 s^2)

where ``s_k`` is the median nearest-neighbour distance within node ``k``'s set
(:func:`point_spacing`). For dense sets it is exactly ``chamfer_edges``.

This module is separate from :mod:`graphseg.graphs.chamfer` on purpose (that
module is being reworked); ``benchmarks/bench_sparse_points.py`` measures both
tests on dense, stereo and sparse point maps (``docs/results.md``).

Examples
--------
>>> import numpy as np
>>> from graphseg.graphs.chamfer import PointSets
>>> a = np.c_[np.arange(0, 1, 0.1), np.zeros(10), np.zeros(10)]      # spacing 0.1
>>> b = a + [0.05, 0, 0]                                             # the same line, shifted by half
>>> sets = PointSets(np.r_[a, b], np.array([0, 10, 20]))
>>> chamfer_edges(sets, 1e-4).num_edges, spacing_aware_chamfer_edges(sets, 1e-4).num_edges
(0, 1)
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..graphs.chamfer import PointSets, chamfer_edges
from ..graphs.evidence import EdgeSet

__all__ = ["point_spacing", "spacing_aware_chamfer_edges", "chamfer_edges"]


def point_spacing(sets: PointSets) -> np.ndarray:
    """Median nearest-neighbour distance within each node's point set ``[N]`` (NaN with < 2 points).

    Examples
    --------
    >>> s = point_spacing(PointSets(np.array([[0.0, 0, 0], [0.1, 0, 0], [0.3, 0, 0]]), np.array([0, 3, 3])))
    >>> np.round(s, 3).tolist()[0], bool(np.isnan(s[1]))
    (0.1, True)

    Notes
    -----
    One k-d tree per node: O(P log P) in total.
    """
    out = np.full(sets.num_nodes, np.nan)
    for k in range(sets.num_nodes):
        x = sets[k]
        if len(x) >= 2:
            d, _ = cKDTree(x).query(x, k=2)
            out[k] = float(np.median(d[:, 1]))
    return out


def spacing_aware_chamfer_edges(sets: PointSets, tau: float = 5e-5, *, factor: float = 1.5, prune: bool = True) -> EdgeSet:
    """``chamfer_edges`` with the per-pair threshold ``max(tau, (factor * max(s_i, s_j))^2)``.

    Parameters
    ----------
    sets : PointSets
    tau : float
        m^2, the floor (the dense-point threshold).
    factor : float
        Multiple of the spacing allowed as RMS nearest-neighbour distance
        (1.5: random samplings of one surface give about 1.2 s).
    prune : bool
        As in :func:`graphseg.graphs.chamfer.chamfer_edges`.

    Returns
    -------
    EdgeSet
        As ``chamfer_edges``, plus the column ``tau`` (the threshold each edge met).
    """
    if not tau > 0 or not factor >= 0:
        raise ValueError(f"expected tau > 0 and factor >= 0 (got {tau}, {factor})")
    s = np.nan_to_num(point_spacing(sets), nan=0.0)
    node_tau = np.maximum(tau, (factor * s) ** 2)
    es = chamfer_edges(sets, float(node_tau.max()) if node_tau.size else tau, prune=prune)
    i, j = es.edge_index
    pair_tau = np.maximum(node_tau[i], node_tau[j]) if i.size else np.zeros(0)
    keep = es.edge_attr["distance"] <= pair_tau
    attr = {k: v[keep] for k, v in es.edge_attr.items()}
    attr["weight"] = 1.0 / (1.0 + attr["distance"] / pair_tau[keep]) if keep.any() else np.zeros(0)
    attr["tau"] = pair_tau[keep]
    return EdgeSet(es.edge_index[:, keep], attr, {**es.info, "tau": tau, "factor": factor})
