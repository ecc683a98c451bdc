"""Registries of edge criteria, graph operations and contractors (entry-point groups
``graphseg.edge_adders``, ``graphseg.operations`` and ``graphseg.contractors``).

``criteria`` is the same registry as ``edge_adders`` (its historical name).

Examples
--------
>>> "pixel_match" in edge_adders.names() and "star" in contractors.names()
True
>>> type(contractors.resolve("union_find")).__name__
'UnionFindContraction'
"""

from __future__ import annotations

from ..registry import Registry

__all__ = ["edge_adders", "criteria", "operations", "contractors"]

edge_adders = Registry("edge criterion", group="graphseg.edge_adders")
edge_adders.register("pixel_match", "graphseg.graphs.pixel_match:PixelMatch")
edge_adders.register("chamfer_3d", "graphseg.graphs.chamfer:Chamfer3D")
edge_adders.register("dino", "graphseg.graphs.features:FeatureSimilarity")
edge_adders.register("depth_repulsion", "graphseg.graphs.repulsion:DepthRepulsion")
edge_adders.register("view_consensus", "graphseg.graphs.consensus:ViewConsensus")
edge_adders.register("smooth_adjacency", "graphseg.graphs.adjacency:SmoothAdjacency")
edge_adders.register("bidirectional_overlap", "graphseg.graphs.overlap:BidirectionalOverlap")

criteria = edge_adders

#: Graph operations, the steps of a method after its edge stages (:mod:`graphseg.method.operations`).
operations = Registry("graph operation", group="graphseg.operations")
for _name, _cls in (
    ("support", "Support"),
    ("split", "Split"),
    ("merge", "Merge"),
    ("join_shared", "JoinShared"),
    ("mask_join", "MaskJoin"),
    ("snap", "Snap"),
    ("support_final", "SupportFinal"),
    ("refine", "Refine"),
    ("grow", "Grow"),
    ("trim", "Trim"),
):
    operations.register(_name, f"graphseg.method.operations:{_cls}")

contractors = Registry("contractor", group="graphseg.contractors")
contractors.register("star", "graphseg.graphs.contract:StarContraction")
contractors.register("union_find", "graphseg.graphs.contract:UnionFindContraction")
contractors.register("scipy", "graphseg.graphs.contract:ScipyContraction")
contractors.register("constrained", "graphseg.graphs.signed:ConstrainedUnionFindContraction")
contractors.register("core_attach", "graphseg.graphs.signed:CoreAttachContraction")
contractors.register("gaec", "graphseg.graphs.signed:GreedyAdditiveContraction")
