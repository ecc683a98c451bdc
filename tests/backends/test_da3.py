"""The da3 lifter with Depth Anything 3's real network code (da3-small, random weights, tiny input).

The checkpoint is a random-weight state dict written by the test; the geometry is
therefore meaningless, and the test checks shapes, finiteness, the checkpoint
loading path and the error messages.
"""

import numpy as np
import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("depth_anything_3")
pytest.importorskip("addict")

from graphseg.backends.lifters.da3 import DA3Lifter, load_da3  # noqa: E402
from graphseg.scene import Scene, SceneError, View  # noqa: E402
from graphseg.testing.scenes import TWO_BOXES, box_scene  # noqa: E402


@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory):
    torch.manual_seed(0)
    net = load_da3("da3-small")
    path = tmp_path_factory.mktemp("da3") / "da3-small.pt"
    torch.save({"model." + k: v for k, v in net.state_dict().items()}, path)  # the Hub wrapper's key prefix
    return path


@pytest.fixture(scope="module")
def lifter(checkpoint):
    return DA3Lifter(checkpoint=str(checkpoint), size=70)


def test_da3_lifts_an_rgb_only_scene(lifter):
    s = box_scene(TWO_BOXES, views=3, shape=(48, 64))
    scene = Scene([View(v.name, v.rgb) for v in s.views])
    out = lifter(scene)
    assert out.meta["lifter"] == "da3" and out.meta["scale"]["method"] == "nominal-distance"
    for v in out.views:
        assert v.points.shape == (48, 64, 3) and v.confidence.shape == (48, 64)
        assert np.isfinite(v.points).any() and np.isfinite(v.cam_to_world).all()
        v.validate()
    known = Scene([v.replace(cam_to_world=t.cam_to_world) for v, t in zip(scene.views, s.views)])
    assert lifter(known).meta["scale"]["metric"]  # the scene's poses calibrate the scale


def test_da3_errors_name_the_option(checkpoint, tmp_path):
    with pytest.raises(SceneError, match=r"da3: checkpoint: no checkpoint given; set --backend-option da3.checkpoint=PATH; pip install \"graphseg\[da3\]\""):
        DA3Lifter()
    with pytest.raises(SceneError, match=r"missing.pt: checkpoint: no such file"):
        DA3Lifter(checkpoint=str(tmp_path / "missing.pt"))
    with pytest.raises(SceneError, match=r"da3-small.pt: checkpoint: does not match da3-base.*da3.model"):
        DA3Lifter(checkpoint=str(checkpoint), model="da3-base")
    with pytest.raises(SceneError, match="unknown DA3 model 'da3-tiny'"):
        DA3Lifter(random_weights=True, model="da3-tiny")


def test_missing_package_names_the_extra_and_the_option(monkeypatch):
    import sys

    from graphseg.registry import MissingDependencyError

    monkeypatch.setitem(sys.modules, "depth_anything_3.cfg", None)
    with pytest.raises(MissingDependencyError, match=r'graphseg\[da3\].*--no-deps depth-anything-3==0.1.1.*da3.checkpoint=PATH'):
        DA3Lifter(random_weights=True)


def test_cli_runs_an_rgb_only_scene_with_da3(lifter, tmp_path, capsys, monkeypatch):
    """End to end through the CLI; the lifter built from the checkpoint above is reused (config options: test_dust3r)."""
    from graphseg.backends.registry import lifters
    from graphseg.cli import main
    from graphseg.io.images import write_rgb

    monkeypatch.setitem(lifters._targets, "da3", lifter)
    monkeypatch.setattr(lifters, "_loaded", {k: v for k, v in lifters._loaded.items() if k != "da3"})
    img = tmp_path / "images"
    img.mkdir()
    for v in box_scene(TWO_BOXES, views=3, shape=(48, 64)).views:
        write_rgb(img / f"{v.name}.png", v.rgb)
    code = main([str(a) for a in ["run", img, "-o", tmp_path / "out", "--lifter", "da3", "--segmenter", "superpixel", "--quiet"]])
    assert code == 0, capsys.readouterr().err
    run = __import__("json").loads((tmp_path / "out" / "run.json").read_text())
    assert run["pipeline"]["lifter"] == "da3" and (tmp_path / "out" / "result.npz").exists()
