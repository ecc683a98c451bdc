"""LoFTR and RoMa matchers on the real model code with random weights written to checkpoint files."""

import sys
import warnings
from functools import partial

import numpy as np
import pytest

from graphseg.backends.matchers.sampling import sample_by_certainty
from graphseg.backends.registry import matchers
from graphseg.registry import MissingDependencyError
from graphseg.scene import Matches, SceneError, View


# ----------------------------------------------------------------------------- sampling
def _m(cert):
    n = len(cert)
    xy = np.arange(2 * n, dtype=np.float32).reshape(n, 2)
    return Matches(xy, xy + 1, np.asarray(cert, np.float32))


def test_sample_by_certainty_shape_and_order():
    m = _m(np.linspace(0.01, 1, 50))
    s = sample_by_certainty(m, 10, rng=0)
    assert len(s) == 10 and s.xy_i.shape == (10, 2)
    assert np.all(np.diff(s.xy_i[:, 0]) > 0)  # original order kept
    assert np.array_equal(s.xy_j, s.xy_i + 1)  # pairs stay together
    assert np.array_equal(sample_by_certainty(m, 10, rng=0).xy_i, s.xy_i)  # seeded


def test_sample_by_certainty_weights_follow_roma_threshold():
    # 1000 matches above the threshold (weight 1) vs 1000 at 0.001 (weight 0.001):
    # drawing 100, the expected number of low ones is ~ 100 * 1 / 1001 -> at most a few
    cert = np.r_[np.full(1000, 0.3), np.full(1000, 0.001)]
    s = sample_by_certainty(_m(cert), 100, rng=1)
    assert (s.certainty < 0.01).sum() <= 3
    # above the threshold every certainty weighs the same: 0.06 and 0.99 are drawn alike
    cert = np.r_[np.full(1000, 0.06), np.full(1000, 0.99)]
    s = sample_by_certainty(_m(cert), 1000, rng=2)
    assert 400 < (s.certainty < 0.5).sum() < 600


def test_sample_by_certainty_edge_cases():
    m = _m([0.0, 0.2, 0.0])
    assert sample_by_certainty(m, None).certainty.tolist() == pytest.approx([0.2])
    assert len(sample_by_certainty(_m([]), 5)) == 0


# ----------------------------------------------------------------------------- LoFTR
torch = pytest.importorskip("torch")


@pytest.fixture(scope="module")
def loftr_ckpt(tmp_path_factory):
    pytest.importorskip("kornia")
    from kornia.feature import LoFTR

    torch.manual_seed(0)
    path = tmp_path_factory.mktemp("loftr") / "loftr_outdoor.ckpt"
    torch.save({"state_dict": LoFTR(pretrained=None).state_dict()}, path)
    return path


def _pair(h=96, w=128, shift=6):
    rng = np.random.default_rng(0)
    a = rng.integers(0, 255, (h, w, 3)).astype(np.uint8)
    return View("a", a), View("b", np.roll(a, shift, axis=1))


def test_loftr_loads_checkpoint_and_matches(loftr_ckpt):
    m = matchers.resolve("loftr", checkpoint=str(loftr_ckpt), image_size=(64, 48), match_threshold=0.0, num_matches=3)
    assert m.needs_3d is False
    vi, vj = _pair()
    raw = m.raw_matches(vi, vj)
    assert raw.xy_i.shape[1] == 2 and len(raw) >= 1
    assert (raw.xy_i >= -0.5).all() and (raw.xy_i[:, 0] <= 127.5).all() and (raw.xy_i[:, 1] <= 95.5).all()
    assert len(m(vi, vj)) == min(3, len(raw))


