"""Dense DINOv2 features for the ``dino`` criterion: feature extractor ``dinov2``.

From the user's DINOv2 weights, either an official PyTorch checkpoint
(``dinov2_vits14_pretrain.pth`` ... ``dinov2_vitg14_pretrain.pth``, run with the
DINOv2 model code vendored in ``romatch``) or an ONNX export run with
onnxruntime. The image is resized so its longer side is about ``image_size``
with both sides multiples of 14, normalised with ImageNet statistics, and the
last layer's normalised patch tokens are returned as a grid ``[h, w, D]``
(``h, w`` = image size / 14), like the ``color`` extractor's output.

Examples
--------
>>> dinov2_arch("dinov2_vitb14_pretrain.pth")
'vitb14'
>>> patch_grid((480, 640), 448)
(336, 448)
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from ...scene import SceneError, View
from ..imaging import IMAGENET_MEAN, IMAGENET_STD, view_rgb
from ..options import ModelBackend, checkpoint_path, require_backend

__all__ = ["DINOv2Features", "dinov2_arch", "patch_grid", "build_dinov2"]

_ARCHS = {"vits14": ("vit_small", 384), "vitb14": ("vit_base", 768), "vitl14": ("vit_large", 1024), "vitg14": ("vit_giant2", 1536)}


def dinov2_arch(name: str | Path) -> str:
    """The DINOv2 architecture (``vits14``, ``vitb14``, ``vitl14``, ``vitg14``) named in a file name.

    Raises
    ------
    ValueError
        If the name does not contain one of them.
    """
    m = re.search(r"vit([sblg])14", Path(str(name)).name.lower())
    if m is None:
        raise ValueError(f"cannot tell the DINOv2 architecture from {Path(str(name)).name!r}; set arch to one of {', '.join(_ARCHS)}")
    return f"vit{m.group(1)}14"


def patch_grid(shape: tuple[int, int], image_size: int, patch: int = 14) -> tuple[int, int]:
    """Network input size ``(H', W')``: longer side ~ ``image_size``, both multiples of ``patch`` (>= 1 patch).

    Examples
    --------
    >>> patch_grid((100, 100), 50)  # 50 / 14 = 3.6 patches -> 4
    (56, 56)
    """
    h, w = shape
    k = image_size / max(h, w)
    return max(patch, int(round(h * k / patch)) * patch), max(patch, int(round(w * k / patch)) * patch)


def build_dinov2(arch: str) -> Any:
    """DINOv2 ``arch`` with random weights, as the official hub builds it (no register tokens)."""
    from ..matchers.romatch_compat import import_romatch

    import_romatch()
    from romatch.models.transformer import dinov2 as D

    fn, _ = _ARCHS[arch]
    return getattr(D, fn)(img_size=518, patch_size=14, init_values=1.0, ffn_layer="swiglufused" if arch == "vitg14" else "mlp", block_chunks=0)


class DINOv2Features(ModelBackend):
    """The ``dinov2`` feature extractor: patch features ``[h, w, D]`` from a user DINOv2 checkpoint.

    Options: ``checkpoint`` (required; ``.pth`` state dict or ``.onnx``),
    ``arch`` (``vits14`` ... ``vitg14``, inferred from the file name; torch only),
    ``image_size`` (longer side, 448), ``normalize`` (L2-normalise each feature),
    ``onnx_input`` / ``onnx_output`` (names; default the first), ``device``.

    An ONNX export must take ``[1, 3, H', W']`` and return either tokens
    ``[1, T, D]`` (leading CLS/register tokens are dropped: the last ``h * w``
    are the patches) or a map ``[1, D, h, w]``.
    """

    name = "dinov2"
    extra = "dinov2"

    class Options(BaseModel):
        model_config = ConfigDict(extra="forbid")
        checkpoint: str | None = None
        arch: str | None = Field(None, pattern="^vit[sblg]14$")
        image_size: int = Field(448, ge=14)
        normalize: bool = False
        onnx_input: str | None = None
        onnx_output: str | None = None
        device: str = "cpu"
        providers: list[str] = Field(default_factory=lambda: ["CPUExecutionProvider"])

    def __init__(self, options: Any = None, /, **kwargs: Any) -> None:
        super().__init__(options, **kwargs)
        o = self.options
        self.onnx = str(o.checkpoint or "").lower().endswith(".onnx")
        field = "backends.options.dinov2"
        if self.onnx:
            ort = require_backend("onnxruntime", "dinov2", "onnx")
            path = checkpoint_path(o.checkpoint, "dinov2", "onnx")
            try:
                self.session = ort.InferenceSession(str(path), providers=list(o.providers))
            except Exception as err:
                raise SceneError(f"cannot load the ONNX model ({type(err).__name__})", where=str(path), field=f"{field}.checkpoint") from None
            ins = [i.name for i in self.session.get_inputs()]
            outs = [i.name for i in self.session.get_outputs()]
            self.input_name = o.onnx_input or ins[0]
            self.output_name = o.onnx_output or outs[0]
            if self.input_name not in ins:
                raise SceneError(f"model has no input {self.input_name!r}; its inputs: {', '.join(ins)}", where=str(path), field=f"{field}.onnx_input")
            if self.output_name not in outs:
                raise SceneError(f"model has no output {self.output_name!r}; its outputs: {', '.join(outs)}", where=str(path), field=f"{field}.onnx_output")
            shape = next(i.shape for i in self.session.get_inputs() if i.name == self.input_name)
            self.fixed = tuple(shape[-2:]) if all(isinstance(d, int) for d in shape[-2:]) else None
            return
        require_backend("torch", "dinov2", "dinov2")
        path = checkpoint_path(o.checkpoint, "dinov2", "dinov2")
        try:
            self.arch = o.arch or dinov2_arch(path)
        except ValueError as err:
            raise SceneError(str(err), field=f"{field}.arch") from None
        from ..weights import load_into, load_state_dict_file

        state = load_state_dict_file(path, "dinov2", keys=("model", "state_dict", "teacher"))
        self.model = build_dinov2(self.arch)
        load_into(self.model, state, path, "dinov2", what=f"DINOv2 {self.arch}")
        self.model = self.model.to(o.device).eval()

    def _input(self, rgb: np.ndarray) -> tuple[np.ndarray, int, int]:
        import cv2

        H, W = self.fixed if self.onnx and self.fixed else patch_grid(rgb.shape[:2], self.options.image_size)
        x: Any = cv2.resize(rgb, (W, H), interpolation=cv2.INTER_AREA if W < rgb.shape[1] else cv2.INTER_CUBIC).astype(np.float32) / 255.0
        x = (x - np.array(IMAGENET_MEAN, np.float32)) / np.array(IMAGENET_STD, np.float32)
        return np.ascontiguousarray(x.transpose(2, 0, 1)[None]), H // 14, W // 14

    def __call__(self, view: View) -> np.ndarray:
        x, h, w = self._input(view_rgb(view))
        if self.onnx:
            out = np.asarray(self.session.run([self.output_name], {self.input_name: x})[0], np.float32)
            if out.ndim == 3 and out.shape[1] >= h * w:
                feat = out[0, -h * w :].reshape(h, w, -1)
            elif out.ndim == 4 and out.shape[2:] == (h, w):
                feat = out[0].transpose(1, 2, 0)
            else:
                raise SceneError(f"expected tokens [1, T >= {h * w}, D] or a map [1, D, {h}, {w}] (got {list(out.shape)})", where=str(self.options.checkpoint), field="backends.options.dinov2.onnx_output")
        else:
            import torch

            with torch.inference_mode():
                tok = self.model.forward_features(torch.from_numpy(x).to(self.options.device))["x_norm_patchtokens"]
            feat = tok[0].float().cpu().numpy().reshape(h, w, -1)
        if self.options.normalize:
            feat = feat / np.maximum(np.linalg.norm(feat, axis=-1, keepdims=True), 1e-12)
        return np.ascontiguousarray(feat, np.float32)
