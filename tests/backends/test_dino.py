"""DINOv2 dense features from a checkpoint file (torch) and from an ONNX export, random weights."""

import numpy as np
import pytest

from graphseg.backends.features.dino import dinov2_arch, patch_grid
from graphseg.backends.registry import features
from graphseg.scene import SceneError, View


def test_dinov2_arch_from_file_names():
    assert dinov2_arch("dinov2_vits14_pretrain.pth") == "vits14"
    assert dinov2_arch("/x/dinov2_vitg14_reg4_pretrain.pth") == "vitg14"
    with pytest.raises(ValueError, match="set arch to one of vits14"):
        dinov2_arch("weights.pth")


def test_patch_grid_multiples_of_14():
    assert patch_grid((480, 640), 448) == (336, 448)
    assert patch_grid((640, 480), 224) == (224, 168)
    assert patch_grid((10, 1000), 100) == (14, 98)  # never less than one patch


torch = pytest.importorskip("torch")


@pytest.fixture(scope="module")
def vits14(tmp_path_factory):
    pytest.importorskip("kornia")
    pytest.importorskip("einops")
    from graphseg.backends.features.dino import build_dinov2
    from graphseg.backends.matchers.romatch_compat import import_romatch
    from graphseg.registry import MissingDependencyError

    try:
        import_romatch()
    except MissingDependencyError as err:
        pytest.skip(str(err))

    torch.manual_seed(0)
    model = build_dinov2("vits14").eval()
    path = tmp_path_factory.mktemp("dino") / "dinov2_vits14_pretrain.pth"
    torch.save(model.state_dict(), path)
    return model, path


@pytest.fixture(scope="module")
def fx(vits14):
    return features.resolve("dinov2", checkpoint=str(vits14[1]), image_size=112)


@pytest.fixture(scope="module")
def rgb():
    return np.random.default_rng(0).integers(0, 255, (48, 64, 3)).astype(np.uint8)


def test_dinov2_torch_features(vits14, fx, rgb):
    model, _ = vits14
    out = fx(View("0", rgb))
    assert out.shape == (6, 8, 384) and out.dtype == np.float32  # 84x112 input / 14
    x, h, w = fx._input(rgb)
    with torch.no_grad():
        ref = model.forward_features(torch.from_numpy(x))["x_norm_patchtokens"][0].numpy()
    assert np.allclose(out.reshape(-1, 384), ref, atol=1e-5)
    fx.options.normalize = True
    unit = fx(View("0", rgb))
    fx.options.normalize = False
    assert np.allclose(np.linalg.norm(unit, axis=-1), 1, atol=1e-5)


def test_dinov2_onnx_matches_torch(vits14, fx, rgb, tmp_path):
    pytest.importorskip("onnxruntime")
    pytest.importorskip("onnx")
    model, _ = vits14
    ref = fx(View("0", rgb))
    x, h, w = fx._input(rgb)

    from graphseg.backends.onnx_export import export_dinov2_onnx

    onnx_path = export_dinov2_onnx(model, tmp_path / "dinov2_vits14.onnx", *x.shape[2:])
    assert "interpolate_pos_encoding" not in vars(model)  # the model is left as it was
    fx_onnx = features.resolve("dinov2", checkpoint=str(onnx_path))
    assert fx_onnx.fixed == (84, 112)  # read from the model's fixed input
    out = fx_onnx(View("0", rgb))
    assert out.shape == ref.shape and np.allclose(out, ref, atol=1e-4)
    with pytest.raises(SceneError, match="no output 'feats'; its outputs: tokens"):
        features.resolve("dinov2", checkpoint=str(onnx_path), onnx_output="feats")


def test_dinov2_errors(vits14, tmp_path):
    _, path = vits14
    with pytest.raises(SceneError, match="no checkpoint given; set --backend-option dinov2.checkpoint=PATH"):
        features.resolve("dinov2")
    bad = tmp_path / "dinov2_vits14_bad.pth"
    torch.save({"pos_embed": torch.zeros(1)}, bad)
    with pytest.raises(SceneError, match="weights do not fit DINOv2 vits14") as err:
        features.resolve("dinov2", checkpoint=str(bad))
    assert err.value.where == str(bad) and "\n" not in str(err.value)
    renamed = tmp_path / "weights.pth"
    renamed.write_bytes(path.read_bytes())
    with pytest.raises(SceneError, match="cannot tell the DINOv2 architecture") as err:
        features.resolve("dinov2", checkpoint=str(renamed))
    assert err.value.field == "backends.options.dinov2.arch"
