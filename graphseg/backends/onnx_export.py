"""Export SAM 2 and DINOv2 to ONNX in the layout the ``sam-onnx`` and ``dinov2`` backends read.

Run once where torch and the model package are installed; the ONNX files then
run anywhere onnxruntime does (CPU deployment).

* :func:`export_sam2_onnx` writes ``encoder.onnx`` (``image [1, 3, S, S]`` ->
  ``image_embed``, ``high_res_feats_0``, ``high_res_feats_1``) and ``decoder.onnx``
  (those three + ``point_coords [B, 1, 2]``, ``point_labels [B, 1]`` ->
  ``masks [B, 3, S/4, S/4]`` logits, ``iou_predictions [B, 3]``), with a dynamic
  prompt batch ``B``. Uses the legacy exporter (``dynamo=False``), which SAM's
  decoder needs.
* :func:`export_dinov2_onnx` writes ``pixel_values [1, 3, H, W]`` -> ``tokens
  [1, h * w, D]`` for one fixed input size (the position embedding is resized
  once, outside the graph).

Command line::

    python -m graphseg.backends.onnx_export sam2 sam2.1_hiera_large.pt OUT_DIR
    python -m graphseg.backends.onnx_export dinov2 dinov2_vitl14_pretrain.pth OUT.onnx --height 336 --width 448

Examples
--------
>>> sorted(SAM2_DECODER_INPUTS)[:2]
['high_res_feats_0', 'high_res_feats_1']
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path
from typing import Any

__all__ = ["export_sam2_onnx", "export_dinov2_onnx", "SAM2_DECODER_INPUTS", "main"]

SAM2_ENCODER_OUTPUTS = ("image_embed", "high_res_feats_0", "high_res_feats_1")
SAM2_DECODER_INPUTS = (*SAM2_ENCODER_OUTPUTS, "point_coords", "point_labels")


def _wrappers(model: Any) -> tuple[Any, Any]:
    import torch

    class Encoder(torch.nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.m = model

        def forward(self, x: Any) -> Any:
            _, feats, _, sizes = self.m._prepare_backbone_features(self.m.forward_image(x))
            if self.m.directly_add_no_mem_embed:
                feats[-1] = feats[-1] + self.m.no_mem_embed
            maps = [f.permute(1, 2, 0).reshape(1, -1, *hw) for f, hw in zip(feats, sizes)]
            return maps[-1], maps[0], maps[1]

    class Decoder(torch.nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.m = model

        def forward(self, embed: Any, hr0: Any, hr1: Any, coords: Any, labels: Any) -> Any:
            pe = self.m.sam_prompt_encoder
            sparse, dense = pe(points=(coords, labels.int()), boxes=None, masks=None)
            low, iou, _, _ = self.m.sam_mask_decoder(
                image_embeddings=embed,
                image_pe=pe.get_dense_pe(),
                sparse_prompt_embeddings=sparse,
                dense_prompt_embeddings=dense,
                multimask_output=True,
                repeat_image=True,
                high_res_features=[hr0, hr1],
            )
            return low, iou

    return Encoder().eval(), Decoder().eval()


def export_sam2_onnx(model: Any, out_dir: str | Path, *, opset: int = 17) -> tuple[Path, Path]:
    """Export a loaded SAM 2 model (:func:`graphseg.backends.segmenters.sam.load_sam2`) to ``encoder.onnx`` + ``decoder.onnx``.

    Refuses to overwrite existing files. Returns the two paths.
    """
    import torch

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    enc_path, dec_path = out / "encoder.onnx", out / "decoder.onnx"
    for p in (enc_path, dec_path):
        if p.exists():
            raise FileExistsError(f"{p} exists; choose another folder")
    if not model.use_high_res_features_in_sam:
        raise ValueError("this export layout needs a SAM 2 model with high-resolution features (all official ones)")
    s = int(model.image_size)
    enc, dec = _wrappers(model)
    x = torch.randn(1, 3, s, s)
    with warnings.catch_warnings(), torch.no_grad():
        warnings.simplefilter("ignore")
        feats = enc(x)
        torch.onnx.export(enc, (x,), str(enc_path), input_names=["image"], output_names=list(SAM2_ENCODER_OUTPUTS), dynamo=False, opset_version=opset)
        pc, pl = torch.rand(2, 1, 2) * s, torch.ones(2, 1)
        axes = {n: {0: "prompts"} for n in ("point_coords", "point_labels", "masks", "iou_predictions")}
        torch.onnx.export(dec, (*feats, pc, pl), str(dec_path), input_names=list(SAM2_DECODER_INPUTS), output_names=["masks", "iou_predictions"], dynamic_axes=axes, dynamo=False, opset_version=opset)
    return enc_path, dec_path


def export_dinov2_onnx(model: Any, out_path: str | Path, height: int, width: int, *, opset: int = 17) -> Path:
    """Export a DINOv2 model (:func:`graphseg.backends.features.dino.build_dinov2` + weights) for one input size.

    ``height`` and ``width`` must be multiples of 14 (use
    :func:`graphseg.backends.features.dino.patch_grid` for your images).
    """
    import torch

    if height % 14 or width % 14:
        raise ValueError(f"expected height and width that are multiples of 14 (got {height}, {width})")
    out = Path(out_path)
    if out.exists():
        raise FileExistsError(f"{out} exists; choose another name")
    h, w = height // 14, width // 14
    pe = model.interpolate_pos_encoding(torch.zeros(1, 1 + h * w, model.embed_dim), height, width).detach()

    class Tokens(torch.nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.m = model

        def forward(self, x: Any) -> Any:
            return self.m.forward_features(x)["x_norm_patchtokens"]

    patched_before = "interpolate_pos_encoding" in vars(model)
    original = model.interpolate_pos_encoding
    model.interpolate_pos_encoding = lambda *a: pe
    try:
        with warnings.catch_warnings(), torch.no_grad():
            warnings.simplefilter("ignore")
            torch.onnx.export(Tokens().eval(), (torch.zeros(1, 3, height, width),), str(out), input_names=["pixel_values"], output_names=["tokens"], dynamo=False, opset_version=opset)
    finally:
        if patched_before:
            model.interpolate_pos_encoding = original
        else:
            del model.interpolate_pos_encoding
    return out


def main(argv: list[str] | None = None) -> int:
    """``python -m graphseg.backends.onnx_export {sam2,dinov2} CHECKPOINT OUT``."""
    ap = argparse.ArgumentParser(prog="python -m graphseg.backends.onnx_export", description="Export SAM 2 or DINOv2 to ONNX for graphseg.")
    ap.add_argument("model", choices=["sam2", "dinov2"])
    ap.add_argument("checkpoint")
    ap.add_argument("out", help="sam2: output folder; dinov2: output .onnx file")
    ap.add_argument("--config", help="sam2 config name (default: from the checkpoint name)")
    ap.add_argument("--image-size", type=int, help="sam2 input size (default: the config's 1024)")
    ap.add_argument("--arch", help="dinov2 architecture (default: from the checkpoint name)")
    ap.add_argument("--height", type=int, default=336)
    ap.add_argument("--width", type=int, default=448)
    args = ap.parse_args(argv)
    paths: tuple[Path, ...]
    if args.model == "sam2":
        from .segmenters.sam import load_sam2

        paths = export_sam2_onnx(load_sam2(args.checkpoint, args.config, image_size=args.image_size), args.out)
    else:
        from .features.dino import DINOv2Features

        fx = DINOv2Features(checkpoint=args.checkpoint, arch=args.arch)
        paths = (export_dinov2_onnx(fx.model, args.out, args.height, args.width),)
    for p in paths:
        print(p)
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
