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
    for cls, dim, req in ((PixelMatch, "2d", {"matches", "points"}), (Chamfer3D, "3d", {"points"}), (FeatureSimilarity, "2d", {"features"})):
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
    with pytest.raises(CriterionOptionsError, match="ring: unknown option 'stpe'; valid options: step"):
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