def test_loftr_maps_keypoints_to_original_pixels(loftr_ckpt):
    m = matchers.resolve("loftr", checkpoint=str(loftr_ckpt), image_size=(64, 48))

    def fake(batch):  # keypoints in the 64x48 frame, pixel centres at +0.5 (LoFTR's frame)
        assert batch["image0"].shape == (1, 1, 48, 64) and float(batch["image0"].max()) <= 1.0
        kp = torch.tensor([[0.0, 0.0], [63.0, 47.0]])
        return {"keypoints0": kp, "keypoints1": kp + 1, "confidence": torch.tensor([0.9, 0.3])}

    m.model = fake
    out = m.raw_matches(*_pair(96, 128))  # 2x larger images: x -> ((x - 0.5) + 0.5) * 2 - 0.5
    assert out.xy_i.tolist() == [[-0.5, -0.5], [125.5, 93.5]]
    assert out.xy_j.tolist() == [[1.5, 1.5], [127.5, 95.5]]
    assert out.certainty.tolist() == pytest.approx([0.9, 0.3])


def test_pipeline_passes_num_matches_and_config_options_to_loftr(loftr_ckpt):
    from graphseg.config import Config
    from graphseg.pipeline import compute_matches
    from graphseg.sim.boxes import Box
    from graphseg.testing.scenes import box_scene

    scene = box_scene([Box((0.0, 0.0, 0.05), (0.1, 0.1, 0.1))], views=2, shape=(48, 64), rng=0)
    opts = {"checkpoint": str(loftr_ckpt), "image_size": [64, 48], "match_threshold": 0.0}
    cfg = Config.model_validate({"backends": {"matcher": "loftr", "num_matches": 1, "options": {"loftr": opts}}})
    matches = compute_matches(scene, config=cfg, pairs=[(0, 1)])
    assert set(matches) == {(0, 1)}
    assert len(matches[(0, 1)]) <= 1  # backends.num_matches reaches the matcher through its signature


def test_loftr_errors_are_one_line(loftr_ckpt, tmp_path):
    with pytest.raises(SceneError, match="no checkpoint given; set --backend-option loftr.checkpoint=PATH"):
        matchers.resolve("loftr")
    bad = tmp_path / "bad.ckpt"
    torch.save({"state_dict": {"x": torch.zeros(1)}}, bad)
    with pytest.raises(SceneError, match="weights do not fit kornia's LoFTR") as err:
        matchers.resolve("loftr", checkpoint=str(bad))
    assert err.value.where == str(bad) and "\n" not in str(err.value)
    with pytest.raises(SceneError, match="multiples of 8"):
        matchers.resolve("loftr", checkpoint=str(loftr_ckpt), image_size=(100, 60))
    with pytest.raises(SceneError, match="valid keys: checkpoint, num_matches"):
        matchers.resolve("loftr", checkpoint=str(loftr_ckpt), resolution=(64, 48))


def test_loftr_missing_package(monkeypatch):
    monkeypatch.setitem(sys.modules, "kornia", None)
    with pytest.raises(MissingDependencyError, match=r'graphseg\[loftr\]", then set --backend-option loftr.checkpoint=PATH'):
        matchers.resolve("loftr", checkpoint="x.ckpt")


# ----------------------------------------------------------------------------- RoMa
@pytest.fixture(scope="module")
def romatch():
    pytest.importorskip("kornia")
    pytest.importorskip("einops")
    pytest.importorskip("loguru")
    from graphseg.backends.matchers.romatch_compat import import_romatch

    try:
        return import_romatch()
    except MissingDependencyError as err:
        pytest.skip(str(err))


def test_romatch_import_leaves_no_fake_torchvision(romatch):
    mod = sys.modules.get("torchvision")
    assert mod is None or getattr(mod, "__file__", None)


def test_tiny_roma_matches(romatch, tmp_path):
    from kornia.feature import XFeatModel
    from romatch.models.model_zoo.roma_models import tiny_roma_v1_model

    torch.manual_seed(0)
    path = tmp_path / "tiny_roma_v1_outdoor.pth"
    torch.save(tiny_roma_v1_model(weights=None, xfeat=XFeatModel()).state_dict(), path)
    m = matchers.resolve("roma", checkpoint=str(path), num_matches=40)
    assert m.kind == "tiny"  # from the file name
    vi, vj = _pair(64, 96)
    raw = m.raw_matches(vi, vj)
    assert len(raw) == 64 * 96  # one per pixel of view i
    # the warp's first pixel is view i's pixel (0, 0)
    assert np.allclose(raw.xy_i[0], [0, 0], atol=1e-3) and np.allclose(raw.xy_i[1], [1, 0], atol=1e-3)
    out = m(vi, vj)
    assert len(out) == 40 and (out.certainty > 0).all()


