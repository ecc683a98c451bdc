"""SAM 2 segmenters: ``sam2`` (torch, the ``sam2`` package) and ``sam-onnx`` (onnxruntime).

Both run graphseg's own automatic mask generator
(:func:`graphseg.backends.segmenters.automask.generate_masks`) on the model's image
encoder, prompt encoder and mask decoder; neither needs torchvision (which
SAM 2's ``SAM2ImagePredictor`` and ``SAM2AutomaticMaskGenerator`` import).
Weights come only from the user's files; nothing is downloaded.

* ``sam2``: SAM 2 / 2.1 of any size from an official checkpoint
  (``sam2.1_hiera_large.pt`` ...) and its config name (inferred from the file
  name when not given). Extra: ``graphseg[sam2]``.
* ``sam-onnx``: an encoder/decoder ONNX pair exported by the user. Input and
  output names are options because exporters name them differently. Extra:
  ``graphseg[onnx]``.

Examples
--------
>>> sam2_config_name("sam2.1_hiera_base_plus.pt")
'configs/sam2.1/sam2.1_hiera_b+.yaml'
>>> sam2_config_name("sam2_hiera_l")
'configs/sam2/sam2_hiera_l.yaml'
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import Field

from ...scene import SceneError, View
from ..imaging import IMAGENET_MEAN, IMAGENET_STD, view_rgb
from ..options import ModelBackend, checkpoint_path, require_backend
from .automask import AutomaskOptions, Predict, Proposals, generate_masks

__all__ = ["AutomaskOptions", "SAM2Segmenter", "SamOnnxSegmenter", "sam2_config_name", "sam2_predictor", "load_sam2"]

_SIZES = {"tiny": "t", "t": "t", "small": "s", "s": "s", "base_plus": "b+", "b+": "b+", "base": "b+", "large": "l", "l": "l"}


def sam2_config_name(name: str | Path) -> str:
    """The ``sam2`` package config for a config or checkpoint name.

    Accepts a full config name (``configs/sam2.1/sam2.1_hiera_t.yaml``), a short
    one (``sam2.1_hiera_t``) or an official checkpoint file name
    (``sam2.1_hiera_tiny.pt``, ``sam2_hiera_base_plus.pt``).

    Raises
    ------
    ValueError
        If the name does not say the version and size.
    """
    s = Path(str(name)).name if str(name).endswith(".pt") else str(name)
    if s.startswith("configs/") and s.endswith(".yaml"):
        return s
    m = re.match(r"^(sam2(?:\.1)?)_hiera_(tiny|small|base_plus|base|large|t|s|b\+|l)(?:\.pt|\.yaml)?$", Path(s).name)
    if m is None:
        raise ValueError(f"cannot tell the SAM 2 config from {str(name)!r}; give config=configs/sam2.1/sam2.1_hiera_{{t,s,b+,l}}.yaml")
    version, size = m.group(1), _SIZES[m.group(2)]
    return f"configs/{version}/{version}_hiera_{size}.yaml"


def load_sam2(checkpoint: str | Path | None, config: str | None = None, *, image_size: int | None = None, device: str = "cpu") -> Any:
    """Build a SAM 2 model from its config and load the user's checkpoint (never downloads).

    Parameters
    ----------
    checkpoint : path
        A file saved by ``torch.save``: ``{"model": state_dict}`` (the official
        format) or a bare state dict.
    config : str, optional
        Config name; inferred from the checkpoint's file name when None.
    image_size : int, optional
        Override the config's input size (1024), e.g. 256 for tests.

    Raises
    ------
    MissingDependencyError, SceneError
        One line each, before anything is built.
    """
    field = "backends.options.sam2"
    require_backend("sam2", "sam2", "sam2")
    require_backend("torch", "sam2", "sam2")
    path = checkpoint_path(checkpoint, "sam2", "sam2")
    try:
        cfg = sam2_config_name(config if config else path)
    except ValueError as err:
        raise SceneError(str(err), field=f"{field}.config") from None
    from hydra.errors import MissingConfigException
    from sam2.build_sam import build_sam2

    extra = [f"++model.image_size={int(image_size)}"] if image_size else []
    try:
        model = build_sam2(cfg, ckpt_path=None, device="cpu", hydra_overrides_extra=extra)
    except MissingConfigException:
        raise SceneError(f"no SAM 2 config {cfg!r} in the sam2 package (configs/sam2.1/sam2.1_hiera_{{t,s,b+,l}}.yaml)", field=f"{field}.config") from None
    from ..weights import load_into, load_state_dict_file

    load_into(model, load_state_dict_file(path, "sam2", keys=("model",)), path, "sam2", what=cfg)
    return model.to(device).eval()


def sam2_predictor(model: Any, rgb: np.ndarray) -> Predict:
    """Encode ``rgb`` once with a SAM 2 model and return the prompt -> masks callable.

    Parameters
    ----------
    model : sam2.modeling.sam2_base.SAM2Base
    rgb : uint8 ``[H, W, 3]``

    Returns
    -------
    callable
        ``predict(points [B, 2] pixels of rgb, labels [B]) -> (logits [B, 3, s/4, s/4], iou [B, 3])``
        with ``s = model.image_size``; the logits cover the whole image.

    Notes
    -----
    The image is resized to ``s x s`` (bilinear, antialiased) and normalised with
    ImageNet statistics, as SAM 2's own transforms do.
    """
    import torch
    import torch.nn.functional as F

    h, w = rgb.shape[:2]
    s = int(model.image_size)
    dev = next(model.parameters()).device
    with torch.inference_mode():
        x = torch.from_numpy(np.ascontiguousarray(rgb)).to(dev).permute(2, 0, 1)[None].float() / 255.0
        x = F.interpolate(x, (s, s), mode="bilinear", align_corners=False, antialias=True)
        x = (x - torch.tensor(IMAGENET_MEAN, device=dev)[:, None, None]) / torch.tensor(IMAGENET_STD, device=dev)[:, None, None]
        out = model.forward_image(x)
        _, feats, _, sizes = model._prepare_backbone_features(out)
        if model.directly_add_no_mem_embed:
            feats[-1] = feats[-1] + model.no_mem_embed
        maps = [f.permute(1, 2, 0).reshape(1, -1, *hw) for f, hw in zip(feats, sizes)]
    embed = maps[-1]
    high_res = maps[:-1] if model.use_high_res_features_in_sam else None
    scale = torch.tensor([s / w, s / h], device=dev)

    def predict(points: np.ndarray, labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        with torch.inference_mode():
            coords = torch.as_tensor(points, dtype=torch.float32, device=dev)[:, None] * scale
            labs = torch.as_tensor(labels, dtype=torch.int32, device=dev)[:, None]
            sparse, dense = model.sam_prompt_encoder(points=(coords, labs), boxes=None, masks=None)
            low, iou, _, _ = model.sam_mask_decoder(
                image_embeddings=embed,
                image_pe=model.sam_prompt_encoder.get_dense_pe(),
                sparse_prompt_embeddings=sparse,
                dense_prompt_embeddings=dense,
                multimask_output=True,
                repeat_image=len(points) > 1,
                high_res_features=high_res,
            )
        return low.float().cpu().numpy(), iou.float().cpu().numpy()

    return predict


def _crop_predictor(make: Any, rgb: np.ndarray) -> Any:
    def predict_crop(box: np.ndarray) -> Predict:
        x0, y0, x1, y1 = (int(v) for v in box)
        return make(rgb[y0:y1, x0:x1])

    return predict_crop


class SAM2Segmenter(ModelBackend):
    """The ``sam2`` segmenter: SAM 2 / 2.1 "segment everything" with graphseg's mask generator.

    Options (``--backend-option sam2.KEY=VALUE``): ``checkpoint`` (required, an
    official ``sam2.1_hiera_*.pt`` or any ``torch.save``\\ d state dict),
    ``config`` (inferred from the checkpoint name), ``image_size`` (None = the
    config's 1024), ``device`` (``cpu``), and every :class:`AutomaskOptions` field.

    Returns a list of boolean ``[H, W]`` masks (may overlap), best predicted IoU
    first, or an all-zero label image when no mask passes the filters.
    """

    name = "sam2"
    extra = "sam2"

    class Options(AutomaskOptions):
        checkpoint: str | None = None
        config: str | None = None
        image_size: int | None = Field(None, ge=16)
        device: str = "cpu"

    def __init__(self, options: Any = None, /, **kwargs: Any) -> None:
        super().__init__(options, **kwargs)
        o = self.options
        self.model = load_sam2(o.checkpoint, o.config, image_size=o.image_size, device=o.device)

    def proposals(self, view: View) -> Proposals:
        """All kept proposals (masks, predicted IoU, stability, boxes, prompt points)."""
        rgb = view_rgb(view)
        make = lambda im: sam2_predictor(self.model, im)  # noqa: E731
        return generate_masks(make(rgb), rgb.shape[:2], self.options, predict_crop=_crop_predictor(make, rgb))


    def __call__(self, view: View) -> list[np.ndarray] | np.ndarray:
        return _masks_or_empty(self.proposals(view), view)


# ----------------------------------------------------------------------------- ONNX
class SamOnnxSegmenter(ModelBackend):
    """The ``sam-onnx`` segmenter: a user-exported SAM (2) encoder/decoder ONNX pair on onnxruntime.

    The encoder takes the normalised image ``[1, 3, S, S]``; every encoder output
    is fed to the decoder input of the same name (``feeds`` renames:
    ``{decoder_input: encoder_output}``). The decoder takes point prompts
    ``point_coords [B, 1, 2]`` (model-input pixels) and ``point_labels [B, 1]``
    and returns mask logits ``[B, K, h, w]`` and predicted IoUs ``[B, K]``.
    Other decoder inputs (``mask_input``, ``has_mask_input`` of SAM 1 exports)
    are fed zeros of their declared shape. With ``batch_prompts=False`` prompts
    are decoded one at a time (exports with a fixed batch of 1).

    Options: ``encoder``, ``decoder`` (required paths), ``image_size`` (S, read
    from the encoder's input when fixed), ``resize`` (``"square"`` as SAM 2,
    ``"longest_side"`` with bottom-right padding as SAM 1), ``pixel_mean`` /
    ``pixel_std`` (for images scaled to 0..1), the input/output names, and every
    :class:`AutomaskOptions` field.
    """

    name = "sam-onnx"
    extra = "onnx"

    class Options(AutomaskOptions):
        encoder: str | None = None
        decoder: str | None = None
        image_size: int | None = Field(None, ge=16)
        resize: str = Field("square", pattern="^(square|longest_side)$")
        pixel_mean: tuple[float, float, float] = IMAGENET_MEAN
        pixel_std: tuple[float, float, float] = IMAGENET_STD
        image_input: str | None = None
        point_coords_input: str = "point_coords"
        point_labels_input: str = "point_labels"
        masks_output: str | None = None
        iou_output: str | None = None
        feeds: dict[str, str] = Field(default_factory=dict)
        add_padding_point: bool = False
        batch_prompts: bool = True
        providers: list[str] = Field(default_factory=lambda: ["CPUExecutionProvider"])

    def __init__(self, options: Any = None, /, **kwargs: Any) -> None:
        super().__init__(options, **kwargs)
        o = self.options
        ort = require_backend("onnxruntime", "sam-onnx", "onnx", option="encoder")
        enc = checkpoint_path(o.encoder, "sam-onnx", "onnx", option="encoder")
        dec = checkpoint_path(o.decoder, "sam-onnx", "onnx", option="decoder")
        field = "backends.options.sam-onnx"
        try:
            self.encoder = ort.InferenceSession(str(enc), providers=list(o.providers))
        except Exception as err:
            raise SceneError(f"cannot load the ONNX encoder ({type(err).__name__})", where=str(enc), field=f"{field}.encoder") from None
        try:
            self.decoder = ort.InferenceSession(str(dec), providers=list(o.providers))
        except Exception as err:
            raise SceneError(f"cannot load the ONNX decoder ({type(err).__name__})", where=str(dec), field=f"{field}.decoder") from None
        ins = self.encoder.get_inputs()
        self.image_input = o.image_input or ins[0].name
        names = [i.name for i in ins]
        if self.image_input not in names:
            raise SceneError(f"encoder has no input {self.image_input!r}; its inputs: {', '.join(names)}", where=str(enc), field=f"{field}.image_input")
        shape = next(i.shape for i in ins if i.name == self.image_input)
        fixed = shape[-1] if isinstance(shape[-1], int) else None
        self.image_size = int(o.image_size or fixed or 0)
        if not self.image_size:
            raise SceneError("the encoder's input size is dynamic; set image_size", field=f"{field}.image_size")
        enc_out = [x.name for x in self.encoder.get_outputs()]
        dec_in = {x.name: x for x in self.decoder.get_inputs()}
        dec_out = {x.name: x for x in self.decoder.get_outputs()}
        for name in (o.point_coords_input, o.point_labels_input, *o.feeds):
            if name not in dec_in:
                raise SceneError(f"decoder has no input {name!r}; its inputs: {', '.join(dec_in)}", where=str(dec), field=field)
        for src in o.feeds.values():
            if src not in enc_out:
                raise SceneError(f"encoder has no output {src!r}; its outputs: {', '.join(enc_out)}", where=str(enc), field=f"{field}.feeds")
        self.feeds = {k: k for k in enc_out if k in dec_in} | dict(o.feeds)
        self.constant_inputs = [x for k, x in dec_in.items() if k not in self.feeds and k not in (o.point_coords_input, o.point_labels_input)]
        self.masks_output = o.masks_output or _pick(dec_out, 4, ("low_res_masks", "masks", "low_res_logits", "pred_masks"))
        self.iou_output = o.iou_output or _pick(dec_out, 2, ("iou_predictions", "iou_scores", "scores", "iou_pred"))
        for k, v in (("masks_output", self.masks_output), ("iou_output", self.iou_output)):
            if v is None or v not in dec_out:
                raise SceneError(f"cannot find the decoder output for {k}; its outputs: {', '.join(dec_out)}", where=str(dec), field=f"{field}.{k}")

    def _frame(self, h: int, w: int) -> tuple[float, float, int, int]:
        s = self.image_size
        if self.options.resize == "square":
            return s / w, s / h, s, s
        k = s / max(h, w)
        return k, k, int(round(w * k)), int(round(h * k))

    def predictor(self, rgb: np.ndarray) -> Predict:
        """Encode ``rgb`` and return ``predict(points, labels) -> (logits, iou)`` (see :mod:`automask`)."""
        import cv2

        o = self.options
        h, w = rgb.shape[:2]
        s = self.image_size
        sx, sy, nw, nh = self._frame(h, w)
        img: Any = cv2.resize(rgb, (nw, nh), interpolation=cv2.INTER_AREA if nw < w else cv2.INTER_LINEAR).astype(np.float32) / 255.0
        img = (img - np.array(o.pixel_mean, np.float32)) / np.array(o.pixel_std, np.float32)
        x = np.zeros((1, 3, s, s), np.float32)
        x[0, :, :nh, :nw] = img.transpose(2, 0, 1)
        enc_names = [e.name for e in self.encoder.get_outputs()]
        enc = dict(zip(enc_names, self.encoder.run(None, {self.image_input: x})))
        fixed = {k: enc[v] for k, v in self.feeds.items()}

        def run(points: np.ndarray, labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            b = len(points)
            coords = (np.asarray(points, np.float32) * np.array([sx, sy], np.float32))[:, None]
            labs = np.asarray(labels, np.float32)[:, None]
            if o.add_padding_point:
                coords = np.concatenate([coords, np.zeros((b, 1, 2), np.float32)], 1)
                labs = np.concatenate([labs, -np.ones((b, 1), np.float32)], 1)
            feed = dict(fixed)
            feed[o.point_coords_input] = coords
            feed[o.point_labels_input] = labs.astype(_np_type(self.decoder, o.point_labels_input))
            for inp in self.constant_inputs:
                dims = [d if isinstance(d, int) else (b if i == 0 else 1) for i, d in enumerate(inp.shape)]
                feed[inp.name] = np.zeros(dims, _np_type(self.decoder, inp.name))
            logits, iou = self.decoder.run([self.masks_output, self.iou_output], feed)  # in the order asked for
            return logits, iou

        def predict(points: np.ndarray, labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            if o.batch_prompts:
                logits, iou = run(points, labels)
            else:
                outs = [run(points[i : i + 1], labels[i : i + 1]) for i in range(len(points))]
                logits = np.concatenate([a for a, _ in outs])
                iou = np.concatenate([b for _, b in outs])
            logits = np.asarray(logits, np.float32)
            if logits.shape[-2:] != (h, w) and (nh, nw) != (s, s):
                fh, fw = logits.shape[-2] / s, logits.shape[-1] / s
                logits = logits[..., : max(1, int(round(nh * fh))), : max(1, int(round(nw * fw)))]
            return logits, np.asarray(iou, np.float32)

        return predict

    def proposals(self, view: View) -> Proposals:
        """All kept proposals (masks, predicted IoU, stability, boxes, prompt points)."""
        rgb = view_rgb(view)
        return generate_masks(self.predictor(rgb), rgb.shape[:2], self.options, predict_crop=_crop_predictor(self.predictor, rgb))

    def __call__(self, view: View) -> list[np.ndarray] | np.ndarray:
        return _masks_or_empty(self.proposals(view), view)


def _masks_or_empty(props: Proposals, view: View) -> list[np.ndarray] | np.ndarray:
    """The kept masks, or an all-zero label image (no segment) when none was kept."""
    if len(props.masks) == 0:
        return np.zeros(view.shape, np.int32)
    return list(props.masks)


def _pick(outputs: dict[str, Any], ndim: int, names: tuple[str, ...]) -> str | None:
    for n in names:
        if n in outputs:
            return n
    same = [k for k, v in outputs.items() if len(v.shape) == ndim]
    return same[0] if len(same) == 1 else None


_ORT_TYPES = {"tensor(float)": np.float32, "tensor(int64)": np.int64, "tensor(int32)": np.int32, "tensor(double)": np.float64, "tensor(bool)": np.bool_}


def _np_type(session: Any, name: str) -> Any:
    t = next(i.type for i in session.get_inputs() if i.name == name)
    return _ORT_TYPES.get(t, np.float32)
