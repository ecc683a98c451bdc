"""SAM 2 segmenters on the real model code with random weights (tiny, 256 px)."""

import sys

import numpy as np
import pytest

from graphseg.backends.registry import segmenters
from graphseg.registry import MissingDependencyError
from graphseg.scene import SceneError, View

torch = pytest.importorskip("torch")
pytest.importorskip("sam2")

SIZE = 256
FAST = dict(image_size=SIZE, points_per_side=3, pred_iou_thresh=-1e9, stability_score_thresh=0.0)


@pytest.fixture(scope="module")
def tiny_sam2(tmp_path_factory):
    """A random tiny SAM 2.1 and its checkpoint, saved under the official file name."""
    from sam2.build_sam import build_sam2

    torch.manual_seed(0)
    model = build_sam2("configs/sam2.1/sam2.1_hiera_t.yaml", ckpt_path=None, device="cpu", hydra_overrides_extra=[f"++model.image_size={SIZE}"])
    path = tmp_path_factory.mktemp("sam2") / "sam2.1_hiera_tiny.pt"
    torch.save({"model": model.state_dict()}, path)
    return model.eval(), path


@pytest.fixture(scope="module")
def sam2_seg(tiny_sam2):
    """The ``sam2`` backend loaded from the checkpoint (config inferred from the file name)."""
    return segmenters.resolve("sam2", checkpoint=str(tiny_sam2[1]), **FAST)


@pytest.fixture(scope="module")
def image():
    rng = np.random.default_rng(0)
    rgb = np.zeros((48, 64, 3), np.uint8)
    rgb[:] = (40, 60, 80)
    rgb[10:30, 12:40] = (220, 30, 30)
    return (rgb + rng.integers(0, 10, rgb.shape)).astype(np.uint8)


def test_registered():
    from graphseg.backends.segmenters.sam import SAM2Segmenter, SamOnnxSegmenter

    assert segmenters.get("sam2") is SAM2Segmenter
    assert segmenters.get("sam-onnx") is SamOnnxSegmenter


def test_sam2_segmenter_loads_checkpoint_and_segments(tiny_sam2, sam2_seg, image):
    seg = sam2_seg
    masks = seg(View("0", image))
    assert isinstance(masks, list) and len(masks) >= 1
    assert all(m.dtype == bool and m.shape == (48, 64) for m in masks)
    # the checkpoint's weights were loaded: same parameters as the saved model
    ref = dict(tiny_sam2[0].named_parameters())
    for k, v in seg.model.named_parameters():
        assert torch.equal(v, ref[k])


