"""The ``dust3r`` lifter against a torch re-implementation of DUSt3R (issue 22).

DUSt3R is not on PyPI and its weights cannot be downloaded here, so the reference is
``tests/backends/_dust3r_reference.py``: graphseg's own compact re-implementation of the
published architecture and input pipeline (naver/dust3r 4c24a6e, naver/croco d7de070;
read for facts, no code copied), at a tiny size with seeded random weights, exported to
ONNX with docs/models.md's recipe. Proven here, on odd-sized non-square images:

* the ONNX pair run by graphseg (``DUSt3RLifter.predict_pair``) gives the torch model's
  ``pts3d``, ``conf``, ``pts3d_in_other_view`` and view 2's ``conf`` (1e-4);
* graphseg's preprocessing is ``load_images`` + ``ImgNorm`` exactly (resize rule, Pillow
  filters, centre crop, RGB, ``[-1, 1]``, ``true_shape``), read from the same PNG files;
* a marker at a known pixel comes back at that pixel of the final world point map after
  the resize, the crop and the way back, and the pixels the crop cut off are invalid.

Not proven: that the re-implementation equals DUSt3R's own code on real weights (it has
DUSt3R's linear head, not the DPT head of the 512 checkpoints), or anything about the
global alignment beyond the marker (tests/backends/test_align.py checks it on ground truth).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("onnxruntime")
pytest.importorskip("onnx")
pytest.importorskip("PIL")

from graphseg.backends.lifters.dust3r import DUSt3RLifter, input_geometry, preprocess  # noqa: E402
from graphseg.io.images import read_rgb, write_rgb  # noqa: E402
from graphseg.scene import Scene, View  # noqa: E402
from tests.backends._dust3r_reference import (  # noqa: E402
    PATCH,
    TinyDUSt3R,
    export_dust3r_onnx,
    load_image_reference,
)

TOL = 1e-4  # pts3d / conf, ONNX through graphseg vs the torch model (measured max 7.2e-6)


@pytest.fixture(scope="module", autouse=True)
def _one_thread():
    """One intra-op thread: tiny models run faster than with OpenMP threads on a busy 2-core machine."""
    n = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(n)


def _images(shape, n, seed):
    """Smooth, asymmetric, colourful uint8 images (a gradient per channel plus blobs)."""
    rng = np.random.default_rng(seed)
    h, w = shape
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    out = []
    for _ in range(n):
        img = np.stack([30 + 180 * x / w, 50 + 150 * y / h, 220 - 120 * (x + y) / (h + w)], -1)
        for _ in range(5):
            cy, cx, r = rng.uniform(0, h), rng.uniform(0, w), rng.uniform(2, 0.3 * min(h, w))
            img += np.exp(-((y - cy) ** 2 + (x - cx) ** 2) / (2 * r * r))[..., None] * rng.uniform(-90, 90, 3)
        out.append(np.clip(img, 0, 255).astype(np.uint8))
    return out


# ============================================================================ (b) preprocessing

CASES = [  # (image shape, size, square_ok): what the reference gives is asserted in the test
    ((83, 101), 64, False),  # shrink (Lanczos), 53 rows cropped to 48
    ((37, 53), 64, False),  # enlarge (bicubic), 45 rows cropped to 32
    ((101, 83), 64, False),  # portrait: 53 columns cropped to 48
    ((50, 50), 64, False),  # square: cropped to 4:3
    ((50, 50), 64, True),  # square kept
    ((333, 500), 512, False),  # a real size: 341 rows cropped to 336 from row 2
    ((150, 211), 224, False),  # the 224 models' rule: short side to 224, centre square
]


@pytest.mark.parametrize(("shape", "size", "square_ok"), CASES)
def test_preprocessing_is_load_images(tmp_path, shape, size, square_ok):
    """Same PNG file: graphseg (read_rgb + input_geometry + preprocess) == the reference load_images, bit for bit."""
    path = tmp_path / "img.png"
    write_rgb(path, _images(shape, 1, seed=sum(shape))[0])
    ref = load_image_reference(path, size, square_ok=square_ok)
    g = input_geometry(shape, size, PATCH, square_ok=square_ok)
    x0, y0, x1, y1 = ref["box"]
    assert g.resized == ref["resized"] and (g.top, g.left) == (y0, x0) and g.hw == (y1 - y0, x1 - x0)
    assert g.hw == tuple(ref["true_shape"][0]) and all(s % PATCH == 0 for s in g.hw)
    got = preprocess(read_rgb(path), g)
    want = ref["img"].numpy()
    assert got.dtype == np.float32 and got.shape == want.shape
    assert np.abs(got - want).max() == 0.0, np.abs(got - want).max()
    # a fixed model input of that size gets the same geometry
    assert input_geometry(shape, size, PATCH, fixed=g.hw, square_ok=square_ok) == g


def test_geometry_by_hand_and_edge_cases():
    """Hand-computed: 500x333 -> 512x341 (round(333 * 512 / 500) = 341), 2 (341 // 2) = 340 -> 336 rows from row 170 - 168 = 2."""
    g = input_geometry((333, 500), 512)
    assert (g.resized, g.top, g.left, g.hw) == ((341, 512), 2, 0, (336, 512))
    assert input_geometry((512, 512), 512).hw == (384, 512) and input_geometry((512, 512), 512, square_ok=True).hw == (512, 512)
    # a fixed input of another aspect: cover (scale max(64/48, 80/64) = 4/3 -> 64x85), centre crop columns 2..82
    g = input_geometry((48, 64), 512, fixed=(64, 80))
    assert (g.resized, g.top, g.left, g.hw) == ((64, 85), 0, 2, (64, 80))
    with pytest.raises(ValueError, match="too small"):
        input_geometry((5, 3), 16, 16)
    with pytest.raises(ValueError, match=r"expected an image of \[4, 4\]"):
        preprocess(np.zeros((5, 4, 3), np.uint8), input_geometry((4, 4), 16, 4))


# ============================================================================ (a) the ONNX pair against the torch model


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    """(torch reference model, graphseg lifter on its ONNX export at 48x64 = load_images' input for 83x101 at 64)."""
    model = TinyDUSt3R(seed=0)
    enc = export_dust3r_onnx(model, (48, 64), tmp_path_factory.mktemp("dust3r_ref"))
    return model, DUSt3RLifter(encoder=str(enc), threads=1)


def test_onnx_pair_matches_the_torch_model(tiny, tmp_path):
    """Both orders of an 83x101 pair: graphseg's pair inference == the reference model on load_images' tensors."""
    model, lifter = tiny
    assert lifter.fixed_hw == (48, 64)
    rgbs = _images((83, 101), 2, seed=5)
    paths = [tmp_path / f"{k}.png" for k in range(2)]
    for p, rgb in zip(paths, rgbs):
        write_rgb(p, rgb)
    refs = [load_image_reference(p, 64)["img"] for p in paths]
    worst = 0.0
    for a, b in ((0, 1), (1, 0)):
        got = lifter.predict_pair(read_rgb(paths[a]), read_rgb(paths[b]))
        assert (got["geometry"].top, got["geometry"].hw) == (2, (48, 64))
        want = model(refs[a], refs[b])
        for key, ref_key in (("pts3d1", "pts3d"), ("conf1", "conf"), ("pts3d2", "pts3d_in_other_view"), ("conf2", "conf2")):
            w = want[ref_key][0].numpy()
            assert got[key].shape == w.shape, key
            err = float(np.abs(got[key] - w).max())
            worst = max(worst, err)
            assert err < TOL, (key, (a, b), err)
        assert (got["conf1"] >= 1).all() and (got["conf2"] >= 1).all()
    # the pair is asymmetric: swapping the views changes view 1's map (so a view mix-up cannot pass)
    p01, p10 = lifter.predict_pair(rgbs[0], rgbs[1]), lifter.predict_pair(rgbs[1], rgbs[0])
    assert np.abs(p01["pts3d1"] - p10["pts3d2"]).max() > 100 * TOL
    assert worst < TOL


def test_dynamic_encoder_uses_the_size_rule(tmp_path):
    """An encoder with dynamic H, W: graphseg sizes the input by ``size`` (load_images' rule); the decoder is
    fixed at that rule's 64x48 for a portrait 101x83 image, so any other size fails to decode."""
    model = TinyDUSt3R(seed=1)
    enc = export_dust3r_onnx(model, (64, 48), tmp_path, dynamic_encoder=True)
    lifter = DUSt3RLifter(encoder=str(enc), size=64, threads=1)
    assert lifter.fixed_hw is None
    rgbs = _images((101, 83), 2, seed=9)
    got = lifter.predict_pair(rgbs[0], rgbs[1])
    ref = [load_image_reference(r, 64)["img"] for r in rgbs]
    want = model(ref[0], ref[1])
    assert np.abs(got["pts3d1"] - want["pts3d"][0].numpy()).max() < TOL
    assert np.abs(got["pts3d2"] - want["pts3d_in_other_view"][0].numpy()).max() < TOL


# ============================================================================ (c) pixel convention


class _MarkerEncoder(torch.nn.Module):
    """Features = the image's 16x16 patches, unchanged (an identity convolution); DUSt3R's positions."""

    def __init__(self):
        super().__init__()
        self.conv = torch.nn.Conv2d(3, 3 * PATCH * PATCH, PATCH, stride=PATCH, bias=False)
        with torch.no_grad():
            self.conv.weight.zero_()
            for c in range(3):
                for i in range(PATCH):
                    for j in range(PATCH):
                        self.conv.weight[c * PATCH * PATCH + i * PATCH + j, c, i, j] = 1.0

    def forward(self, image):
        x = self.conv(image)
        h, w = x.shape[2], x.shape[3]
        ys, xs = torch.meshgrid(torch.arange(h), torch.arange(w), indexing="ij")
        return x.flatten(2).transpose(1, 2), torch.stack([ys.reshape(-1), xs.reshape(-1)], -1)[None].to(torch.int64)


class _MarkerDecoder(torch.nn.Module):
    """Each view's point at model pixel (u, v): (u, v, 2 + red) in one shared frame (identical cameras); conf 2."""

    def __init__(self, hw):
        super().__init__()
        self.hw = hw
        v, u = torch.meshgrid(torch.arange(hw[0], dtype=torch.float32), torch.arange(hw[1], dtype=torch.float32), indexing="ij")
        self.register_buffer("uv", torch.stack([u, v], -1)[None])

    def _points(self, f):
        img = torch.nn.functional.pixel_shuffle(f.transpose(1, 2).reshape(1, -1, self.hw[0] // PATCH, self.hw[1] // PATCH), PATCH)
        return torch.cat([self.uv, 2.0 + img[:, 0, :, :, None]], -1), torch.full((1, *self.hw), 2.0)

    def forward(self, features1, pos1, features2, pos2):
        p1, c1 = self._points(features1)
        p2, c2 = self._points(features2)
        return p1, c1, p2, c2


def _marker_lifter(tmp_path, hw, size):
    with torch.no_grad(), warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the legacy exporter's deprecation and tracer warnings
        img = torch.zeros(1, 3, *hw)
        f, p = _MarkerEncoder()(img)
        torch.onnx.export(_MarkerEncoder(), (img,), tmp_path / "encoder.onnx", input_names=["image"], output_names=["features", "pos"], dynamic_axes={"image": {2: "h", 3: "w"}}, dynamo=False)
        torch.onnx.export(_MarkerDecoder(hw), (f, p, f, p), tmp_path / "decoder.onnx", input_names=["features1", "pos1", "features2", "pos2"], output_names=["pts3d1", "conf1", "pts3d2", "conf2"], dynamo=False)
    return DUSt3RLifter(encoder=str(tmp_path / "encoder.onnx"), size=size, scale="none", iterations=2, threads=1)


MARKER_CASES = [  # (image shape, size, model input the reference gives, a marker per view)
    ((83, 101), 64, (48, 64), [(20, 77), (61, 14)]),  # shrink, rows cropped
    ((37, 53), 64, (32, 64), [(12, 40), (25, 7)]),  # enlarge, rows cropped
    ((101, 83), 64, (64, 48), [(70, 30), (15, 60)]),  # portrait, columns cropped
    ((50, 50), 64, (48, 64), [(18, 33), (30, 9)]),  # square, cropped to 4:3
]


@pytest.mark.parametrize(("shape", "size", "hw", "markers"), MARKER_CASES)
def test_marker_comes_back_at_its_pixel(tmp_path, shape, size, hw, markers):
    """A one-pixel red marker per view (different places): its pixel holds the highest point of its own view's
    final world map, every pixel's point carries a model pixel within half a model pixel of it, and exactly
    the pixels the reference crop cuts off are invalid."""
    H, W = shape
    rgbs = []
    for y0, x0 in markers:
        img = np.full((H, W, 3), 40, np.uint8)
        img[y0, x0] = (255, 40, 40)
        rgbs.append(img)
    ref = load_image_reference(rgbs[0], size)
    (bx0, by0, bx1, by1), (Hr, Wr) = ref["box"], ref["resized"]
    assert (by1 - by0, bx1 - bx0) == hw
    out = _marker_lifter(tmp_path, hw, size)(Scene([View(f"{k}", r) for k, r in enumerate(rgbs)]))
    # where each image pixel's centre falls in the model input, by the reference's resize and crop
    my = (np.arange(H) + 0.5) * Hr / H - by0
    mx = (np.arange(W) + 0.5) * Wr / W - bx0
    inside = ((my >= 0) & (my < hw[0]))[:, None] & ((mx >= 0) & (mx < hw[1]))[None, :]
    assert (~inside).any()  # every case crops something
    for k, (v, (y0, x0)) in enumerate(zip(out.views, markers)):
        pts = v.points
        # K's principal point: the model input's centre, through the crop offset and the resize
        assert v.K[0, 2] == pytest.approx(((hw[1] - 1) / 2 + bx0 + 0.5) * W / Wr - 0.5) and v.K[1, 2] == pytest.approx(((hw[0] - 1) / 2 + by0 + 0.5) * H / Hr - 0.5)
        assert (np.isfinite(pts).all(-1) == inside).all(), k
        assert (v.confidence[~inside] == 0).all() and (v.confidence[inside] == 2).all(), k
        z = np.where(inside, pts[..., 2], -np.inf)
        assert z[y0, x0] == pytest.approx(z.max(), abs=1e-5), (k, np.unravel_index(np.argmax(z), z.shape), (y0, x0))
        assert z.max() > np.median(z[inside]) + 0.2  # the marker stands out (a shrunk one-pixel marker: +0.37)
        top = np.argwhere(z >= z.max() - 1e-5)  # the pixels sharing the marker's model pixel
        assert (np.abs(top - [y0, x0]) <= np.ceil([H / Hr, W / Wr])).all(), (k, top)
        # the point's model pixel (u, v) is within half a model pixel of the image pixel's centre
        assert np.abs(pts[..., 0][inside] - np.broadcast_to(mx[None, :], (H, W))[inside] + 0.5).max() <= 0.5 + 1e-4
        assert np.abs(pts[..., 1][inside] - np.broadcast_to(my[:, None], (H, W))[inside] + 0.5).max() <= 0.5 + 1e-4
