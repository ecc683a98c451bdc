"""The contractor contract: one base class with pydantic Options, validated when a Config is built."""

import numpy as np
import pytest
from pydantic import BaseModel, ValidationError

from graphseg.config import Config
from graphseg.graphs import BaseContractor, CorrespondenceGraph, contractors, run_contractor
from graphseg.graphs.signed import CoreAttachContraction, core_attach_contraction
from graphseg.validation import CriterionOptionsError, NoOptions


@pytest.mark.parametrize("name", ["star", "union_find", "scipy", "constrained", "core_attach", "gaec"])
def test_every_builtin_contractor_shares_the_base_and_forbids_unknown_options(name):
    cls = contractors.get(name)
    assert issubclass(cls, BaseContractor) and cls.name == name
    assert issubclass(cls.Options, BaseModel) and cls.Options.model_config.get("extra") == "forbid"
    c = cls()
    assert isinstance(c.options, cls.Options)
    with pytest.raises(CriterionOptionsError, match=f"^{name}: unknown option 'no_such_option'"):
        cls(no_such_option=1)


def test_misspelt_core_attach_option_fails_when_the_config_is_built():
    # before the shared base, core_attach had no Options: this validated and failed at the first run
    with pytest.raises(ValidationError, match="core_attach: unknown option 'min_aera'; valid options: min_area; did you mean 'min_area'"):
        Config(contractor={"core_attach": {"min_aera": 5}})
    with pytest.raises(ValidationError, match="core_attach: option 'min_area'"):
        Config(contractor={"core_attach": {"min_area": "big"}})
    with pytest.raises(ValidationError, match="star: unknown option 'seed'; valid options: \\(none\\)"):
        Config(contractor={"star": {"seed": 1}})


def test_config_builds_core_attach_with_its_option_and_default():
    cfg = Config(contractor={"core_attach": {"min_area": 10}})
    assert cfg.contractor.options == {"min_area": 10.0}
    c = cfg.contractor.build()
    assert isinstance(c, CoreAttachContraction) and c.min_area == 10.0
    assert Config(contractor="core_attach").contractor.build().min_area == 1000.0  # the one default, in Options
    assert Config(contractor="core_attach").model_dump()["contractor"] == {"core_attach": {"min_area": 1000.0}}


def test_core_attach_from_config_hand_computed():
    # core 0 - fragment 1 - core 2; the fragment's strongest edge (0.9) leads to 2
    ei = np.array([[0, 1], [1, 2]])
    attrs = {"weight": np.array([0.4, 0.9])}
    area = {"area": np.array([50, 3, 50])}
    c = Config(contractor={"core_attach": {"min_area": 10}}).contractor.build()
    got = run_contractor(c, ei, 3, edge_attr=attrs, node_attr=area)
    assert got.tolist() == [0, 1, 1]
    assert got.tolist() == core_attach_contraction(ei, 3, core=[True, False, True], weight=[0.5, 1.0]).tolist()
    # min_area above every area: no core, every node keeps its strongest edge (0: 0-1, 1 and 2: 1-2), one cluster
    everything_small = run_contractor(CoreAttachContraction(min_area=100), ei, 3, edge_attr=attrs, node_attr=area)
    assert everything_small.tolist() == [0, 0, 0]
    g = CorrespondenceGraph(3, ei, attrs, area)
    assert g.contract(CoreAttachContraction(min_area=10)).tolist() == [0, 1, 1]


def test_base_takes_an_options_instance_or_keywords_not_both():
    opts = CoreAttachContraction.Options(min_area=5)
    assert CoreAttachContraction(opts).options is opts
    with pytest.raises(TypeError, match="not both"):
        CoreAttachContraction(opts, min_area=6)
    with pytest.raises(TypeError, match="expected Options options \\(got NoOptions\\)"):
        CoreAttachContraction(NoOptions())
    with pytest.raises(CriterionOptionsError, match="finite number"):
        CoreAttachContraction(min_area=float("inf"))


def test_a_plugin_contractor_needs_only_name_and_call():
    class Pairs(BaseContractor):
        name = "pairs"

        def __call__(self, edge_index, num_nodes, *, rng=None):
            return np.arange(num_nodes) // 2

    c = Pairs()
    assert repr(c) == "Pairs(NoOptions())"
    assert run_contractor(c, np.zeros((2, 0), np.int64), 5).tolist() == [0, 0, 1, 1, 2]
    # plain contractors never see repulsive edges
    seen = []

    class Spy(BaseContractor):
        def __call__(self, edge_index, num_nodes, *, rng=None):
            seen.append(np.asarray(edge_index).tolist())
            return np.arange(num_nodes)

    run_contractor(Spy(), np.array([[0, 1], [1, 2]]), 3, edge_attr={"sign": np.array([1.0, -1.0])})
    assert seen == [[[0], [1]]]
