"""graphseg's ``loftr`` and ``roma`` matchers against the reference packages' own inference (issue 22).

Every model is built once at its smallest size with seeded random weights; the
weights go to a checkpoint file that graphseg loads, and the same weights run
in the reference package:

* ``loftr``: ``kornia.feature.LoFTR`` called directly. LoFTR's keypoints are
  ``(x, y)`` in the model frame of the reference implementation, with pixel
  centres at ``+0.5`` (kornia's docstring); graphseg subtracts 0.5 and maps
  them to each image's pixels by the half-pixel rule
  ``(k - 0.5 + 0.5) * size / model_size - 0.5``.
* ``roma``: romatch's ``RegressionMatcher.match`` (full RoMa) and
  ``TinyRoMa.match`` given PIL images, so that romatch does its own
  preprocessing, and romatch's ``sample``. romatch's ``to_pixel_coordinates``
  puts pixel centres at ``+0.5``; graphseg's matches are those minus 0.5.

Without torchvision (see ``graphseg/backends/matchers/romatch_compat.py``) romatch's PIL
path needs torchvision's ``Resize`` / ``Normalize`` / ``ToTensor``: the
``tv_transforms`` fixture supplies them with torchvision's documented behaviour
for PIL images (``PIL.Image.resize`` with the given filter, ``(x - mean) / std``,
``HWC uint8 -> CHW float / 255``); the mean and std are romatch's own.

The pixel-convention tests replace the model by a stand-in that finds a marker
(a Gaussian blob) in the tensors the backend gives it and answers its centre:
graphseg must put it back at the marker's pixel in the original, non-square
images, after every resize the backend does.
"""

import copy
import gc
import warnings
from functools import partial

import numpy as np
import pytest

from graphseg.backends.registry import matchers
from graphseg.scene import View

torch = pytest.importorskip("torch")
F = torch.nn.functional

# tolerances (measured maxima in the comments of each test)
GREY_TOL = 1.5 / 255  # graphseg rounds to uint8 after grey conversion and after resizing (OpenCV)
PIL_TOL = 3.0 / 255  # PIL's bicubic resize works on uint8, graphseg's in float
MARKER_TOL = 0.05  # pixels


@pytest.fixture(scope="module", autouse=True)
def _one_thread():
    """One intra-op thread: these small models run 3-10x faster than with OpenMP threads on a busy 2-core machine."""
    n = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(n)


def _blob(h, w, x, y, sigma, rgb=(255, 255, 255)):
    """uint8 ``[h, w, 3]``: a Gaussian marker centred on pixel ``(x, y)`` (centres at integers) on black."""
    yy, xx = np.mgrid[0:h, 0:w]
    g = np.exp(-((xx - x) ** 2 + (yy - y) ** 2) / (2 * sigma**2))
    return np.round(g[..., None] * np.asarray(rgb, np.float64)).astype(np.uint8)


