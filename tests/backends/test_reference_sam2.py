"""The ``sam2`` backend against SAM 2's own reference code, on the same random weights.

graphseg drives SAM 2's image encoder, prompt encoder and mask decoder itself
(:func:`graphseg.backends.segmenters.sam.sam2_predictor`, :func:`graphseg.backends.segmenters.automask.generate_masks`);
here they are checked against ``sam2``'s ``SAM2ImagePredictor`` and
``SAM2AutomaticMaskGenerator``. Those import torchvision, which cannot be
installed beside the tests' CPU torch: the ``reference`` fixture imports them
with a stand-in (``_torchvision_standin``, plain torch, test-only) and removes
it again afterwards.

The tiny SAM 2.1 runs at 128 px input (its config says 1024) so that the whole
file takes seconds; ``SAM2ImagePredictor`` hard-codes the backbone feature
sizes of a 1024 px input, so the tests set them for 128 px.
"""

import importlib.util
import sys

import numpy as np
import pytest

from graphseg.backends.registry import segmenters
from graphseg.scene import View

torch = pytest.importorskip("torch")
pytest.importorskip("sam2")

from . import _torchvision_standin as tv  # noqa: E402  (needs torch)

SIZE = 128
H, W = 48, 80  # non-square on purpose: x and y scale differently (W -> SIZE: 1.6, H -> SIZE: 2.67)
TOL = 1e-4

# Automatic mask generator settings for both implementations. Random weights give weak
# logits (|logit| < 0.5) and predicted IoUs near 0.5: the thresholds are lowered so that
# some masks pass, with one crop layer so that crops, the crop-edge filter and both NMS
# steps all act (on the blocks image: 9 masks kept of more than 20 candidates).
AMG = dict(
    points_per_side=4,
    points_per_batch=16,
    pred_iou_thresh=0.45,
    stability_score_thresh=0.3,
    stability_score_offset=0.02,
    mask_threshold=0.15,
    box_nms_thresh=0.7,
    crop_n_layers=1,
    crop_nms_thresh=0.7,
    crop_overlap_ratio=512 / 1500,
    crop_n_points_downscale_factor=2,
    min_mask_region_area=0,
)


# ----------------------------------------------------------------------------- fixtures
def _watched():
    """The torchvision and SAM 2 reference modules now in ``sys.modules``."""
    return {k: v for k, v in sys.modules.items() if k == "torchvision" or k.startswith("torchvision.") or k in tv.REFERENCE_MODULES}


@pytest.fixture(scope="module")
def reference():
    """SAM 2's reference modules, imported with the torchvision stand-in (removed after this module)."""
    before = _watched()
    with tv.installed() as mods:
        yield mods
    assert _watched() == before


@pytest.fixture(scope="module")
def weights(tmp_path_factory):
    """A random tiny SAM 2.1 (the reference's model) and the ``sam2`` backend (``AMG`` settings) loaded from its checkpoint."""
    from sam2.build_sam import build_sam2

    torch.manual_seed(0)
    model = build_sam2("configs/sam2.1/sam2.1_hiera_t.yaml", ckpt_path=None, device="cpu", hydra_overrides_extra=[f"++model.image_size={SIZE}"]).eval()
    path = tmp_path_factory.mktemp("sam2_ref") / "sam2.1_hiera_tiny.pt"
    torch.save({"model": model.state_dict()}, path)
    seg = segmenters.resolve("sam2", checkpoint=str(path), image_size=SIZE, **AMG)
    assert seg.model is not model
    return model, seg