def test_sam2_predictor_matches_model_decoder(tiny_sam2, image):
    from graphseg.backends.segmenters.sam import sam2_predictor

    model, _ = tiny_sam2
    predict = sam2_predictor(model, image)
    pts = np.array([[10.0, 20.0], [50.0, 5.0], [30.0, 30.0]])
    logits, iou = predict(pts, np.ones(3, np.int64))
    assert logits.shape == (3, 3, SIZE // 4, SIZE // 4) and iou.shape == (3, 3)
    # batching does not change a prompt's result
    one, iou1 = predict(pts[1:2], np.ones(1, np.int64))
    assert np.allclose(one[0], logits[1], atol=1e-4) and np.allclose(iou1[0], iou[1], atol=1e-5)


def test_sam2_missing_checkpoint_is_one_line(tmp_path):
    with pytest.raises(SceneError) as err:
        segmenters.resolve("sam2", checkpoint=str(tmp_path / "nope.pt"))
    msg = str(err.value)
    assert "\n" not in msg and err.value.field == "backends.options.sam2.checkpoint"
    assert err.value.where == str(tmp_path / "nope.pt") and "graphseg[sam2]" in msg
    with pytest.raises(SceneError, match="no checkpoint given; set --backend-option sam2.checkpoint=PATH"):
        segmenters.resolve("sam2")


def test_sam2_wrong_checkpoint_and_config(tiny_sam2, tmp_path):
    bad = tmp_path / "weights.pt"
    torch.save({"model": {"not_a_key": torch.zeros(1)}}, bad)
    with pytest.raises(SceneError, match="weights do not fit configs/sam2.1/sam2.1_hiera_t.yaml") as err:
        segmenters.resolve("sam2", checkpoint=str(bad), config="sam2.1_hiera_t", image_size=SIZE)
    assert "\n" not in str(err.value) and err.value.field == "backends.options.sam2.checkpoint" and err.value.where == str(bad)
    with pytest.raises(SceneError, match="cannot tell the SAM 2 config") as err:
        segmenters.resolve("sam2", checkpoint=str(bad))
    assert err.value.field == "backends.options.sam2.config"
    with pytest.raises(SceneError, match="no SAM 2 config"):
        segmenters.resolve("sam2", checkpoint=str(bad), config="configs/sam2.1/sam2.1_hiera_xl.yaml")


def test_sam2_unknown_option_lists_valid_keys():
    with pytest.raises(SceneError, match="unknown option 'chekpoint'; valid keys: points_per_side, .*checkpoint, config.*did you mean 'checkpoint'") as err:
        segmenters.resolve("sam2", checkpoint="x.pt", chekpoint="x.pt")
    assert err.value.field == "backends.options.sam2.chekpoint"


def test_sam2_missing_package_names_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "sam2", None)
    msg = r'pip install "graphseg\[sam2\]" && SAM2_BUILD_CUDA=0 pip install --no-build-isolation --no-deps sam2, then set --backend-option sam2.checkpoint=PATH'
    with pytest.raises(MissingDependencyError, match=msg):
        segmenters.resolve("sam2", checkpoint="x.pt")


# ----------------------------------------------------------------------------- ONNX
@pytest.fixture(scope="module")
def onnx_pair(tiny_sam2, tmp_path_factory):
    """The tiny SAM 2 exported with graphseg's exporter (encoder + prompt encoder/mask decoder)."""
    pytest.importorskip("onnxruntime")
    pytest.importorskip("onnx")
    from graphseg.backends.onnx_export import export_sam2_onnx

    out = tmp_path_factory.mktemp("sam_onnx")
    enc, dec = export_sam2_onnx(tiny_sam2[0], out)
    with pytest.raises(FileExistsError):  # never overwrites
        export_sam2_onnx(tiny_sam2[0], out)
    return enc, dec


def test_sam_onnx_matches_torch_backend(sam2_seg, onnx_pair, image):
    enc, dec = onnx_pair
    opts = {k: v for k, v in FAST.items() if k != "image_size"}
    onnx_seg = segmenters.resolve("sam-onnx", encoder=str(enc), decoder=str(dec), points_per_batch=4, **opts)
    assert onnx_seg.image_size == SIZE  # read from the encoder's fixed input
    props = onnx_seg.proposals(View("0", image))
    assert props.masks.shape[1:] == (48, 64) and props.masks.dtype == bool and len(props.masks) >= 1
    ref = sam2_seg.proposals(View("0", image))
    assert np.all(np.diff(ref.iou) <= 0)  # best predicted IoU first
    assert len(ref.masks) == len(props.masks)
    assert np.allclose(ref.iou, props.iou, atol=1e-3)
    agree = (ref.masks == props.masks).mean()
    assert agree > 0.999


def test_sam_onnx_one_prompt_at_a_time_and_renamed_outputs(onnx_pair, image):
    enc, dec = onnx_pair
    opts = {k: v for k, v in FAST.items() if k != "image_size"}
    a = segmenters.resolve("sam-onnx", encoder=str(enc), decoder=str(dec), **opts).proposals(View("0", image))
    b = segmenters.resolve("sam-onnx", encoder=str(enc), decoder=str(dec), batch_prompts=False, masks_output="masks", iou_output="iou_predictions", **opts).proposals(View("0", image))
    assert np.array_equal(a.masks, b.masks) and np.allclose(a.iou, b.iou, atol=1e-5)


