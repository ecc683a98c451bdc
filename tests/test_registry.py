import warnings
from importlib.metadata import EntryPoint

import pytest

from graphseg import registry as regmod
from graphseg.graphs import contractors, edge_adders
from graphseg.graphs.pixel_match import PixelMatch
from graphseg.registry import (
    MissingDependencyError,
    PluginLoadWarning,
    PluginNotFoundError,
    Registry,
    require,
)
from graphseg.testing.plugins import refresh_registries, write_dist_info


def test_builtins_by_name_class_instance():
    a = edge_adders.resolve("pixel_match", tau=0.3)
    assert isinstance(a, PixelMatch) and a.options.tau == 0.3
    assert isinstance(edge_adders.resolve(PixelMatch), PixelMatch)
    inst = PixelMatch()
    assert edge_adders.resolve(inst) is inst
    with pytest.raises(TypeError, match="cannot apply options"):
        edge_adders.resolve(inst, tau=1.0)


def test_unknown_name_lists_installed_choices():
    with pytest.raises(PluginNotFoundError, match=r"unknown edge criterion 'nope'; installed choices: pixel_match, chamfer_3d, dino"):
        edge_adders.get("nope")


@pytest.fixture
def loopback_dist(tmp_path, monkeypatch):
    """The loopback plugins installed the way pip would: a dist-info folder on sys.path."""
    write_dist_info(
        tmp_path,
        "graphseg-loopback",
        {
            "graphseg.edge_adders": {"testing_loopback": "graphseg.testing.plugins:LoopbackEdgeAdder"},
            "graphseg.contractors": {"testing_loopback": "graphseg.testing.plugins:LoopbackContractor"},
        },
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    refresh_registries()
    yield
    monkeypatch.undo()
    refresh_registries()


def test_entry_point_plugins_load_for_real(loopback_dist):
    """Entry points come through importlib.metadata from a dist-info folder on sys.path."""
    assert "testing_loopback" in edge_adders.names()
    assert "testing_loopback" in contractors.names()
    adder = edge_adders.resolve("testing_loopback")
    assert type(adder).__module__ == "graphseg.testing.plugins"
    c = contractors.resolve("testing_loopback")
    assert c([[0], [1]], 3).tolist() == [0, 0, 1]


def test_legacy_plain_callable_runs_as_a_stage(loopback_dist):
    from graphseg.config import Config
    from graphseg.method.segment import segment
    from graphseg.testing.plugins import LoopbackEdgeAdder
    from graphseg.testing.scenes import two_boxes_scene

    before = LoopbackEdgeAdder.calls
    r = segment(*two_boxes_scene(), Config(stages=[["pixel_match"], ["chamfer_3d", "testing_loopback"]]))
    assert LoopbackEdgeAdder.calls == before + 1 and r.num_objects == 2


def test_test_plugins_are_not_in_the_package_metadata():
    """pyproject declares no test-only entry points (they would show in users' choices)."""
    from pathlib import Path

    import tomllib

    meta = tomllib.loads((Path(__file__).resolve().parents[1] / "pyproject.toml").read_text())
    eps = meta["project"].get("entry-points", {})
    assert not any("testing" in name for group in eps.values() for name in group)


def test_entry_points_are_lazy(monkeypatch):
    reg = Registry("thing", "graphseg.test_group")
    loaded = []

    class FakeEP(EntryPoint):
        def load(self):
            loaded.append(self.name)
            return dict

    monkeypatch.setattr(regmod, "entry_points", lambda group: [FakeEP("lazy", "x:y", group)])
    assert reg.names() == ["lazy"]
    assert loaded == []  # listing does not import
    assert reg.get("lazy") is dict and loaded == ["lazy"]


def test_broken_plugin_warns_not_crashes(monkeypatch):
    reg = Registry("thing", "graphseg.test_group")
    reg.register("good", "collections:OrderedDict")
    monkeypatch.setattr(regmod, "entry_points", lambda group: [EntryPoint("broken", "no_such_module_abc:Thing", group)])
    assert reg.get("good").__name__ == "OrderedDict"
    with pytest.warns(PluginLoadWarning, match="'broken' failed to load"):
        with pytest.raises(PluginNotFoundError, match="failed to load"):
            reg.get("broken")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert reg.available() == ["good"]
        with pytest.raises(PluginNotFoundError, match="installed choices: good"):
            reg.get("other")
    reg.refresh()
    assert "broken" in reg.names()


def test_register_decorator_and_repr():
    reg = Registry("thing", "graphseg.test_group")

    @reg.register("mine")
    class Mine:
        pass

    assert reg.resolve("mine").__class__ is Mine
    assert "mine" in repr(reg) and "mine" in reg


def test_require_names_the_extra():
    with pytest.raises(MissingDependencyError, match=r'pip install "graphseg\[open3d\]"'):
        require("no_such_module_q", "open3d")
