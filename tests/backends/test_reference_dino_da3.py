"""The ``dinov2`` feature extractor and the ``da3`` lifter against their reference code (issue 22).

Same seeded random weights on both sides (ViT-S/14, DA3-small; small inputs), written to
checkpoint files as a user's would be:

* ``dinov2``: graphseg's features (torch ``.pth`` and ONNX paths) against the DINOv2
  forward pass of the vendored official code in kornia (``kornia.feature.dedode``; the
  same code as facebookresearch/dinov2's hub models: ``img_size=518``, ``init_values=1``,
  no registers, bicubic position-embedding interpolation with offset 0.1), fed with the
  official preprocessing: RGB in [0, 1], ImageNet mean/std (DINOv2's
  ``make_normalize_transform``).
* ``da3``: graphseg's lifter against Depth Anything 3's own entry point
  ``DepthAnything3.inference`` (its ``InputProcessor`` resize and normalisation, the
  network, its ``OutputProcessor``), and world point maps against DA3's own
  ``unproject_depth`` with ``c2w = affine_inverse(w2c)``.
* Pixel conventions on non-square images: a marker at a known pixel comes back in the
  right feature cell (and ``node_mean_features`` maps that cell back to the marker's
  pixels), and in the right point-map pixel after DA3's two resizes and the nearest
  resize back.

``depth_anything_3.api`` imports modules graphseg does not install (huggingface_hub, its
exporters, ``evo``, torchvision); :func:`_reference_da3_api` loads it privately with
stand-ins for exactly those, and removes them again. The torchvision stand-in has only
``ToTensor`` and ``Normalize`` (their documented arithmetic: HWC uint8 -> CHW float / 255;
``(x - mean) / std`` with the mean and std the caller passes, here DA3's own). The
reference runs in float32: its ``forward`` autocasts to float16 on CPU, which only adds
rounding noise (measured: depth 2e-5, extrinsics 2e-3 with random weights).
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import sys
import types
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from graphseg.graphs.features import node_mean_features  # noqa: E402
from graphseg.io.precomputed import resize_nearest, scale_intrinsics  # noqa: E402
from graphseg.scene import Scene, View  # noqa: E402

IMAGENET_MEAN = (0.485, 0.456, 0.406)  # DINOv2's IMAGENET_DEFAULT_MEAN / DA3's InputProcessor
IMAGENET_STD = (0.229, 0.224, 0.225)


def _scene_rgb(shape, n, seed):
    """Smooth, asymmetric, colourful test images (a gradient per channel plus blobs)."""
    rng = np.random.default_rng(seed)
    h, w = shape
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    out = []
    for _ in range(n):
        img = np.stack([40 + 150 * x / w, 60 + 120 * y / h, 200 - 100 * (x + y) / (h + w)], -1)
        for _ in range(4):
            cy, cx, r = rng.uniform(0, h), rng.uniform(0, w), rng.uniform(3, 0.3 * min(h, w))
            img += np.exp(-((y - cy) ** 2 + (x - cx) ** 2) / (2 * r * r))[..., None] * rng.uniform(-80, 80, 3)
        out.append(np.clip(img, 0, 255).astype(np.uint8))
    return out


# ============================================================================ dinov2


@pytest.fixture(scope="module")
def dino(tmp_path_factory):
    """(graphseg's extractor from a checkpoint file, the reference model with the same weights)."""
    pytest.importorskip("einops")
    kd = pytest.importorskip("kornia.feature.dedode.transformer.dinov2")
    from graphseg.backends.matchers.romatch_compat import import_romatch
    from graphseg.backends.registry import features
    from graphseg.registry import MissingDependencyError

    try:
        import_romatch()
    except MissingDependencyError as err:
        pytest.skip(str(err))
    torch.manual_seed(0)
    ref = kd.vit_small(patch_size=14, img_size=518, init_values=1.0, block_chunks=0).eval()  # the hub's dinov2_vits14
    path = tmp_path_factory.mktemp("dino_ref") / "dinov2_vits14_pretrain.pth"
    torch.save(ref.state_dict(), path)  # the official checkpoint layout (graphseg loads it strictly)
    return features.resolve("dinov2", checkpoint=str(path), image_size=112), ref


def _reference_dino_tokens(ref, rgb):
    """The official preprocessing of an image already at a multiple of 14: ToTensor + Normalize; then ``forward_features``."""
    x = torch.from_numpy(np.ascontiguousarray(rgb.transpose(2, 0, 1))).float() / 255.0
    x = (x - torch.tensor(IMAGENET_MEAN)[:, None, None]) / torch.tensor(IMAGENET_STD)[:, None, None]
    with torch.no_grad():
        tok = ref.forward_features(x[None])["x_norm_patchtokens"][0]
    h, w = rgb.shape[0] // 14, rgb.shape[1] // 14
    return tok.numpy().reshape(h, w, -1)


def test_dinov2_features_match_the_reference_forward(dino):
    """84x112 needs no resize (so the reference input is only ToTensor + Normalize);
    150x250 is shrunk to 70x112 (graphseg's rule: area resize to the patch grid)."""
    import cv2

    fx, ref = dino
    for shape, grid in [((84, 112), (6, 8)), ((150, 250), (5, 8))]:
        rgb = _scene_rgb(shape, 1, seed=3)[0]
        out = fx(View("0", rgb))
        assert out.shape == (*grid, 384)
        net_in = rgb if shape == (grid[0] * 14, grid[1] * 14) else cv2.resize(rgb, (grid[1] * 14, grid[0] * 14), interpolation=cv2.INTER_AREA)
        expected = _reference_dino_tokens(ref, net_in)
        assert np.abs(out - expected).max() < 1e-4, (shape, np.abs(out - expected).max())


def test_dinov2_onnx_features_match_the_reference_forward(dino, tmp_path):
    """The ``.onnx`` path: the reference model exported at 84x112, run by graphseg through onnxruntime."""
    pytest.importorskip("onnxruntime")
    pytest.importorskip("onnx")
    from graphseg.backends.onnx_export import export_dinov2_onnx
    from graphseg.backends.registry import features

    ref = dino[1]
    rgb = _scene_rgb((84, 112), 1, seed=4)[0]
    onnx_path = export_dinov2_onnx(ref, tmp_path / "dinov2_vits14_ref.onnx", 84, 112)
    out = features.resolve("dinov2", checkpoint=str(onnx_path))(View("0", rgb))
    expected = _reference_dino_tokens(ref, rgb)
    assert out.shape == expected.shape == (6, 8, 384)
    assert np.abs(out - expected).max() < 1e-4, np.abs(out - expected).max()


@pytest.mark.parametrize(
    ("shape", "size", "markers"),
    [
        ((60, 100), 140, [(8, 83), (47, 12), (27, 55)]),  # enlarged (cubic) to 84x140: 6x10 cells
        ((150, 250), 112, [(20, 200), (130, 40), (75, 140)]),  # shrunk (area) to 70x112: 5x8 cells
    ],
)
def test_dinov2_marker_lands_in_its_feature_cell(dino, monkeypatch, shape, size, markers):
    """A 3x3 marker on a flat image changes its own patch's feature most; cell = floor((pixel + 0.5) * grid / image)."""
    fx = dino[0]
    monkeypatch.setattr(fx.options, "image_size", size)
    H, W = shape
    flat = np.full((H, W, 3), 90, np.uint8)
    f0 = fx(View("0", flat))
    h, w = f0.shape[:2]
    for y0, x0 in markers:
        img = flat.copy()
        img[y0 - 1 : y0 + 2, x0 - 1 : x0 + 2] = (250, 30, 200)
        f1 = fx(View("0", img))
        change = np.linalg.norm(f1 - f0, axis=-1)
        cell = (int((y0 + 0.5) * h / H), int((x0 + 0.5) * w / W))
        assert np.unravel_index(np.argmax(change), change.shape) == cell, (y0, x0)
        # back to pixels: the pixels of that cell (the marker among them) get its feature
        ys = ((np.arange(H) + 0.5) * h / H).astype(int)
        xs = ((np.arange(W) + 0.5) * w / W).astype(int)
        labels = np.where((ys[:, None] == cell[0]) & (xs[None, :] == cell[1]), 0, 1)
        assert (labels[y0 - 1 : y0 + 2, x0 - 1 : x0 + 2] == 0).all()
        assert np.allclose(node_mean_features([labels], [f1], 2)[0], f1[cell], atol=1e-6)


# ============================================================================ da3


class _Stub:
    """torchvision's ``ToTensor`` and ``Normalize`` (documented arithmetic), for DA3's InputProcessor."""

    class ToTensor:
        def __call__(self, pic):
            a = np.asarray(pic)
            return torch.from_numpy(np.ascontiguousarray(a.transpose(2, 0, 1))).float().div(255)

    class Normalize:
        def __init__(self, mean, std):
            self.mean, self.std = torch.tensor(mean), torch.tensor(std)

        def __call__(self, t):
            return (t - self.mean[:, None, None]) / self.std[:, None, None]

    class Unavailable:
        def __init__(self, *a, **k):
            raise RuntimeError("not provided by the test's stand-in")


def _reference_da3_api():
    """``depth_anything_3.api`` loaded privately (see the module docstring); sys.modules is left as it was."""
    tv = types.ModuleType("torchvision")
    tvt = types.ModuleType("torchvision.transforms")
    tvt.ToTensor, tvt.Normalize, tvt.CenterCrop = _Stub.ToTensor, _Stub.Normalize, _Stub.Unavailable
    tv.transforms = tvt
    hub = types.ModuleType("huggingface_hub")
    hub.PyTorchModelHubMixin = type("PyTorchModelHubMixin", (), {})
    export = types.ModuleType("depth_anything_3.utils.export")
    export.export = _Stub.Unavailable
    pose = types.ModuleType("depth_anything_3.utils.pose_align")
    pose.align_poses_umeyama = _Stub.Unavailable
    stubs = {"torchvision": tv, "torchvision.transforms": tvt, "huggingface_hub": hub, export.__name__: export, pose.__name__: pose}
    private = "depth_anything_3.utils.io.input_processor"  # imports torchvision
    saved = {k: sys.modules[k] for k in [*stubs, private] if k in sys.modules}
    sys.modules.update(stubs)
    sys.modules.pop(private, None)
    try:
        spec = importlib.util.spec_from_file_location("_graphseg_test_da3_api", Path(importlib.util.find_spec("depth_anything_3.registry").origin).parent / "api.py")
        api = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(api)
    finally:
        for k in [*stubs, private]:
            sys.modules.pop(k, None)
        sys.modules.update(saved)
        pkg = sys.modules.get("depth_anything_3.utils.io")
        if pkg is not None and private not in saved and hasattr(pkg, "input_processor"):
            delattr(pkg, "input_processor")

    class Float32Torch(types.ModuleType):  # DepthAnything3.forward autocasts; run it in float32 like graphseg
        def __getattr__(self, name):
            return getattr(torch, name)

    t32 = Float32Torch("torch")
    t32.autocast = lambda device_type, dtype=None, **kw: torch.autocast(device_type, dtype=dtype, enabled=False)
    api.torch = t32
    return api


@pytest.fixture(scope="module")
def da3(tmp_path_factory):
    """The reference ``DepthAnything3`` (random weights) and a graphseg lifter from its state dict saved to a file."""
    pytest.importorskip("depth_anything_3")
    for mod in ("addict", "einops", "omegaconf", "PIL"):
        pytest.importorskip(mod)
    from graphseg.backends.lifters.da3 import DA3Lifter

    api = _reference_da3_api()
    torch.manual_seed(0)
    with contextlib.redirect_stdout(io.StringIO()):
        ref = api.DepthAnything3(model_name="da3-small")
    path = tmp_path_factory.mktemp("da3_ref") / "model.pt"
    torch.save(ref.state_dict(), path)  # keys "model.*", as the Hub's model.safetensors
    lifter = DA3Lifter(checkpoint=str(path), size=70, scale="none")
    assert "torchvision" not in sys.modules or getattr(sys.modules["torchvision"], "__file__", None)
    return ref, lifter


@pytest.fixture(scope="module")
def da3_runs(da3):
    """Both pipelines on three 90x160 views (16:9; DA3 resizes to 39x70 (area) then 42x70 (cubic))."""
    ref, lifter = da3
    rgbs = _scene_rgb((90, 160), 3, seed=5)
    with contextlib.redirect_stdout(io.StringIO()):
        ref_in = ref.input_processor(rgbs, None, None, 70, "upper_bound_resize")[0]
        pred = ref.inference(rgbs, process_res=70)
    seen = []
    net = lifter.net

    class Recorder(torch.nn.Module):
        def forward(self, x, **kw):
            seen.append(x.clone())
            return net(x, **kw)

    lifter.net = Recorder()
    try:
        out = lifter(Scene([View(f"{k}", r) for k, r in enumerate(rgbs)]))
    finally:
        lifter.net = net
    return rgbs, ref_in, pred, seen[0][0], out


def test_da3_input_is_the_reference_preprocessing(da3_runs):
    """Same model input as DA3's InputProcessor: size 42x70, RGB order, ImageNet mean/std, both resizes."""
    _, ref_in, _, ours, _ = da3_runs
    assert tuple(ours.shape) == tuple(ref_in.shape) == (3, 3, 42, 70)
    assert torch.abs(ours - ref_in).max().item() < 1e-6


def test_da3_outputs_match_reference_inference(da3, da3_runs):
    """Depth, confidence, extrinsics (w2c) and intrinsics as ``DepthAnything3.inference`` returns them."""
    lifter = da3[1]
    rgbs, _, pred, _, _ = da3_runs
    raw = lifter.predict(rgbs, (42, 70))
    for key, ref in [("depth", pred.depth), ("conf", pred.conf), ("extrinsics", pred.extrinsics[:, :3]), ("intrinsics", pred.intrinsics)]:
        assert raw[key].shape == ref.shape, key
        np.testing.assert_allclose(raw[key], ref, rtol=1e-4, atol=1e-5, err_msg=key)


def _reference_world_points(depth, K, w2c):
    """DA3's own back-projection: ``unproject_depth`` with ``c2w = affine_inverse(w2c)``; [N, h, w, 3]."""
    from depth_anything_3.utils.geometry import affine_inverse, unproject_depth

    E = torch.eye(4, dtype=torch.float64).repeat(len(w2c), 1, 1)
    E[:, :3] = torch.as_tensor(np.asarray(w2c)[:, :3], dtype=torch.float64)
    pts = unproject_depth(torch.as_tensor(depth, dtype=torch.float64)[None, ..., None], torch.as_tensor(K, dtype=torch.float64)[None], affine_inverse(E)[None])
    return pts[0].numpy(), affine_inverse(E).numpy()


def test_da3_world_points_and_cameras_match_reference(da3_runs):
    """Per view: cam_to_world = inverse of the reference's w2c; points = the reference back-projection, resized nearest to the image."""
    _, _, pred, _, out = da3_runs
    pts, c2w = _reference_world_points(pred.depth, pred.intrinsics, pred.extrinsics)
    scale = np.abs(pts).max()
    for k, v in enumerate(out.views):
        np.testing.assert_allclose(v.cam_to_world, c2w[k], atol=1e-5)
        np.testing.assert_allclose(v.K, scale_intrinsics(pred.intrinsics[k], (42, 70), (90, 160)), rtol=1e-6)
        assert np.abs(v.points - resize_nearest(pts[k], (90, 160))).max() < 1e-5 * scale, k


class _FakeDA3(torch.nn.Module):
    """Stands in for the network: depth = 2 + the red channel of its input; sensible K, a different camera per view."""

    def __init__(self):
        super().__init__()
        self.w2c = []

    def forward(self, x, **kw):
        b, n, _, h, w = x.shape
        depth = 2.0 + x[:, :, 0]
        K = torch.tensor([[1.2 * w, 0, (w - 1) / 2 + 0.7], [0, 1.2 * w, (h - 1) / 2 - 0.4], [0, 0, 1]], dtype=torch.float32)
        exts = []
        for k in range(n):
            a = 0.3 + 0.4 * k
            R = torch.tensor([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]], dtype=torch.float32)
            exts.append(torch.cat([R, torch.tensor([[0.1 * k], [-0.2], [0.5 + k]])], 1))
        self.w2c = torch.stack(exts)
        return {"depth": depth, "depth_conf": torch.ones_like(depth), "extrinsics": self.w2c[None], "intrinsics": K.expand(b, n, 3, 3)}


