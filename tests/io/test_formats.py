import textwrap

import pytest

from graphseg.io import detect_format, load_scene, scene_formats
from graphseg.scene import SceneError
from graphseg.testing.plugins import refresh_registries, write_dist_info

READER = '''
import numpy as np
from graphseg.io import SceneFormat
from graphseg.scene import Scene, View


class TinyFormat(SceneFormat):
    name = "tiny"

    def detect(self, path):
        return (path / "tiny.txt").exists()

    def read(self, path, *, views=None, step=None, num_views=None):
        n = int((path / "tiny.txt").read_text())
        vs = [View(name=f"v{i}", rgb=np.full((4, 5, 3), i, np.uint8)) for i in range(n)]
        return Scene(vs, name="tiny")
'''


@pytest.fixture
def tiny_reader(tmp_path, monkeypatch):
    pkg = tmp_path / "site"
    pkg.mkdir()
    (pkg / "tiny_reader.py").write_text(textwrap.dedent(READER))
    write_dist_info(pkg, "tiny-reader", {"graphseg.scene_formats": {"tiny": "tiny_reader:TinyFormat"}})
    monkeypatch.syspath_prepend(str(pkg))
    refresh_registries()
    yield
    monkeypatch.undo()
    refresh_registries()


def test_reader_plugin_is_detected_and_read(tiny_reader, tmp_path):
    scene_dir = tmp_path / "scene"
    scene_dir.mkdir()
    (scene_dir / "tiny.txt").write_text("3")
    assert "tiny" in scene_formats.names()
    assert detect_format(scene_dir) == "tiny"
    scene = load_scene(scene_dir)
    assert scene.name == "tiny" and [v.name for v in scene.views] == ["v0", "v1", "v2"]


def test_unknown_format_lists_the_choices(tmp_path):
    with pytest.raises(SceneError, match="unknown scene format 'nope'; choose one of native, bop, graspnet, ycbv"):
        load_scene(tmp_path, format="nope")


def test_builtin_detection_unchanged(tmp_path):
    (tmp_path / "scene.json").write_text("{}")
    assert detect_format(tmp_path) == "native"
    with pytest.raises(SceneError, match="no such file"):
        detect_format(tmp_path / "missing")