@pytest.fixture(scope="module")
def small_roma(romatch, tmp_path_factory):
    """Full RoMa (VGG19 + DINOv2 + GP + decoders) with a 1-block DINOv2 so the test stays small."""
    import romatch.models.transformer as T
    import romatch.models.transformer.dinov2 as D
    from romatch.models.matcher import RegressionMatcher
    from romatch.models.model_zoo.roma_models import roma_model

    def one_block_vit(patch_size=14, **kw):
        return D.DinoVisionTransformer(patch_size=patch_size, embed_dim=1024, depth=1, num_heads=16, mlp_ratio=4, block_fn=partial(D.Block, attn_class=D.MemEffAttention), **kw)

    mp = pytest.MonkeyPatch()
    mp.setattr(T, "vit_large", one_block_vit)
    torch.manual_seed(0)
    dino = one_block_vit(img_size=518, init_values=1.0, ffn_layer="mlp", block_chunks=0).state_dict()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mp.setattr(RegressionMatcher, "load_state_dict", lambda self, sd, strict=True: None)
        model = roma_model(resolution=(56, 56), upsample_preds=False, device="cpu", weights={}, dinov2_weights=dino, amp_dtype=torch.float32, use_custom_corr=False)
        mp.undo()
        mp.setattr(T, "vit_large", one_block_vit)
    d = tmp_path_factory.mktemp("roma")
    torch.save(dino, d / "dinov2_vitl14_pretrain.pth")
    torch.save(model.state_dict(), d / "roma_outdoor.pth")
    del model, dino  # the files are what the tests load: don't hold a second RoMa all module long
    yield d / "roma_outdoor.pth", d / "dinov2_vitl14_pretrain.pth"
    mp.undo()


def test_roma_loads_both_weight_files_and_matches(small_roma):
    ckpt, dino = small_roma
    m = matchers.resolve("roma", checkpoint=str(ckpt), dinov2_checkpoint=str(dino), coarse_res=56, upsample_res=None, symmetric=False, num_matches=30)
    assert m.kind == "roma"
    vi, vj = _pair(48, 64)
    raw = m.raw_matches(vi, vj)
    assert len(raw) > 0 and raw.xy_i.shape[1] == 2
    # 56x56 warp over a 64x48 image: first pixel centre -> (0.5 * 64 / 56 - 0.5, 0.5 * 48 / 56 - 0.5)
    assert np.allclose(raw.xy_i[0], [0.5 * 64 / 56 - 0.5, 0.5 * 48 / 56 - 0.5], atol=1e-3)
    assert len(m(vi, vj)) == 30


def test_roma_errors(small_roma, tmp_path):
    ckpt, dino = small_roma
    with pytest.raises(SceneError, match="no checkpoint given; set --backend-option roma.dinov2_checkpoint=PATH") as err:
        matchers.resolve("roma", checkpoint=str(ckpt))
    assert err.value.field == "backends.options.roma.dinov2_checkpoint"
    with pytest.raises(SceneError, match="weights do not fit DINOv2") as err:
        matchers.resolve("roma", checkpoint=str(ckpt), dinov2_checkpoint=str(ckpt), coarse_res=56, upsample_res=None)
    assert err.value.where == str(ckpt)
    with pytest.raises(SceneError, match="multiple of 14"):
        matchers.resolve("roma", checkpoint=str(ckpt), dinov2_checkpoint=str(dino), coarse_res=100)


def test_roma_missing_package_names_no_deps_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "romatch", None)
    msg = r'roma needs \'romatch\': pip install "graphseg\[roma\]" && pip install --no-deps romatch, then set --backend-option roma.checkpoint=PATH'
    with pytest.raises(MissingDependencyError, match=msg):
        matchers.resolve("roma", checkpoint=__file__, model="tiny")