def _for_size(predictor, size=SIZE):
    """The reference predictor's backbone feature sizes (hard-coded for 1024 px) for ``size``."""
    predictor._bb_feat_sizes = [(size // 4, size // 4), (size // 8, size // 8), (size // 16, size // 16)]
    return predictor


def _blocks_image():
    """Grey with three coloured blocks, none symmetric to another."""
    rgb = np.full((H, W, 3), 128, np.uint8)
    rgb[8:20, 10:26] = (255, 0, 0)
    rgb[28:42, 50:70] = (0, 0, 255)
    rgb[4:12, 56:64] = (255, 255, 255)
    return rgb


# ----------------------------------------------------------------------------- the stand-in
def test_standin_nms_semantics():
    """``nms`` / ``batched_nms`` / ``box_area`` as torchvision documents them (hand-computed)."""
    b = torch.tensor([[0, 0, 4, 4], [0, 0, 4, 2], [10, 10, 14, 14], [0, 0, 0, 0], [0, 0, 0, 0]], dtype=torch.float32)
    s = torch.tensor([0.9, 0.8, 0.7, 0.6, 0.5])
    assert tv.box_area(b).tolist() == [16, 8, 16, 0, 0]
    assert tv.box_area(b.long()).dtype == torch.int64
    # IoU([0,0,4,4], [0,0,4,2]) = 0.5: suppressed only when strictly above the threshold;
    # empty boxes give IoU 0/0 = NaN, which suppresses nothing
    assert tv.nms(b, s, 0.5).tolist() == [0, 1, 2, 3, 4]
    assert tv.nms(b, s, 0.49).tolist() == [0, 2, 3, 4]
    assert tv.nms(b, torch.tensor([0.1, 0.8, 0.7, 0.6, 0.5]), 0.49).tolist() == [1, 2, 3, 4]  # best score first
    # categories never suppress each other
    assert tv.batched_nms(b, s, torch.tensor([0, 1, 0, 0, 0]), 0.49).tolist() == [0, 1, 2, 3, 4]
    assert tv.batched_nms(b, s, torch.zeros(5, dtype=torch.int64), 0.49).tolist() == [0, 2, 3, 4]
    assert tv.batched_nms(b[:0], s[:0], torch.zeros(0), 0.5).tolist() == []
    big = torch.tensor([[0, 0, 4, 4], [0, 0, 4, 2]] * 600, dtype=torch.float32)  # > 4000 coordinates: per-category path
    idx = torch.arange(1200) // 2
    assert tv.batched_nms(big, torch.linspace(1, 0, 1200), idx, 0.49).tolist() == list(range(0, 1200, 2))


def test_standin_transforms_semantics():
    rgb = np.arange(2 * 3 * 3, dtype=np.uint8).reshape(2, 3, 3) * 10
    x = tv.ToTensor()(rgb)
    assert x.shape == (3, 2, 3) and x.dtype == torch.float32 and x[2, 1, 0] == pytest.approx(rgb[1, 0, 2] / 255)
    n = tv.Normalize([0.5, 0.25, 0.0], [0.5, 0.25, 1.0])(x)
    assert torch.allclose(n[0], (x[0] - 0.5) / 0.5) and torch.allclose(n[1], (x[1] - 0.25) / 0.25) and torch.equal(n[2], x[2])
    # Resize((h, w)): bilinear, antialiased, half-pixel centres; the same size is returned as is
    up = tv.Resize((4, 6))(x)
    assert up.shape == (3, 4, 6) and torch.allclose(up[:, 0, 0], x[:, 0, 0])  # corner pixels extend
    assert tv.Resize((2, 3))(x) is x
    flat = torch.full((3, 8, 8), 0.25)
    assert torch.allclose(tv.Resize((3, 5))(flat), torch.full((3, 3, 5), 0.25))  # antialias weights sum to 1
    # scriptable, as SAM 2 scripts them
    scripted = torch.jit.script(torch.nn.Sequential(tv.Resize((4, 6)), tv.Normalize([0.1] * 3, [0.2] * 3)))
    assert torch.allclose(scripted(x), (up - 0.1) / 0.2)


def test_standin_leaves_nothing_behind():
    before = _watched()
    importable = "torchvision" in before or importlib.util.find_spec("torchvision") is not None
    with tv.installed() as mods:
        assert mods["sam2.automatic_mask_generator"].batched_nms is tv.batched_nms
        assert sys.modules["torchvision.transforms"].Resize is tv.Resize
    assert _watched() == before
    if not importable:  # no torchvision before (installed or stand-in): none after
        with pytest.raises(ImportError):
            import torchvision  # noqa: F401


# ----------------------------------------------------------------------------- predictor
def test_predictor_matches_sam2_image_predictor(weights, reference):
    """Low-resolution logits and predicted IoUs, one prompt at a time and batched, foreground and background."""
    from graphseg.backends.segmenters.sam import sam2_predictor

    model, seg = weights
    rng = np.random.default_rng(0)
    rgb = (_blocks_image().astype(np.int64) + rng.integers(-20, 20, (H, W, 3))).clip(0, 255).astype(np.uint8)
    ref = _for_size(reference["sam2.sam2_image_predictor"].SAM2ImagePredictor(model))
    ref.set_image(rgb)
    predict = sam2_predictor(seg.model, rgb)
    pts = np.array([[0.0, 0.0], [79.0, 47.0], [70.0, 5.0], [12.5, 40.25], [41.0, 23.0]], np.float32)
    labels = np.array([1, 1, 0, 1, 1])
    logits, iou = predict(pts, labels)
    assert logits.shape == (5, 3, SIZE // 4, SIZE // 4) and iou.shape == (5, 3)
    for i in range(len(pts)):
        _, ref_iou, ref_low = ref.predict(pts[i : i + 1], labels[i : i + 1], multimask_output=True, return_logits=True)
        # the reference clamps its low-resolution logits to +-32 (for reuse as a mask prompt)
        np.testing.assert_allclose(np.clip(logits[i], -32, 32), ref_low, rtol=0, atol=TOL)
        np.testing.assert_allclose(iou[i], ref_iou, rtol=0, atol=TOL)
    # batched, as the reference's automatic mask generator calls it (coordinates normalised by the image size)
    coords = ref._transforms.transform_coords(torch.as_tensor(pts), normalize=True, orig_hw=(H, W))
    _, ref_iou, ref_low = ref._predict(coords[:, None], torch.as_tensor(labels, dtype=torch.int32)[:, None], multimask_output=True, return_logits=True)
    np.testing.assert_allclose(np.clip(logits, -32, 32), ref_low.numpy(), rtol=0, atol=TOL)
    np.testing.assert_allclose(iou, ref_iou.numpy(), rtol=0, atol=TOL)


# ----------------------------------------------------------------------------- automatic mask generator
def _ref_boxes(anns):
    """The reference's XYWH boxes (last pixel inclusive) as graphseg's half-open boxes."""
    return [[x, y, x + w + 1, y + h + 1] for x, y, w, h in (a["bbox"] for a in anns)]


def _same_proposals(props, anns):
    """graphseg's proposals and the reference's annotations hold the same masks (and IoUs, stabilities, boxes, prompts)."""
    assert len(props.masks) == len(anns)
    ours = {m.tobytes(): i for i, m in enumerate(props.masks)}
    assert len(ours) == len(props.masks)
    for a, box in zip(anns, _ref_boxes(anns)):
        i = ours.pop(a["segmentation"].tobytes(), None)
        assert i is not None, f"reference mask {a['bbox']} (prompt {a['point_coords']}) missing in graphseg's"
        assert props.boxes[i].tolist() == box
        assert props.iou[i] == pytest.approx(a["predicted_iou"], abs=TOL)
        assert props.stability[i] == pytest.approx(a["stability_score"], abs=TOL)
        assert props.points[i].tolist() == pytest.approx(a["point_coords"][0], abs=TOL)
    assert not ours


def test_automatic_mask_generator_matches_sam2(weights, reference, monkeypatch):
    import graphseg.backends.segmenters.sam as sam

    model, seg = weights
    rgb = _blocks_image()
    gen = reference["sam2.automatic_mask_generator"].SAM2AutomaticMaskGenerator(model, **AMG)
    _for_size(gen.predictor)
    anns = gen.generate(rgb)
    encoded: dict = {}  # image (crop) -> predict: encode each crop once for both runs below
    encode = sam.sam2_predictor

    def cached(m, im):
        key = (im.shape, im.tobytes())
        if key not in encoded:
            encoded[key] = encode(m, im)
        return encoded[key]

    monkeypatch.setattr(sam, "sam2_predictor", cached)
    props = seg.proposals(View("0", rgb))  # the backend, with the AMG options it was built with
    _same_proposals(props, anns)
    assert len(anns) >= 5 and any(a["crop_box"] != [0, 0, W, H] for a in anns) and len(encoded) == 5
    # NMS (within and across crops) did act: without it there are many more masks
    seg.options.box_nms_thresh = seg.options.crop_nms_thresh = 1.0
    try:
        assert len(seg.proposals(View("0", rgb)).masks) > len(anns) + 5
    finally:
        seg.options.box_nms_thresh, seg.options.crop_nms_thresh = AMG["box_nms_thresh"], AMG["crop_nms_thresh"]


# ----------------------------------------------------------------------------- pixel conventions
class _PromptProbe:
    """SAM 2's prompt encoder, recording the prompt coordinates it gets (model-input pixels)."""

    def __init__(self, encoder):
        self.encoder = encoder
        self.coords = None

    def __call__(self, points, boxes, masks):
        self.coords = points[0].detach().clone()
        return self.encoder(points=points, boxes=boxes, masks=masks)

    def get_dense_pe(self):
        return self.encoder.get_dense_pe()


class _DiscModel:
    """The tiny SAM 2 whose mask decoder draws discs around the prompt; records the encoder's input.

    Logit ``r - d`` at distance ``d`` (model-input pixels) from the prompt, for radii
    ``r`` = 10, 16, 22, on the decoder's ``SIZE/4`` grid; SAM's prompt encoder takes
    a prompt ``p`` as the point ``p + 0.5`` (pixel centre), and so does the disc.
    """

    RADII = (10.0, 16.0, 22.0)

    def __init__(self, model):
        self._model = model
        self.sam_prompt_encoder = _PromptProbe(model.sam_prompt_encoder)
        self.inputs = []
        self._features = None

    def __getattr__(self, name):
        return getattr(self._model, name)

    def forward_image(self, x):
        """Records ``x``; the features (unused by the discs) are computed once, for speed."""
        self.inputs.append(x.detach().clone())
        if self._features is None:
            self._features = self._model.forward_image(x)
        return self._features

    def sam_mask_decoder(self, *, multimask_output, **kwargs):
        pts = self.sam_prompt_encoder.coords[:, 0]  # [B, 2] first (only) point of each prompt
        g = SIZE // 4
        centres = (torch.arange(g, dtype=torch.float32) + 0.5) * (SIZE / g)
        dx = centres[None, None, :] - (pts[:, 0, None, None] + 0.5)
        dy = centres[None, :, None] - (pts[:, 1, None, None] + 0.5)
        d = torch.sqrt(dx**2 + dy**2)
        logits = torch.stack([r - d for r in self.RADII], 1)
        iou = torch.tensor([[0.9, 0.8, 0.7]]).repeat(len(pts), 1)
        return logits, iou, None, None


def _marker_image():
    """Asymmetric: a marker of colour (230, 40, 10) at x 60..71, y 6..13 on (20, 90, 200)."""
    rgb = np.zeros((H, W, 3), np.uint8)
    rgb[:] = (20, 90, 200)
    rgb[6:14, 60:72] = (230, 40, 10)
    return rgb


def _check_encoder_input(x):
    """The marker is where it should be in the normalised ``SIZE x SIZE`` input, in RGB order."""
    mean = torch.tensor([0.485, 0.456, 0.406])[:, None, None]
    std = torch.tensor([0.229, 0.224, 0.225])[:, None, None]
    assert x.shape == (1, 3, SIZE, SIZE)
    rgb = (x[0] * std + mean) * 255
    # input pixel (u, v) samples image pixel ((u + 0.5) W / SIZE - 0.5, (v + 0.5) H / SIZE - 0.5)
    inside = (105, 26)  # image (65.4, 9.4): deep inside the marker
    outside = [(SIZE - 1 - 105, 26), (105, SIZE - 1 - 26), (26, 105)]  # mirrored / transposed: background
    assert rgb[:, inside[1], inside[0]].tolist() == pytest.approx([230, 40, 10], abs=1e-3)
    for u, v in outside:
        assert rgb[:, v, u].tolist() == pytest.approx([20, 90, 200], abs=1e-3)
    # the marker spans image x 60..71 -> input 96.0..115.2 and y 6..13 -> 16.0..37.3 (edges blend)
    red = rgb[0] > 125
    cols, rows = red.any(0).nonzero()[:, 0], red.any(1).nonzero()[:, 0]
    assert (cols.min().item(), cols.max().item(), rows.min().item(), rows.max().item()) == (96, 114, 16, 36)


def _check_discs_at_prompts(masks, points):
    """Every mask contains its prompt's pixel and is centred on it (within a pixel)."""
    assert len(masks) >= 1
    for m, (x, y) in zip(masks, points):
        assert m.shape == (H, W)
        assert m[int(round(y)), int(round(x))], (x, y)
        yy, xx = np.nonzero(m)
        # a disc cut by the image border is centred inside it: compare only whole discs
        if yy.min() > 0 and xx.min() > 0 and yy.max() < H - 1 and xx.max() < W - 1:
            assert abs(xx.mean() - x) < 1.0 and abs(yy.mean() - y) < 1.0, (xx.mean(), yy.mean(), x, y)


PROMPTS = np.array([[70.0, 38.0], [9.0, 5.0], [41.0, 23.0], [66.0, 10.0]], np.float32)


def test_pixel_conventions_predictor(weights, reference):
    """A prompt at image pixel (x, y) comes back as a disc at (x, y) on a non-square image; the image marker is in place."""
    import torch.nn.functional as F

    from graphseg.backends.segmenters.sam import sam2_predictor

    model, seg = weights
    rgb = _marker_image()
    ours = _DiscModel(seg.model)
    logits, _ = sam2_predictor(ours, rgb)(PROMPTS, np.ones(len(PROMPTS), np.int64))
    _check_encoder_input(ours.inputs[-1])
    expect = torch.as_tensor(PROMPTS) * torch.tensor([SIZE / W, SIZE / H])
    assert torch.allclose(ours.sam_prompt_encoder.coords[:, 0], expect, atol=1e-4)
    # the low-resolution logits cover the whole image (half-pixel centres)
    full = F.interpolate(torch.as_tensor(logits), (H, W), mode="bilinear", align_corners=False).numpy() > 0
    for c in range(3):
        _check_discs_at_prompts(full[:, c], PROMPTS)
    # the reference agrees (the test's conventions are SAM 2's)
    theirs = _DiscModel(model)
    ref = _for_size(reference["sam2.sam2_image_predictor"].SAM2ImagePredictor(theirs))
    ref.set_image(rgb)
    _check_encoder_input(theirs.inputs[-1])
    for i, p in enumerate(PROMPTS):
        masks, _, low = ref.predict(p[None], np.ones(1), multimask_output=True)
        np.testing.assert_allclose(low, np.clip(logits[i], -32, 32), rtol=0, atol=TOL)
        for c in range(3):
            _check_discs_at_prompts(masks[c : c + 1].astype(bool), p[None])
            assert np.array_equal(masks[c].astype(bool), full[i, c])


def test_pixel_conventions_automatic_masks(weights, reference):
    """Grid prompts, full image and crops: each mask is a disc at its prompt; same masks as the reference."""
    from graphseg.backends.segmenters.automask import AutomaskOptions, generate_masks, point_grid
    from graphseg.backends.segmenters.sam import _crop_predictor, sam2_predictor

    model, seg = weights
    rgb = _marker_image()
    opts = dict(AMG, points_per_side=3, crop_n_points_downscale_factor=1, mask_threshold=0.0, stability_score_offset=1.0, stability_score_thresh=0.5, pred_iou_thresh=0.5)
    ours = _DiscModel(seg.model)
    make = lambda im: sam2_predictor(ours, im)  # noqa: E731
    props = generate_masks(make(rgb), (H, W), AutomaskOptions(**opts), predict_crop=_crop_predictor(make, rgb))
    _check_encoder_input(ours.inputs[0])  # the full image is encoded first
    _check_discs_at_prompts(props.masks, props.points)
    # discs from prompts of the full image's 3 x 3 grid and from prompts in crops (crop pixels, shifted back)
    grid = {tuple(p) for p in (point_grid(3) * [W, H]).astype(np.float32).tolist()}
    from_grid = np.array([tuple(p) in grid for p in props.points.tolist()])
    assert from_grid.sum() >= 9 and (~from_grid).sum() >= 4
    gen = reference["sam2.automatic_mask_generator"].SAM2AutomaticMaskGenerator(_DiscModel(model), **opts)
    _for_size(gen.predictor)
    _same_proposals(props, gen.generate(rgb))