def _colour(h, w, seed, cell=6):
    """A smooth, saturated random colour image (random pixels would make the random-weight models' matches fragile)."""
    rng = np.random.default_rng(seed)
    x = torch.from_numpy(rng.random((1, 3, h // cell + 2, w // cell + 2)).astype(np.float32))
    x = F.interpolate(x, (h, w), mode="bicubic", align_corners=False)[0].permute(1, 2, 0).numpy()
    return np.round(np.clip(x, 0, 1) * 255).astype(np.uint8)


def _centroid(img):
    """Intensity-weighted centre ``(x, y)`` (pixel centres at integers) of ``[C, H, W]`` above each channel's minimum."""
    wgt = (img - img.amin(dim=(-2, -1), keepdim=True)).double().sum(0)
    ys, xs = torch.meshgrid(torch.arange(wgt.shape[0], dtype=wgt.dtype), torch.arange(wgt.shape[1], dtype=wgt.dtype), indexing="ij")
    return float((wgt * xs).sum() / wgt.sum()), float((wgt * ys).sum() / wgt.sum())


# ============================================================================ LoFTR
MODEL_WH = (96, 64)  # LoFTR's image_size here: small, non-square, multiples of 8


@pytest.fixture(scope="module")
def loftr(tmp_path_factory):
    """(kornia's LoFTR with seeded random weights, graphseg's ``loftr`` matcher loaded from their checkpoint)."""
    pytest.importorskip("kornia")
    pytest.importorskip("cv2")
    from kornia.feature import LoFTR
    from kornia.feature.loftr.loftr import default_cfg

    cfg = copy.deepcopy(default_cfg)
    cfg["match_coarse"]["thr"] = 0.0  # random weights: dual-softmax scores are ~1e-3, far below the default 0.2
    torch.manual_seed(0)
    ref = LoFTR(pretrained=None, config=cfg).eval()
    path = tmp_path_factory.mktemp("loftr") / "loftr_outdoor.ckpt"
    torch.save({"state_dict": ref.state_dict()}, path)
    m = matchers.resolve("loftr", checkpoint=str(path), image_size=MODEL_WH, match_threshold=0.0, num_matches=None)
    return ref, m


def _area_matrix(n_src, n_dst):
    """Area (box) resampling ``n_src -> n_dst`` (n_dst <= n_src) as a ``[n_dst, n_src]`` matrix of overlaps."""
    s = n_src / n_dst
    lo, hi = np.arange(n_dst)[:, None] * s, (np.arange(n_dst)[:, None] + 1) * s
    i = np.arange(n_src)[None]
    return np.clip(np.minimum(hi, i + 1) - np.maximum(lo, i), 0, None) / s


def _reference_grey(rgb, wh=MODEL_WH):
    """LoFTR's input by graphseg's documented rule, computed independently in float.

    kornia's ``rgb_to_grayscale`` (BT.601 on R, G, B), then area averaging when the
    image shrinks and bilinear interpolation (pixel centres at ``+0.5``, as
    OpenCV's ``INTER_LINEAR``) when it grows, to ``wh``; ``[1, 1, H, W]`` in 0..1.
    """
    from kornia.color import rgb_to_grayscale

    g = rgb_to_grayscale(torch.from_numpy(rgb).permute(2, 0, 1)[None].double() / 255.0)
    (h, w), (tw, th) = g.shape[-2:], wh
    if (w, h) == (tw, th):
        return g.float()
    if w > tw:  # OpenCV's rule, per image: INTER_AREA when the width shrinks
        ay, ax = torch.from_numpy(_area_matrix(h, th)), torch.from_numpy(_area_matrix(w, tw))
        return (ay @ g[0, 0] @ ax.T)[None, None].float()
    return F.interpolate(g, (th, tw), mode="bilinear", align_corners=False).float()


def _model_to_pixels(k, src_hw):
    """LoFTR keypoints (model frame, pixel centres at +0.5) to an image of ``src_hw``: minus 0.5, then the half-pixel rule."""
    s = np.array([src_hw[1] / MODEL_WH[0], src_hw[0] / MODEL_WH[1]])
    return (np.asarray(k, np.float64) - 0.5 + 0.5) * s - 0.5


@pytest.mark.parametrize("hw", [(64, 96), (128, 192), (150, 230), (40, 56)], ids=["same", "down2x", "down-fractional", "up-fractional"])
def test_loftr_grey_and_resize_equal_reference(loftr, hw):
    # max |graphseg - reference| measured: 0.50/255 (same size), 0.91/255 (down 2x), 0.78/255 (150x230), 1.09/255 (40x56)
    _, m = loftr
    rgb = _colour(*hw, seed=1)
    got = m._gray(rgb)
    assert got.shape == (1, 1, MODEL_WH[1], MODEL_WH[0]) and got.dtype == torch.float32
    ref = _reference_grey(rgb)
    assert float((got - ref).abs().max()) <= GREY_TOL
    # channel order: pure red and pure blue take BT.601's 0.299 and 0.114
    red, blue = np.zeros((*hw, 3), np.uint8), np.zeros((*hw, 3), np.uint8)
    red[..., 0], blue[..., 2] = 255, 255
    assert float(m._gray(red).mean()) == pytest.approx(0.299, abs=GREY_TOL)
    assert float(m._gray(blue).mean()) == pytest.approx(0.114, abs=GREY_TOL)


def test_loftr_matches_equal_kornia_on_the_same_input(loftr):
    """Same tensors into kornia's LoFTR: graphseg's loading, config, (x, y) order, pixel mapping and confidence, exactly."""
    ref, m = loftr
    # view i shrinks, view j grows, by different factors in x and y; seeds with 4 matches (random weights find few)
    ri, rj = _colour(150, 230, seed=11), _colour(40, 56, seed=31)
    got = m.raw_matches(View("i", ri), View("j", rj))
    with torch.inference_mode():
        out = ref({"image0": m._gray(ri), "image1": m._gray(rj)})
    assert len(got) == len(out["confidence"]) >= 1
    np.testing.assert_allclose(got.xy_i, _model_to_pixels(out["keypoints0"], ri.shape[:2]), atol=1e-4, rtol=0)
    np.testing.assert_allclose(got.xy_j, _model_to_pixels(out["keypoints1"], rj.shape[:2]), atol=1e-4, rtol=0)
    np.testing.assert_array_equal(got.certainty, out["confidence"].numpy())


def test_loftr_matches_equal_kornia_end_to_end(loftr):
    """The reference's own route: kornia's grey conversion, resize in float, kornia's LoFTR, half-pixel rule."""
    # measured: the same 4 matches; xy_i equal, max |xy_j diff| 0.0074 px, max relative confidence diff 0.66 %
    ref, m = loftr
    ri, rj = _colour(128, 192, seed=3), _colour(40, 56, seed=23)  # 4 matches
    got = m.raw_matches(View("i", ri), View("j", rj))
    with torch.inference_mode():
        out = ref({"image0": _reference_grey(ri), "image1": _reference_grey(rj)})
    assert len(got) == len(out["confidence"]) >= 1
    # keypoints of view i sit on LoFTR's coarse grid: the same cells are matched
    np.testing.assert_allclose(got.xy_i, _model_to_pixels(out["keypoints0"], ri.shape[:2]), atol=1e-4, rtol=0)
    np.testing.assert_allclose(got.xy_j, _model_to_pixels(out["keypoints1"], rj.shape[:2]), atol=0.1, rtol=0)
    np.testing.assert_allclose(got.certainty, out["confidence"].numpy(), rtol=0.05, atol=0)


@pytest.mark.parametrize(
    ("hw_i", "xy_i", "hw_j", "xy_j"),
    [((40, 56), (37.3, 12.6), (40, 56), (31.3, 17.6)), ((150, 230), (61.0, 97.5), (40, 56), (12.2, 25.4))],
    ids=["up-up-shifted-copy", "down-up"],
)
def test_loftr_marker_comes_back_at_its_pixel(loftr, monkeypatch, hw_i, xy_i, hw_j, xy_j):
    # measured max error: 0.014 px
    _, m = loftr
    sig_i, sig_j = 2.5 * max(1, hw_i[0] / MODEL_WH[1]), 2.5 * max(1, hw_j[0] / MODEL_WH[1])
    ri = _blob(*hw_i, *xy_i, sig_i)
    rj = np.roll(ri, (5, -6), axis=(0, 1)) if hw_i == hw_j else _blob(*hw_j, *xy_j, sig_j)  # a shifted copy in the first case

    def locate(batch):  # the model answers the marker's centre in the frame it sees, pixel centres at +0.5 as LoFTR's
        for k in ("image0", "image1"):
            assert batch[k].shape == (1, 1, MODEL_WH[1], MODEL_WH[0])
        k0, k1 = [c + 0.5 for c in _centroid(batch["image0"][0])], [c + 0.5 for c in _centroid(batch["image1"][0])]
        return {"keypoints0": torch.tensor([k0]), "keypoints1": torch.tensor([k1]), "confidence": torch.tensor([0.5])}

    monkeypatch.setattr(m, "model", locate)
    got = m.raw_matches(View("i", ri), View("j", rj))
    np.testing.assert_allclose(got.xy_i[0], xy_i, atol=MARKER_TOL, rtol=0)
    np.testing.assert_allclose(got.xy_j[0], xy_j, atol=MARKER_TOL, rtol=0)


# ============================================================================ RoMa
@pytest.fixture(scope="module")
def romatch():
    pytest.importorskip("kornia")
    pytest.importorskip("einops")
    pytest.importorskip("loguru")
    pytest.importorskip("PIL")
    from graphseg.backends.matchers.romatch_compat import import_romatch
    from graphseg.registry import MissingDependencyError

    try:
        return import_romatch()
    except MissingDependencyError as err:
        pytest.skip(str(err))


@pytest.fixture
def tv_transforms(romatch, monkeypatch):
    """torchvision's PIL behaviour for romatch's own preprocessing, where graphseg's stand-in left torchvision out."""
    import romatch.models.tiny as tiny
    import romatch.utils.utils as U
    from PIL import Image

    if getattr(U.transforms, "__file__", None):  # a real torchvision: romatch uses it
        return

    class Resize:  # transforms.Resize((h, w), mode) on a PIL image
        def __init__(self, size, mode="bicubic"):
            self.size, self.mode = size, mode

        def __call__(self, im):
            return im.resize((self.size[1], self.size[0]), {"bicubic": Image.BICUBIC, "bilinear": Image.BILINEAR}[self.mode])

    class Normalize:
        def __init__(self, mean, std):
            self.mean, self.std = torch.tensor(mean)[:, None, None], torch.tensor(std)[:, None, None]

        def __call__(self, x):
            return (x - self.mean) / self.std

    def to_tensor(im):
        return torch.from_numpy(np.asarray(im, np.float32) / 255.0).permute(2, 0, 1).contiguous()

    monkeypatch.setattr(U.transforms, "Resize", Resize)
    monkeypatch.setattr(U.transforms, "Normalize", Normalize)
    monkeypatch.setattr(tiny, "ToTensor", lambda: to_tensor)


def _romatch_pixels(model, warp, hw_a, hw_b):
    """romatch's ``to_pixel_coordinates`` (pixel centres at +0.5) minus 0.5: graphseg's frame."""
    a, b = model.to_pixel_coordinates(torch.as_tensor(warp).reshape(-1, 4), hw_a[0], hw_a[1], hw_b[0], hw_b[1])
    return a.double().numpy() - 0.5, b.double().numpy() - 0.5


class _Spy:
    """Calls the real ``match`` and keeps its arguments and result."""

    def __init__(self, match):
        self.match, self.calls = match, []

    def __call__(self, *args, **kwargs):
        out = self.match(*args, **kwargs)
        self.calls.append((args, kwargs, out))
        return out


COARSE, UPSAMPLE = 56, 70


@pytest.fixture(scope="module")
def roma_full(romatch, tmp_path_factory):
    """(romatch's RoMa with seeded random weights, graphseg's ``roma`` loaded from their files): a 1-block DINOv2."""
    import romatch.models.transformer as T
    import romatch.models.transformer.dinov2 as D
    from romatch.models.matcher import RegressionMatcher
    from romatch.models.model_zoo.roma_models import roma_model

    def one_block_vit(patch_size=14, **kw):
        return D.DinoVisionTransformer(patch_size=patch_size, embed_dim=1024, depth=1, num_heads=16, mlp_ratio=4, block_fn=partial(D.Block, attn_class=D.MemEffAttention), **kw)

    mp = pytest.MonkeyPatch()
    mp.setattr(T, "vit_large", one_block_vit)

    def seeded_reference():
        torch.manual_seed(0)
        dino = one_block_vit(img_size=518, init_values=1.0, ffn_layer="mlp", block_chunks=0).state_dict()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with pytest.MonkeyPatch.context() as no_load:  # random weights: nothing to load
                no_load.setattr(RegressionMatcher, "load_state_dict", lambda self, sd, strict=True: None)
                # the reference: romatch's own model with the options graphseg maps its own to
                ref = roma_model(resolution=(COARSE, COARSE), upsample_preds=True, upsample_res=(UPSAMPLE, UPSAMPLE), device="cpu", weights={}, dinov2_weights=dino, amp_dtype=torch.float32, use_custom_corr=False, symmetric=True)
        return dino, ref

    dino, ref = seeded_reference()
    d = tmp_path_factory.mktemp("roma")
    torch.save(dino, d / "dinov2_vitl14_pretrain.pth")
    torch.save(ref.state_dict(), d / "roma_outdoor.pth")
    # Memory: graphseg's loader holds the file's state dict and its own model at once; without the
    # reference beside them the suite's peak is one RoMa lower. The same seed builds the same
    # reference again (test 2 below compares the two models' outputs bit for bit).
    del dino, ref
    gc.collect()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = matchers.resolve("roma", checkpoint=str(d / "roma_outdoor.pth"), dinov2_checkpoint=str(d / "dinov2_vitl14_pretrain.pth"), coarse_res=COARSE, upsample_res=UPSAMPLE, symmetric=True, num_matches=None)
    _, ref = seeded_reference()
    mp.undo()
    return ref.eval(), m


@pytest.fixture(scope="module")
def roma_tiny(romatch, tmp_path_factory):
    from kornia.feature import XFeatModel
    from romatch.models.model_zoo.roma_models import tiny_roma_v1_model

    torch.manual_seed(0)
    ref = tiny_roma_v1_model(weights=None, xfeat=XFeatModel()).eval()
    path = tmp_path_factory.mktemp("tiny") / "tiny_roma_v1_outdoor.pth"
    torch.save(ref.state_dict(), path)
    m = matchers.resolve("roma", checkpoint=str(path), num_matches=None)
    assert m.kind == "tiny"
    return ref, m


def test_roma_full_equals_romatch_match(roma_full, tv_transforms, monkeypatch):
    """graphseg vs romatch's RoMa on a non-square pair of different sizes: inputs, warp, certainty, pixels."""
    from PIL import Image
    from romatch.utils import get_tuple_transform_ops

    ref, m = roma_full
    ri, rj = _colour(40, 58, seed=1), _colour(52, 44, seed=2)
    spy = _Spy(m.model.match)
    monkeypatch.setattr(m.model, "match", spy)
    got = m.raw_matches(View("i", ri), View("j", rj))
    ((args, kwargs, (warp, cert)),) = spy.calls

    # 1. graphseg's input vs romatch's own transform (PIL bicubic, its ImageNet mean / std), both resolutions
    # (measured max 2.0/255)
    pil = (Image.fromarray(ri), Image.fromarray(rj))
    std = torch.tensor([0.229, 0.224, 0.225])[:, None, None]
    for res, (a, b) in [(COARSE, args), (UPSAMPLE, (kwargs["im_A_high_res"], kwargs["im_B_high_res"]))]:
        ra, rb = get_tuple_transform_ops(resize=(res, res), normalize=True)(pil)
        for x, r in ((a, ra), (b, rb)):
            assert x.shape == (1, 3, res, res)
            assert float(((x[0] - r) * std).abs().max()) <= PIL_TOL

    # 2. romatch's match on those very tensors: the same warp and certainty, bit for bit (same weights, same options)
    r_warp, r_cert = ref.match(*args, **kwargs)
    assert torch.equal(r_warp, warp) and torch.equal(r_cert, cert)

    # 3. graphseg's matches are romatch's to_pixel_coordinates - 0.5, certainty as is, both directions (symmetric)
    xa, xb = _romatch_pixels(ref, warp[0], ri.shape[:2], rj.shape[:2])
    assert len(got) == len(xa) == UPSAMPLE * 2 * UPSAMPLE  # all inside: romatch clamps its warp
    np.testing.assert_allclose(got.xy_i, xa, atol=1e-4, rtol=0)
    np.testing.assert_allclose(got.xy_j, xb, atol=1e-4, rtol=0)
    np.testing.assert_array_equal(got.certainty, cert[0].reshape(-1).numpy())

    # 4. romatch's own inference from the PIL images. The random-weight model's coarse decoder is a classifier
    # over anchors with nearly flat scores, so the <= 2/255 difference between PIL's and torch's bicubic resize
    # moves its warp in one direction of the pair (here A -> B: median 0.06 px, max 8.2 px; the other direction
    # agrees within 5e-4 px); +-1/255 noise on graphseg's own input moves it as much. Measured: 75 % of the
    # matches within 0.05 px, certainty (smooth) within 8.3e-4 everywhere.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rw, rc = ref.match(*pil)
    ra, rb = _romatch_pixels(ref, rw[0], ri.shape[:2], rj.shape[:2])
    np.testing.assert_allclose(got.certainty, rc[0].reshape(-1).numpy(), atol=5e-3, rtol=0)
    close = (np.abs(got.xy_i - ra).max(1) <= 0.05) & (np.abs(got.xy_j - rb).max(1) <= 0.05)
    assert close.mean() >= 0.5  # a wrong convention, scale, axis order or input moves (nearly) all of them


def test_tiny_roma_equals_romatch_match(roma_tiny, tv_transforms):
    """Same-size pair: graphseg's tiny RoMa input is romatch's own (0..1, no resize), so the match is exact."""
    # measured max diff: 0 (pixels and certainty)
    from PIL import Image

    ref, m = roma_tiny
    ri, rj = _colour(48, 72, seed=3), _colour(48, 72, seed=4)
    got = m.raw_matches(View("i", ri), View("j", rj))
    warp, cert = ref.match(Image.fromarray(ri), Image.fromarray(rj))  # romatch's own ToTensor; [H, W, 4], [H, W]
    assert warp.shape == (48, 72, 4)
    xa, xb = _romatch_pixels(ref, warp, ri.shape[:2], rj.shape[:2])
    # tiny RoMa does not clamp its warp: graphseg drops matches that leave either image
    inside = ((xa >= -0.5) & (xa <= np.array([71.5, 47.5]))).all(1) & ((xb >= -0.5) & (xb <= np.array([71.5, 47.5]))).all(1)
    assert inside.sum() == len(got) >= 0.5 * len(xa)
    np.testing.assert_allclose(got.xy_i, xa[inside], atol=1e-4, rtol=0)
    np.testing.assert_allclose(got.xy_j, xb[inside], atol=1e-4, rtol=0)
    np.testing.assert_array_equal(got.certainty, cert.reshape(-1).numpy()[inside])
    np.testing.assert_allclose(got.xy_i[:2], [[0, 0], [1, 0]], atol=1e-4)  # row-major, (x, y), centres at integers


def test_sampling_equals_romatch_sample(roma_tiny, monkeypatch):
    """graphseg's ``sample_by_certainty`` draws as romatch's ``sample`` in its ``threshold`` mode.

    The two use different generators (numpy / torch), so the same seed cannot give
    the same draw: the test compares the kept set where it is certain and the
    inclusion frequencies otherwise (RoMa's default ``threshold_balanced`` adds a
    kernel-density step graphseg leaves out).
    """
    from graphseg.backends.matchers.sampling import sample_by_certainty
    from graphseg.scene import Matches

    ref, _ = roma_tiny
    monkeypatch.setattr(ref, "sample_mode", "threshold")
    cert = np.array([0.9, 0.3, 0.04, 0.02, 0.01, 0.06, 0.005, 0.0], np.float32)
    xy = np.arange(16, dtype=np.float32).reshape(8, 2)
    m = Matches(xy, xy + 100, cert)
    warp = torch.from_numpy(np.c_[xy, xy + 100]).reshape(8, 1, 4)
    # every match with positive certainty: both keep exactly those
    torch.manual_seed(0)
    rm, _ = ref.sample(warp, torch.from_numpy(cert).reshape(8, 1), num=7)
    s = sample_by_certainty(m, 7, threshold=0.05, rng=0)
    assert sorted(rm[:, 0].tolist()) == sorted(s.xy_i[:, 0].tolist()) == xy[:7, 0].tolist()
    # 3 of 8: inclusion frequencies over 4000 draws agree (std of a difference <= 0.011; measured max 0.0105)
    n = 4000
    f_ref, f_got = np.zeros(8), np.zeros(8)
    torch.manual_seed(0)
    for k in range(n):
        rm, _ = ref.sample(warp, torch.from_numpy(cert).reshape(8, 1), num=3)
        f_ref[(rm[:, 0].numpy() / 2).astype(int)] += 1 / n
        f_got[(sample_by_certainty(m, 3, threshold=0.05, rng=k).xy_i[:, 0] / 2).astype(int)] += 1 / n
    assert f_ref[7] == f_got[7] == 0
    np.testing.assert_allclose(f_got, f_ref, atol=0.025)


def _locate_match(*tensors):
    """One warp entry ``(x_A, y_A, x_B, y_B)`` in romatch's normalised frame from markers in two ``[1, 3, h, w]`` tensors."""
    out = []
    for t in tensors:
        x, y = _centroid(t[0])
        h, w = t.shape[-2:]
        out += [(2 * x + 1) / w - 1, (2 * y + 1) / h - 1]
    return out


@pytest.mark.parametrize("kind", ["roma", "tiny"])
def test_roma_marker_comes_back_at_its_pixel(roma_full, roma_tiny, monkeypatch, kind):
    # measured max error: 0.003 px (full: 56x56 and 70x70 squares; tiny: view j resized to view i's size)
    m = (roma_full if kind == "roma" else roma_tiny)[1]
    (hi, wi), xy_i, (hj, wj), xy_j = (40, 58), (41.3, 12.6), (52, 44), (10.2, 33.7)
    ri, rj = _blob(hi, wi, *xy_i, 2.5), _blob(hj, wj, *xy_j, 2.5)
    seen = []

    def locate(a, b, *args, **kwargs):
        seen.append(a.shape[-2:])
        rows = [_locate_match(a, b)]
        if "im_A_high_res" in kwargs:
            seen.append(kwargs["im_A_high_res"].shape[-2:])
            rows.append(_locate_match(kwargs["im_A_high_res"], kwargs["im_B_high_res"]))
        warp = torch.tensor(rows)[None]  # [1, n, 4]
        return warp, torch.full(warp.shape[:-1], 0.9)

    monkeypatch.setattr(m.model, "match", locate)
    got = m.raw_matches(View("i", ri), View("j", rj))
    assert seen == ([(COARSE, COARSE), (UPSAMPLE, UPSAMPLE)] if kind == "roma" else [(hi, wi)])
    assert len(got) == len(seen)
    for k in range(len(got)):
        np.testing.assert_allclose(got.xy_i[k], xy_i, atol=MARKER_TOL, rtol=0)
        np.testing.assert_allclose(got.xy_j[k], xy_j, atol=MARKER_TOL, rtol=0)
