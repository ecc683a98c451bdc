"""The suite's own configuration: only graphseg's warnings are errors (issue 52).

A fresh virtual environment resolves the newest pytest and plugins; pytest 9.2 warned about dash's
old-style hook (dash comes with open3d) and ``filterwarnings = ["error"]`` made that warning stop
collection. These tests run pytest in a subprocess with this project's ``pyproject.toml``.
"""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

PLUGIN = """
import pytest

def pytest_configure(config):
    config.issue_config_time_warning(pytest.PytestDeprecationWarning("a third-party plugin's old-style hook"), stacklevel=2)
"""


def _pytest(tmp_path, test_body):
    (tmp_path / "thirdparty_plugin.py").write_text(PLUGIN)
    (tmp_path / "test_probe.py").write_text(test_body)
    cmd = [sys.executable, "-m", "pytest", "-c", str(ROOT / "pyproject.toml"), "--rootdir", str(tmp_path), "-o", "addopts=", "-p", "no:cacheprovider", "-p", "thirdparty_plugin", str(tmp_path / "test_probe.py")]
    env = {"PYTHONPATH": f"{tmp_path}:{ROOT}", "PATH": "/usr/bin:/bin"}
    return subprocess.run(cmd, capture_output=True, text=True, cwd=tmp_path, env=env, timeout=120)


def test_a_third_party_plugins_warning_never_stops_collection(tmp_path):
    r = _pytest(tmp_path, "def test_ok():\n    pass\n")
    assert r.returncode == 0 and "1 passed" in r.stdout, r.stdout + r.stderr
    assert "old-style hook" in r.stdout  # shown, not hidden


def test_graphsegs_own_warnings_are_still_errors(tmp_path):
    body = (
        "import warnings\n"
        "from graphseg.registry import PluginLoadWarning\n\n"
        "def test_warns():\n"
        "    warnings.warn('a plugin failed to load', PluginLoadWarning)\n"
    )
    r = _pytest(tmp_path, body)
    assert r.returncode == 1 and "1 failed" in r.stdout and "PluginLoadWarning" in r.stdout, r.stdout + r.stderr
