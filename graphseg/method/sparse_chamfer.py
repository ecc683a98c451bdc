"""The Chamfer test on sparse point sets: a threshold that grows with the point spacing.

Two independent samplings of one surface are not point-to-point aligned: for
uniformly random samples with median nearest-neighbour spacing ``s`` the
directed Chamfer distance (mean squared nearest-neighbour distance) is about
``s^2 / ln 2 ~= 1.44 s^2`` even when the surfaces coincide. With dense
RGB-D points (``s`` ~ 1-3 mm at 0.6 m after 5 mm voxels) this is far below
``tau_3D = 5e-5`` m^2 (:data:`graphseg.published.TAU_3D_OFFICIAL`); with the sparse points of structure from motion
(``s`` of centimetres) every pair fails. :func:`spacing_aware_chamfer_edges`
therefore tests each pair against

    ``tau_ij = max(tau, (factor * max(s_i, s_j))^2)``,  ``factor = 1.5`` (2.25 s^2, :data:`SPACING_FACTOR`)

where ``s_k`` is the median nearest-neighbour distance within node ``k``'s set
(:func:`point_spacing`). For dense sets it is exactly ``chamfer_edges``. Both
functions take their options as required keywords (the defaults live in
``Chamfer3D.Options``: ``tau``, ``spacing_factor``, ``prune``).

The functions live in :mod:`graphseg.graphs.chamfer` (the ``chamfer_3d``
option ``spacing_factor`` uses them); this module keeps their older import
path. ``benchmarks/bench_sparse_points.py`` measures both tests on dense,
stereo and sparse point maps (``docs/results.md``).

Examples
--------
>>> import numpy as np
>>> from graphseg.graphs.chamfer import PointSets
>>> a = np.c_[np.arange(0, 1, 0.1), np.zeros(10), np.zeros(10)]      # spacing 0.1
>>> b = a + [0.05, 0, 0]                                             # the same line, shifted by half
>>> sets = PointSets(np.r_[a, b], np.array([0, 10, 20]))
>>> chamfer_edges(sets, 1e-4, prune=True).num_edges, spacing_aware_chamfer_edges(sets, 1e-4, factor=SPACING_FACTOR, prune=True).num_edges
(0, 1)
"""

from __future__ import annotations

from ..graphs.chamfer import (
    SPACING_FACTOR,
    chamfer_edges,
    point_spacing,
    spacing_aware_chamfer_edges,
)

__all__ = ["point_spacing", "spacing_aware_chamfer_edges", "chamfer_edges", "SPACING_FACTOR"]
