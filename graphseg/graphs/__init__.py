"""graphseg.graphs: the correspondence graph, edge criteria, contractors, coarsen and interop.

Examples
--------
>>> import numpy as np
>>> from graphseg.graphs import CorrespondenceGraph, randomized_star_contraction, coarsen
>>> g = CorrespondenceGraph(3, edge_index=[[0], [1]], node_attr={"area": [5, 6, 7]})
>>> cluster = randomized_star_contraction(g.edge_index, g.num_nodes, rng=0)
>>> coarsen(g, cluster).node_attr["area"].tolist()
[11, 7]
"""

from .chamfer import (
    Chamfer3D,
    PointSets,
    chamfer_edges,
    directed_chamfer,
    node_point_sets,
    remove_outliers,
)
from .coalesce import Groups, coalesce, combine_keys, group_by_key
from .coarsen import coarsen, group_reduce
from .contract import (
    ScipyContraction,
    StarContraction,
    UnionFindContraction,
    canonical_cluster,
    randomized_star_contraction,
    scipy_contraction,
    union_find_contraction,
)
from .contractor import BaseContractor, run_contractor
from .criterion import (
    REDUCTIONS,
    REQUIRES,
    Criterion,
    CriterionOptionsError,
    build_criterion,
    criterion_info,
)
from .evidence import Contractor, EdgeSet, Evidence
from .features import FeatureSimilarity, feature_similarity_edges, node_mean_features
from .graph import (
    CorrespondenceGraph,
    GraphValidationError,
    MaskNode,
    SuperNode,
    as_edge_index,
    mask_node_table,
)
from .interop import from_networkx, from_pyg, read_graphml, to_networkx, to_pyg, write_graphml
from .native import NativeFile, load_graph, load_native, save_graph, save_native
from .pixel_match import PixelMatch, pair_counts, pixel_match_edges, pixel_match_ratios
from .registry import contractors, criteria, edge_adders

__all__ = [
    "CorrespondenceGraph",
    "MaskNode",
    "SuperNode",
    "GraphValidationError",
    "as_edge_index",
    "mask_node_table",
    "Evidence",
    "EdgeSet",
    "Criterion",
    "CriterionOptionsError",
    "REQUIRES",
    "REDUCTIONS",
    "criterion_info",
    "build_criterion",
    "Contractor",
    "randomized_star_contraction",
    "union_find_contraction",
    "scipy_contraction",
    "canonical_cluster",
    "StarContraction",
    "UnionFindContraction",
    "ScipyContraction",
    "BaseContractor",
    "run_contractor",
    "coarsen",
    "group_reduce",
    "coalesce",
    "combine_keys",
    "group_by_key",
    "Groups",
    "pixel_match_ratios",
    "pixel_match_edges",
    "pair_counts",
    "PixelMatch",
    "PointSets",
    "node_point_sets",
    "directed_chamfer",
    "remove_outliers",
    "chamfer_edges",
    "Chamfer3D",
    "node_mean_features",
    "feature_similarity_edges",
    "FeatureSimilarity",
    "to_networkx",
    "from_networkx",
    "write_graphml",
    "read_graphml",
    "to_pyg",
    "from_pyg",
    "save_graph",
    "load_graph",
    "save_native",
    "load_native",
    "NativeFile",
    "edge_adders",
    "criteria",
    "contractors",
]