@pytest.mark.parametrize(("shape", "size"), [((90, 160), 70), ((50, 36), 70)])
def test_da3_marker_comes_back_at_its_pixel(da3, monkeypatch, shape, size):
    """A one-pixel red marker per view (different places) is the deepest point of its own view's point map,
    and the point maps equal DA3's back-projection of the (fake) network output with each view's own camera."""
    lifter = da3[1]
    fake = _FakeDA3()
    monkeypatch.setattr(lifter, "net", fake)
    monkeypatch.setattr(lifter.options, "size", size)
    H, W = shape
    markers = [(int(0.2 * H), int(0.8 * W)), (int(0.75 * H), int(0.15 * W)), (int(0.55 * H) + 1, int(0.4 * W) + 2)]
    rgbs = []
    for y0, x0 in markers:
        img = np.full((H, W, 3), 40, np.uint8)
        img[y0, x0] = (255, 40, 40)
        rgbs.append(img)
    out = lifter(Scene([View(f"{k}", r) for k, r in enumerate(rgbs)]))
    from graphseg.backends.lifters.da3 import model_size_14

    hw = model_size_14(shape, size)
    for k, (v, (y0, x0)) in enumerate(zip(out.views, markers)):
        T = np.linalg.inv(v.cam_to_world)
        z = v.points @ T[:3, :3].T[:, 2] + T[2, 3]  # camera-frame depth
        assert z[y0, x0] == pytest.approx(z.max(), abs=1e-6), (k, np.unravel_index(np.argmax(z), z.shape), (y0, x0))
        # each image pixel's point projects back (image K) to within half a model pixel of that pixel
        cam = v.points @ T[:3, :3].T + T[:3, 3]
        uv = cam @ v.K.T
        uv = uv[..., :2] / uv[..., 2:]
        grid = np.stack(np.meshgrid(np.arange(W), np.arange(H)), -1)
        half = 0.5 * np.array([W / hw[1], H / hw[0]])
        assert (np.abs(uv - grid) <= half + 1e-3).all(), k
    # against DA3's own back-projection of the same outputs (each view with its own camera)
    raw = lifter.predict(rgbs, hw)
    pts, c2w = _reference_world_points(raw["depth"], raw["intrinsics"], fake.w2c.numpy())
    for k, v in enumerate(out.views):
        np.testing.assert_allclose(v.cam_to_world, c2w[k], atol=1e-6)
        assert np.abs(v.points - resize_nearest(pts[k], shape)).max() < 1e-5, k