def test_sam_onnx_decoder_output_order_does_not_matter(onnx_pair, image, tmp_path):
    """A decoder that declares its IoU output before its masks gives the same proposals."""
    import onnx

    enc, dec = onnx_pair
    model = onnx.load(str(dec))
    outs = list(model.graph.output)
    del model.graph.output[:]
    model.graph.output.extend(outs[::-1])
    assert [o.name for o in model.graph.output] != [o.name for o in outs]
    onnx.save(model, str(tmp_path / "dec_reversed.onnx"))
    opts = {k: v for k, v in FAST.items() if k != "image_size"}
    a = segmenters.resolve("sam-onnx", encoder=str(enc), decoder=str(dec), **opts).proposals(View("0", image))
    b = segmenters.resolve("sam-onnx", encoder=str(enc), decoder=str(tmp_path / "dec_reversed.onnx"), **opts).proposals(View("0", image))
    assert np.array_equal(a.masks, b.masks) and np.allclose(a.iou, b.iou, atol=1e-6)


def test_sam_onnx_bad_names_and_missing_files(onnx_pair, tmp_path):
    enc, dec = onnx_pair
    with pytest.raises(SceneError, match="decoder has no input 'coords'; its inputs: image_embed, "):
        segmenters.resolve("sam-onnx", encoder=str(enc), decoder=str(dec), point_coords_input="coords")
    with pytest.raises(SceneError, match="encoder has no output 'emb'"):
        segmenters.resolve("sam-onnx", encoder=str(enc), decoder=str(dec), feeds={"image_embed": "emb"})
    with pytest.raises(SceneError) as err:
        segmenters.resolve("sam-onnx", encoder=str(enc), decoder=str(tmp_path / "missing.onnx"))
    assert err.value.field == "backends.options.sam-onnx.decoder" and "graphseg[onnx]" in str(err.value)
    with pytest.raises(SceneError, match="pattern"):
        segmenters.resolve("sam-onnx", encoder=str(enc), decoder=str(dec), resize="stretch")


def test_pipeline_takes_sam2_options_from_the_config(tiny_sam2):
    from graphseg.config import Config
    from graphseg.pipeline import compute_masks
    from graphseg.sim.boxes import Box
    from graphseg.testing.scenes import box_scene

    scene = box_scene([Box((0.0, 0.0, 0.05), (0.1, 0.1, 0.1))], views=2, shape=(48, 64), rng=0)
    opts = {"checkpoint": str(tiny_sam2[1]), **FAST}
    cfg = Config.model_validate({"backends": {"segmenter": "sam2", "options": {"sam2": opts}}})
    masks = compute_masks(scene, config=cfg)
    assert len(masks) == 2 and all(len(ms) >= 1 for ms in masks)
    assert all(m.dtype == bool and m.shape == (48, 64) for ms in masks for m in ms)


def test_sam_onnx_longest_side_crops_logits_to_the_image(onnx_pair, image):
    # SAM 1 layout: 64x48 -> 256x192 padded to 256x256; low-res logits 64x64 -> valid part 48x64
    enc, dec = onnx_pair
    seg = segmenters.resolve("sam-onnx", encoder=str(enc), decoder=str(dec), resize="longest_side")
    logits, iou = seg.predictor(image)(np.array([[10.0, 20.0]]), np.ones(1, np.int64))
    assert logits.shape == (1, 3, 48, 64) and iou.shape == (1, 3)


def test_sam2_no_mask_kept_gives_an_empty_label_image(sam2_seg, image):
    sam2_seg.options.pred_iou_thresh = 1e9  # nothing passes
    try:
        out = sam2_seg(View("0", image))
    finally:
        sam2_seg.options.pred_iou_thresh = FAST["pred_iou_thresh"]
    assert isinstance(out, np.ndarray) and out.shape == (48, 64) and not out.any()
