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


def test_builtins_by_name_class_instance():
    a = edge_adders.resolve("pixel_match", tau=0.3)
    assert isinstance(a, PixelMatch) and a.tau == 0.3
    assert isinstance(edge_adders.resolve(PixelMatch), PixelMatch)
    inst = PixelMatch()
    assert edge_adders.resolve(inst) is inst
    with pytest.raises(TypeError, match="cannot apply options"):
        edge_adders.resolve(inst, tau=1.0)


def test_unknown_name_lists_installed_choices():
    with pytest.raises(PluginNotFoundError, match=r"unknown edge adder 'nope'; installed choices: pixel_match, chamfer_3d, dino"):
        edge_adders.get("nope")


def test_own_entry_point_plugins_load_for_real():
    """graphseg's pyproject registers loopback plugins; they come through importlib.metadata."""
    assert "testing_loopback" in edge_adders.names()
    assert "testing_loopback" in contractors.names()
    adder = edge_adders.resolve("testing_loopback")
    assert type(adder).__module__ == "graphseg.testing.plugins"
    c = contractors.resolve("testing_loopback")
    assert c([[0], [1]], 3).tolist() == [0, 0, 1]


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
