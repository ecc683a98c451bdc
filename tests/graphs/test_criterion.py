import numpy as np
import pytest
from pydantic import BaseModel, ConfigDict, Field

from graphseg.graphs import (
    Chamfer3D,
    CorrespondenceGraph,
    Criterion,
    CriterionOptionsError,
    EdgeSet,
    Evidence,
    FeatureSimilarity,
    PixelMatch,
    build_criterion,
    criterion_info,
)


class Ring(Criterion):
    name = "ring"

    class Options(BaseModel):
        model_config = ConfigDict(extra="forbid")
        step: int = Field(1, ge=1)

    reduce = {"hop": "min"}

    def __call__(self, graph, evidence):
        u = np.arange(graph.num_nodes)
        v = (u + self.options.step) % graph.num_nodes
        return EdgeSet(np.stack([u, v]), {"hop": np.full(u.size, self.options.step)})


def test_builtins_declare_the_contract():
    for cls, dim, req in ((PixelMatch, "2d", {"matches", "points"}), (Chamfer3D, "3d", {"points", "confidence"}), (FeatureSimilarity, "2d", {"features"})):
        info = criterion_info(cls)
        assert info.dimension == dim and info.requires == req and info.Options is cls.Options
        assert info.Options.model_config.get("extra") == "forbid"
        inst = cls(cls.Options())
        assert inst.options == cls.Options()


def test_construction_from_options_or_keywords():
    assert Ring(Ring.Options(step=2)).options.step == 2
    assert Ring(step=3).options.step == 3
    with pytest.raises(TypeError, match="either"):
        Ring(Ring.Options(), step=2)
    with pytest.raises(TypeError, match="expected Options"):
        Ring(PixelMatch.Options())
    with pytest.raises(CriterionOptionsError, match="ring: unknown option 'stpe'; valid options: step; did you mean 'step'\\?$"):
        Ring(stpe=2)
    with pytest.raises(CriterionOptionsError, match="option 'step'"):
        build_criterion(Ring, {"step": 0})


def test_call_does_not_mutate_inputs():
    g = CorrespondenceGraph(4, node_attr={"area": [1, 2, 3, 4]})
    ev = Evidence([np.array([[0, 1, 2, 3]])])
    before = (g.edge_index.copy(), {k: v.copy() for k, v in g.node_attr.items()}, ev.node_labels[0].copy())
    es = Ring(step=1)(g, ev)
    assert es.edge_index.shape == (2, 4)
    assert np.array_equal(g.edge_index, before[0]) and np.array_equal(ev.node_labels[0], before[2])
    assert all(np.array_equal(g.node_attr[k], v) for k, v in before[1].items())


def test_bad_declarations_are_reported():
    class BadReq(Ring):
        requires = frozenset({"depth_maps"})

    class BadReduce(Ring):
        reduce = {"hop": "median"}

    class BadTag(Ring):
        tags = {"dimension": "4d"}

    with pytest.raises(ValueError, match="unknown requires \\['depth_maps'\\]; vocabulary: node_labels"):
        criterion_info(BadReq)
    with pytest.raises(ValueError, match="unknown reduce"):
        criterion_info(BadReduce)
    with pytest.raises(ValueError, match="dimension"):
        criterion_info(BadTag)


def test_legacy_callable_without_options_takes_keywords():
    class Legacy:
        name = "legacy"

        def __init__(self, k=1):
            self.k = k

        def __call__(self, graph, evidence):  # pragma: no cover - not called
            raise AssertionError

    assert build_criterion(Legacy, {"k": 4}).k == 4
    assert criterion_info(Legacy).dimension == "any"


def test_misspelt_options_name_the_closest():
    from graphseg.graphs.criterion import validate_options

    with pytest.raises(CriterionOptionsError) as err:
        validate_options(PixelMatch.Options, {"percentil": 70}, label="pixel_match")
    assert str(err.value).startswith("pixel_match: unknown option 'percentil'; valid options: ") and str(err.value).endswith("; did you mean 'percentile'?")
    with pytest.raises(CriterionOptionsError) as err:
        validate_options(Ring.Options, {"zzz": 1}, label="ring")
    assert str(err.value) == "ring: unknown option 'zzz'; valid options: step"  # no close key, no hint


class Loose(Criterion):
    """A plugin whose own model allows infinities."""

    name = "loose"

    class Options(BaseModel):
        model_config = ConfigDict(extra="forbid", allow_inf_nan=True)
        limit: float = 1.0
        scales: list[float] = [1.0]

    def __call__(self, graph, evidence):  # pragma: no cover - never called
        raise AssertionError


@pytest.mark.parametrize(
    "options,message",
    [
        ({"limit": float("inf")}, "loose: option 'limit': expected a finite number (got inf)"),
        ({"limit": float("-inf")}, "loose: option 'limit': expected a finite number (got -inf)"),
        ({"scales": [1.0, float("nan")]}, "loose: option 'scales.1': expected a finite number (got nan)"),
    ],
)
def test_non_finite_options_are_refused_even_if_the_plugin_allows_them(options, message):
    with pytest.raises(CriterionOptionsError) as err:
        build_criterion(Loose, options)
    assert str(err.value) == message
    assert build_criterion(Loose, {"limit": 1e30}).options.limit == 1e30


def test_builtin_defaults_are_finite():
    from graphseg.graphs.criterion import non_finite
    from graphseg.graphs.registry import contractors, edge_adders

    for registry in (edge_adders, contractors):
        for name in registry.names():
            info = criterion_info(registry.get(name), name)
            if info.Options is not None:
                assert non_finite(info.Options()) is None, name

