"""One home per default: a criterion's option defaults live in its ``Options``, nowhere else.

The pure functions take every option as a required keyword, or the ``Options``
object itself as a required ``options`` parameter (the functions with many
options), so a default cannot drift between the function's signature and the
pydantic model.
"""

import inspect

import numpy as np
import pytest

from graphseg.graphs import adjacency, chamfer, consensus, features, overlap, pixel_match, repulsion
from graphseg.graphs.registry import edge_adders

#: (criterion class, pure function, function parameter -> Options field; None: the same names)
CASES = [
    (pixel_match.PixelMatch, pixel_match.pixel_match_edges, None),
    (pixel_match.PixelMatch, pixel_match.pixel_match_ratios, None),
    (features.FeatureSimilarity, features.feature_similarity_edges, None),
    (repulsion.DepthRepulsion, repulsion.depth_jump_cannot_links, None),
    (repulsion.DepthRepulsion, repulsion.boundary_separation, None),
    (repulsion.DepthRepulsion, repulsion.boundary_jumps, None),
    (adjacency.SmoothAdjacency, adjacency.smooth_adjacency_links, None),
    (consensus.ViewConsensus, consensus.view_consensus_edges, None),
    (consensus.ViewConsensus, consensus.containers, None),
    (consensus.ViewConsensus, consensus.consensus_pairs, None),
    (overlap.BidirectionalOverlap, overlap.bidirectional_overlap_edges, None),
    (chamfer.Chamfer3D, chamfer.chamfer_edges, {"tau": "tau", "prune": "prune"}),
    (chamfer.Chamfer3D, chamfer.spacing_aware_chamfer_edges, {"tau": "tau", "factor": "spacing_factor", "prune": "prune"}),
    (
        chamfer.Chamfer3D,
        chamfer.remove_outliers,
        {"k": "outlier_k", "std_ratio": "outlier_std_ratio", "eps": "dbscan_eps", "min_samples": "dbscan_min_samples"},
    ),
]


@pytest.mark.parametrize("owner, fn, names", CASES, ids=lambda x: getattr(x, "__name__", None))
def test_pure_functions_take_options_as_required_keywords(owner, fn, names):
    params = inspect.signature(fn).parameters
    if "options" in params:  # the Options object itself, required
        assert params["options"].default is inspect.Parameter.empty and not set(params) & set(owner.Options.model_fields)
        return
    fields = owner.Options.model_fields
    shared = names or {p: p for p in params if p in fields}
    assert shared and set(shared.values()) <= set(fields)
    written_twice = [f"{p}={params[p].default!r}" for p in shared if params[p].default is not inspect.Parameter.empty]
    assert not written_twice, f"{fn.__name__}: defaults also in {owner.__name__}.Options: {written_twice}"


def test_every_builtin_criterion_is_covered():
    covered = {(c.values[0] if hasattr(c, "values") else c[0]).name for c in CASES}
    builtin = {n for n, target in edge_adders._targets.items() if isinstance(target, str) and target.startswith("graphseg.graphs.")}
    assert builtin == covered == {"pixel_match", "chamfer_3d", "dino", "depth_repulsion", "view_consensus", "smooth_adjacency", "bidirectional_overlap"}


def test_the_defaults_are_the_former_signature_defaults():
    # the values the pure functions' signatures carried before they moved into Options alone
    assert pixel_match.PixelMatch.Options().model_dump() == {"tau": None, "percentile": 78.0, "normalization": "area", "min_matches": 3, "consistency_percentile": None}
    assert features.FeatureSimilarity.Options().model_dump() == {"threshold": 0.8, "cross_view_only": False}
    assert repulsion.DepthRepulsion.Options().model_dump() == {"jump": 0.02, "fraction": 0.5, "reach": 3, "min_pairs": 10, "same_view": False, "concave": None, "normal_step": 3}
    assert adjacency.SmoothAdjacency.Options().model_dump() == {
        "jump": 0.02, "concave": 0.2, "max_separated": 0.1, "min_pairs": 30, "reach": 3, "normal_step": 3, "color": 20.0,
    }  # fmt: skip
    assert consensus.ViewConsensus.Options().model_dump() == {"threshold": 0.9, "min_views": 2, "min_matches": 5, "min_share": 0.5, "attract": True, "repel_below": None}
    assert overlap.BidirectionalOverlap.Options().model_dump() == {"threshold": 0.5, "min_matches": 5}
    o = chamfer.Chamfer3D.Options()  # chamfer_edges' tau and prune, remove_outliers' k, std_ratio, eps, min_samples
    assert (o.tau, o.prune, o.outlier_k, o.outlier_std_ratio, o.dbscan_eps, o.dbscan_min_samples) == (5e-4, True, 8, 2.0, 0.02, 5)
    assert chamfer.SPACING_FACTOR == 1.5  # spacing_aware_chamfer_edges' former factor (spacing_factor itself is off by default)


def test_a_missing_option_is_a_type_error_naming_it():
    lab = np.array([[0, 0, 1, 1]])
    with pytest.raises(TypeError, match="options"):  # the criterion's Options: required, no second home of its defaults
        repulsion.depth_jump_cannot_links([lab], [np.zeros((1, 4, 3), np.float32)], 2)
    with pytest.raises(TypeError, match="cross_view_only"):
        features.feature_similarity_edges(np.eye(2), 0.5)
    sets = chamfer.PointSets(np.zeros((2, 3)), np.array([0, 1, 2]))
    with pytest.raises(TypeError, match="prune"):
        chamfer.chamfer_edges(sets, 5e-4)
    with pytest.raises(TypeError, match="min_samples"):
        chamfer.remove_outliers(sets, "dbscan", k=8, std_ratio=2.0, eps=0.02)
