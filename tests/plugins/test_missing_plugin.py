"""A result or store written with a plugin criterion, read where the plugin is not installed (issue 52):
one line naming the criterion and how to install it, exit 2 (it used to read "corrupt or tampered result file")."""

import sys

import pytest

from graphseg import Result
from graphseg.cli import main
from graphseg.io import write_scene_folder
from graphseg.registry import PluginLoadWarning
from graphseg.scene import SceneError
from graphseg.testing.plugins import refresh_registries, write_dist_info
from graphseg.testing.scenes import TWO_BOXES, box_scene

NOT_INSTALLED = "config: edge criterion 'probe_x' is not installed (a plugin: install the package that provides the graphseg.edge_adders entry point 'probe_x')"


def _install(site, target):
    write_dist_info(site, "probe-x", {"graphseg.edge_adders": {"probe_x": target}})
    sys.path.insert(0, str(site))
    refresh_registries()


def _uninstall(site):
    while str(site) in sys.path:
        sys.path.remove(str(site))
    refresh_registries()


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    """An output folder and a store made while the plugin ``probe_x`` was installed (then removed)."""
    d = tmp_path_factory.mktemp("missing_plugin")
    write_scene_folder(box_scene(TWO_BOXES, views=2, shape=(48, 64)), d / "scene")
    (d / "c.yaml").write_text("stages:\n  - [pixel_match]\n  - [chamfer_3d]\n  - [probe_x]\n")
    site = d / "site"
    _install(site, "graphseg.testing.plugins:LoopbackEdgeAdder")
    try:
        assert main(["run", str(d / "scene"), "-o", str(d / "out"), "--config", str(d / "c.yaml"), "--quiet"]) == 0
        assert main(["add", str(d / "store"), str(d / "scene"), "--config", str(d / "c.yaml"), "--quiet"]) == 0
        assert Result.load(d / "out" / "result.npz").config.stage_names()[2] == ["probe_x"]
    finally:
        _uninstall(site)
    return d


def test_result_load_names_the_missing_criterion(written):
    path = written / "out" / "result.npz"
    with pytest.raises(SceneError) as err:
        Result.load(path)
    assert str(err.value) == f"{path}: {NOT_INSTALLED}"
    assert "tampered" not in str(err.value)


@pytest.mark.parametrize("command", [["info", "{out}"], ["eval", "{out}"], ["info", "{store}"], ["eval", "{store}"], ["suggest", "{store}"]])
def test_cli_names_the_missing_criterion(written, command, capsys):
    argv = [a.format(out=written / "out", store=written / "store") for a in command]
    code = main(argv)
    out = capsys.readouterr()
    assert code == 2 and out.out == ""
    lines = out.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("graphseg: error: ") and lines[0].endswith(NOT_INSTALLED), lines


def test_a_plugin_that_fails_to_load_says_so(written, tmp_path):
    site = tmp_path / "site"
    _install(site, "no_such_module_for_probe_x:Probe")
    try:
        with pytest.warns(PluginLoadWarning, match="probe_x"), pytest.raises(SceneError) as err:
            Result.load(written / "out" / "result.npz")
    finally:
        _uninstall(site)
    msg = str(err.value)
    assert msg.endswith("config: edge criterion 'probe_x' is installed but failed to load (ModuleNotFoundError: No module named 'no_such_module_for_probe_x')"), msg
