"""The dust3r lifter on a tiny stand-in ONNX pair.

The stand-in is NOT DUSt3R: a random-weight torch model with DUSt3R's encoder /
decoder I/O (patch features + positions in, per-pixel pts3d + conf for both
views out), exported to ONNX by the test. It checks the plumbing (ONNX I/O,
pairwise inference, global alignment, metric scale, CLI), not the geometry,
which tests/backends/test_align.py checks on ground truth.
"""

import warnings

import numpy as np
import pytest
import yaml

torch = pytest.importorskip("torch")
pytest.importorskip("onnxruntime")
pytest.importorskip("onnx")

from graphseg.backends.lifters.dust3r import DUSt3RLifter, model_size  # noqa: E402
from graphseg.cli import main  # noqa: E402
from graphseg.io.images import write_rgb  # noqa: E402
from graphseg.scene import Scene, SceneError, View  # noqa: E402
from graphseg.testing.scenes import TWO_BOXES, box_scene  # noqa: E402

P, D = 16, 32


class Encoder(torch.nn.Module):
    def __init__(self):
        super().__init__()
        self.embed = torch.nn.Conv2d(3, D, P, stride=P)

    def forward(self, image):
        f = self.embed(image)  # [1, D, h/P, w/P]
        h, w = f.shape[2], f.shape[3]
        ys, xs = torch.meshgrid(torch.arange(h), torch.arange(w), indexing="ij")
        pos = torch.stack([ys.reshape(-1), xs.reshape(-1)], -1)[None].to(torch.int64)
        return f.flatten(2).transpose(1, 2), pos


class Decoder(torch.nn.Module):
    def __init__(self, hw):
        super().__init__()
        self.hw = hw
        self.pos = torch.nn.Linear(2, D)
        self.head1 = torch.nn.Linear(2 * D, P * P * 4)
        self.head2 = torch.nn.Linear(2 * D, P * P * 4)

    def _head(self, head, x):
        h, w = self.hw[0] // P, self.hw[1] // P
        y = head(x).reshape(1, h, w, P, P, 4).permute(0, 1, 3, 2, 4, 5).reshape(1, h * P, w * P, 4)
        xy, z, c = y[..., :2], torch.exp(0.1 * y[..., 2:3]), y[..., 3]
        return torch.cat([xy * 0.1 * z, z], -1), 1 + torch.exp(0.1 * c)

    def forward(self, features1, pos1, features2, pos2):
        a = features1 + self.pos(pos1.float())
        b = features2 + self.pos(pos2.float())
        x1 = torch.cat([a, b.mean(1, keepdim=True).expand_as(a)], -1)
        x2 = torch.cat([b, a.mean(1, keepdim=True).expand_as(b)], -1)
        p1, c1 = self._head(self.head1, x1)
        p2, c2 = self._head(self.head2, x2)
        return p1, c1, p2, c2


@pytest.fixture(scope="module")
def onnx_pair(tmp_path_factory):
    d = tmp_path_factory.mktemp("dust3r")
    hw = model_size((48, 64), 80, P)
    torch.manual_seed(0)
    enc, dec = Encoder().eval(), Decoder(hw).eval()
    img = torch.zeros(1, 3, *hw)
    with torch.no_grad(), warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # the legacy (TorchScript) exporter
        f, pos = enc(img)
        torch.onnx.export(enc, (img,), d / "encoder.onnx", input_names=["image"], output_names=["features", "pos"], dynamo=False)
        torch.onnx.export(dec, (f, pos, f, pos), d / "decoder.onnx", input_names=["features1", "pos1", "features2", "pos2"], output_names=["pts3d1", "conf1", "pts3d2", "conf2"], dynamo=False)
    return d


def rgb_scene(n=3):
    s = box_scene(TWO_BOXES, views=n, shape=(48, 64))
    return s, Scene([View(v.name, v.rgb) for v in s.views], name="rgb")


