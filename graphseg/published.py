"""Numbers published with GraphSeg (Tang et al., 2025): one home for each.

The paper and its official code disagree on the 3D threshold ``tau_3D`` of
the ``chamfer_3d`` criterion (a directed Chamfer distance, mean squared
nearest-neighbour distance in m^2). Both are facts worth keeping, so both are
named here, once:

* :data:`TAU_3D_PAPER` (5e-4 m^2): the value the paper states, the default of
  ``Chamfer3D.Options.tau`` and so of the ``paper`` preset;
* :data:`TAU_3D_OFFICIAL` (5e-5 m^2): the value the official code used, which
  the measured methods (``Config()`` = ``rgbd``, ``robust``, ``multicut``) adopt.

This module imports nothing, so the configuration and the graph package can
both read it without loading each other.

Examples
--------
>>> TAU_3D_PAPER / TAU_3D_OFFICIAL
10.0
>>> from graphseg.graphs.chamfer import Chamfer3D
>>> Chamfer3D.Options().tau == TAU_3D_PAPER
True
"""

from __future__ import annotations

__all__ = ["TAU_3D_PAPER", "TAU_3D_OFFICIAL"]

#: ``tau_3D`` as the paper states it (m^2).
TAU_3D_PAPER: float = 5e-4

#: ``tau_3D`` as the official code used it (m^2).
TAU_3D_OFFICIAL: float = 5e-5