def test_lifter_shapes_and_nominal_scale(onnx_pair):
    _, scene = rgb_scene()
    lifter = DUSt3RLifter(encoder=str(onnx_pair / "encoder.onnx"), iterations=2)
    assert lifter.fixed_hw == (48, 80)  # DUSt3R's load_images: 48x64 -> 60x80 -> centre crop to 48x80 from row 6
    out = lifter(scene)
    assert out.meta["lifter"] == "dust3r" and out.meta["scale"]["method"] == "nominal-distance" and not out.meta["scale"]["metric"]
    for v in out.views:
        assert v.points.shape == (48, 64, 3) and v.confidence.shape == (48, 64) and v.K.shape == (3, 3)
        valid = np.isfinite(v.points).all(-1)
        assert valid[5:43].all() and not valid[:5].any() and not valid[43:].any()  # the rows the crop cut off are invalid
        assert (v.confidence[valid] >= 1).all() and (v.confidence[~valid] == 0).all()
        v.validate()


def test_known_poses_make_the_scale_metric(onnx_pair):
    truth, rgb = rgb_scene()
    with_poses = Scene([v.replace(cam_to_world=t.cam_to_world) for v, t in zip(rgb.views, truth.views)])
    out = DUSt3RLifter(encoder=str(onnx_pair / "encoder.onnx"), iterations=1)(with_poses)
    assert out.meta["scale"]["metric"] and out.meta["scale"]["method"].startswith("known-poses-")  # random weights: any centres


def test_errors_name_the_option_and_the_extra(onnx_pair, tmp_path):
    with pytest.raises(SceneError, match=r"dust3r: encoder: no checkpoint given; set --backend-option dust3r.encoder=PATH.*graphseg\[dust3r\]"):
        DUSt3RLifter()
    with pytest.raises(SceneError, match=r"nope.onnx: encoder: no such file"):
        DUSt3RLifter(encoder=str(tmp_path / "nope.onnx"))
    with pytest.raises(SceneError, match=r"encoder.onnx: features: no output 'feats'.*names.features"):
        DUSt3RLifter(encoder=str(onnx_pair / "encoder.onnx"), names={"features": "feats"})
    with pytest.raises(SceneError, match="unknown roles"):
        DUSt3RLifter(encoder=str(onnx_pair / "encoder.onnx"), names={"bogus": "x"})
    with pytest.raises(SceneError, match=r"^backends.options.dust3r.no_such_option: unknown option 'no_such_option'; valid keys: encoder, "):
        DUSt3RLifter(encoder=str(onnx_pair / "encoder.onnx"), no_such_option=1)
    with pytest.raises(SceneError, match=r"backends.options.dust3r.iterations: .*greater than or equal to 0 \(got -1\)"):
        DUSt3RLifter(encoder=str(onnx_pair / "encoder.onnx"), iterations=-1)


def test_cli_runs_an_rgb_only_scene_end_to_end(onnx_pair, tmp_path, capsys):
    _, scene = rgb_scene()
    img = tmp_path / "images"
    img.mkdir()
    for v in scene.views:
        write_rgb(img / f"{v.name}.png", v.rgb)
    cfg = tmp_path / "cfg.yaml"
    cfg.write_text(yaml.safe_dump({"backends": {"options": {"dust3r": {"encoder": str(onnx_pair / "encoder.onnx"), "iterations": 1}}}}))
    code = main([str(a) for a in ["run", img, "-o", tmp_path / "out", "--config", cfg, "--lifter", "dust3r", "--segmenter", "superpixel", "--quiet"]])
    assert code == 0, capsys.readouterr().err
    for name in ("result.npz", "report.html", "run.json", "config.yaml"):
        assert (tmp_path / "out" / name).exists()
    assert main([str(a) for a in ["run", img, "-o", tmp_path / "out2", "--lifter", "dust3r", "--quiet"]]) == 2
    assert "dust3r.encoder=PATH" in capsys.readouterr().err


def test_missing_onnxruntime_names_the_extra_and_the_option(onnx_pair, monkeypatch):
    import sys

    from graphseg.registry import MissingDependencyError

    monkeypatch.setitem(sys.modules, "onnxruntime", None)
    with pytest.raises(MissingDependencyError, match=r'graphseg\[dust3r\].*dust3r.encoder=PATH'):
        DUSt3RLifter(encoder=str(onnx_pair / "encoder.onnx"))
