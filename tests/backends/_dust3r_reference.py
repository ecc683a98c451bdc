"""A test-only torch re-implementation of DUSt3R's network and input pipeline (issue 22).

DUSt3R (naver/dust3r, CC BY-NC-SA 4.0) is not on PyPI. This module is graphseg's own
compact implementation of what its code does, written from reading naver/dust3r at
4c24a6e and naver/croco at d7de070 (no code copied). It is the reference the ``dust3r``
backend is checked against; it is not DUSt3R's code, so what it proves is that graphseg
computes what this implementation of the published architecture and conventions
computes. The facts it follows:

Input (``dust3r.utils.image.load_images`` + ``ImgNorm``)
    Pillow ``RGB`` image; ``size != 224``: long side resized to ``size`` (each side
    ``int(round(side * size / max(W, H)))``; ``Image.LANCZOS`` if the long side shrinks,
    else ``Image.BICUBIC``); crop box ``(cx - hw, cy - hh, cx + hw, cy + hh)`` with
    ``cx, cy = W // 2, H // 2``, ``hw = ((2 cx) // patch) * patch / 2`` (``hh`` likewise) and,
    when the resized image is square and ``square_ok`` is False, ``hh = 3 hw / 4``.
    ``size == 224``: long side to ``round(224 * max(W/H, H/W))``, then a centre square of
    side ``2 min(cx, cy)``. ``ToTensor`` (HWC uint8 -> CHW float / 255) then
    ``Normalize(mean=0.5, std=0.5)``; ``true_shape = [[H, W]]`` of the crop (int32).
Encoder (croco ``PatchEmbed`` / ``Block`` with ``pos_embed="RoPE100"``)
    16x16 conv patch embedding (no norm), positions ``(y, x)`` per patch in row-major
    order (``torch.cartesian_prod(y, x)``); pre-norm blocks (LayerNorm eps 1e-6,
    attention with qkv bias, 2D RoPE on q and k, GELU MLP ratio 4); a final LayerNorm.
2D RoPE (croco ``RoPE2D``, base 100)
    each head's channels split in halves: the first rotated by the y position, the second
    by x; per half ``D``: ``inv_freq = 1 / 100 ** (arange(0, D, 2) / D)``, angles
    ``pos * inv_freq`` repeated twice, ``t cos + rotate_half(t) sin`` with
    ``rotate_half(t) = cat(-t2, t1)``.
Decoder (``AsymmetricCroCo3DStereo._decoder``)
    one linear ``decoder_embed`` for both views; two block stacks (``dec_blocks`` for view 1,
    ``dec_blocks2`` for view 2), each block: self-attention (RoPE), cross-attention to the
    other view's tokens of the previous layer (memory LayerNorm ``norm_y``; RoPE with each
    side's positions), MLP; the last layer through ``dec_norm``.
Head (``LinearPts3d`` + ``postprocess``)
    ``Linear(dec_dim, 4 * 16 * 16)`` per token, ``pixel_shuffle(16)`` to ``[B, 4, H, W]``;
    ``depth_mode=('exp', -inf, inf)``: ``xyz / max(|xyz|, 1e-8) * expm1(|xyz|)``;
    ``conf_mode=('exp', 1, inf)``: ``1 + exp(c)``. Head 1 gives view 1's ``pts3d``; head 2
    gives view 2's, returned as ``pts3d_in_other_view`` (view 2 in view 1's frame).
    The published 512 checkpoints use a DPT head instead (same postprocess); this
    reference has only the linear one. Checkpoints loaded from a file (``load_model``)
    run with ``landscape_only=False`` and ``PatchEmbedDust3R``, so portrait images are
    not transposed; that is the path followed here.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

__all__ = ["load_image_reference", "TinyDUSt3R", "export_dust3r_onnx", "PATCH"]

PATCH = 16


# ----------------------------------------------------------------------------- input
def load_image_reference(image: str | Path | np.ndarray, size: int, *, square_ok: bool = False, patch: int = PATCH) -> dict[str, Any]:
    """One image (a file, opened as DUSt3R does, or a uint8 RGB array) as ``load_images`` makes it.

    Returns ``img`` float32 ``[1, 3, h, w]``, ``true_shape`` int32 ``[1, 2]``, the crop box
    ``(x0, y0, x1, y1)`` in resized pixels (``box``) and the resized size ``(H', W')`` (``resized``).
    """
    import PIL.Image
    from PIL.ImageOps import exif_transpose

    if isinstance(image, np.ndarray):
        img = PIL.Image.fromarray(np.ascontiguousarray(image)).convert("RGB")
    else:
        img = exif_transpose(PIL.Image.open(image)).convert("RGB")
    W1, H1 = img.size
    long = round(size * max(W1 / H1, H1 / W1)) if size == 224 else size
    S = max(img.size)
    new = tuple(int(round(v * long / S)) for v in img.size)
    img = img.resize(new, PIL.Image.LANCZOS if S > long else PIL.Image.BICUBIC)
    W, H = img.size
    cx, cy = W // 2, H // 2
    if size == 224:
        half = min(cx, cy)
        box = (cx - half, cy - half, cx + half, cy + half)
    else:
        halfw = ((2 * cx) // patch) * patch / 2
        halfh = ((2 * cy) // patch) * patch / 2
        if not square_ok and W == H:
            halfh = 3 * halfw / 4
        box = (cx - halfw, cy - halfh, cx + halfw, cy + halfh)
    img = img.crop(box)
    x = torch.from_numpy(np.array(img)).permute(2, 0, 1).float().div(255)  # ToTensor
    x = (x - 0.5) / 0.5  # Normalize((0.5,) * 3, (0.5,) * 3)
    return {"img": x[None], "true_shape": np.int32([img.size[::-1]]), "box": tuple(int(round(b)) for b in box), "resized": (H, W)}


# ----------------------------------------------------------------------------- network
class RoPE2D(nn.Module):
    def __init__(self, base: float = 100.0):
        super().__init__()
        self.base = base

    def _rotate(self, t: torch.Tensor, pos: torch.Tensor) -> torch.Tensor:
        d = t.shape[-1]
        inv = 1.0 / self.base ** (torch.arange(0, d, 2, dtype=torch.float32) / d)
        ang = pos.to(torch.float32)[:, None, :, None] * inv  # [B, 1, N, d/2]
        ang = torch.cat([ang, ang], -1)
        t1, t2 = t[..., : d // 2], t[..., d // 2 :]
        return t * ang.cos() + torch.cat([-t2, t1], -1) * ang.sin()

    def forward(self, t: torch.Tensor, pos: torch.Tensor) -> torch.Tensor:
        """``t`` ``[B, heads, N, Dh]``, ``pos`` ``[B, N, 2]`` as (y, x)."""
        ty, tx = t.chunk(2, -1)
        return torch.cat([self._rotate(ty, pos[..., 0]), self._rotate(tx, pos[..., 1])], -1)


class Attention(nn.Module):
    def __init__(self, dim: int, heads: int, rope: RoPE2D, cross: bool = False):
        super().__init__()
        self.heads, self.rope, self.cross = heads, rope, cross
        if cross:
            self.q, self.k, self.v = (nn.Linear(dim, dim) for _ in range(3))
        else:
            self.qkv = nn.Linear(dim, 3 * dim)
        self.proj = nn.Linear(dim, dim)

    def _split(self, x: torch.Tensor) -> torch.Tensor:
        b, n, c = x.shape
        return x.reshape(b, n, self.heads, c // self.heads).transpose(1, 2)

    def forward(self, x: torch.Tensor, xpos: torch.Tensor, y: torch.Tensor | None = None, ypos: torch.Tensor | None = None) -> torch.Tensor:
        if self.cross:
            assert y is not None and ypos is not None
            q, k, v = self._split(self.q(x)), self._split(self.k(y)), self._split(self.v(y))
            kpos = ypos
        else:
            q, k, v = (self._split(t) for t in self.qkv(x).chunk(3, -1))
            kpos = xpos
        q, k = self.rope(q, xpos), self.rope(k, kpos)
        a = (q @ k.transpose(-2, -1)) * (q.shape[-1] ** -0.5)
        out = a.softmax(-1) @ v
        return self.proj(out.transpose(1, 2).flatten(2))


def _mlp(dim: int) -> nn.Sequential:
    return nn.Sequential(nn.Linear(dim, 4 * dim), nn.GELU(), nn.Linear(4 * dim, dim))


def _ln(dim: int) -> nn.LayerNorm:
    return nn.LayerNorm(dim, eps=1e-6)


class EncoderBlock(nn.Module):
    def __init__(self, dim: int, heads: int, rope: RoPE2D):
        super().__init__()
        self.norm1, self.attn, self.norm2, self.mlp = _ln(dim), Attention(dim, heads, rope), _ln(dim), _mlp(dim)

    def forward(self, x: torch.Tensor, pos: torch.Tensor) -> torch.Tensor:
        x = x + self.attn(self.norm1(x), pos)
        return x + self.mlp(self.norm2(x))


class DecoderBlock(nn.Module):
    def __init__(self, dim: int, heads: int, rope: RoPE2D):
        super().__init__()
        self.norm1, self.attn = _ln(dim), Attention(dim, heads, rope)
        self.norm2, self.cross, self.norm_y = _ln(dim), Attention(dim, heads, rope, cross=True), _ln(dim)
        self.norm3, self.mlp = _ln(dim), _mlp(dim)

    def forward(self, x: torch.Tensor, y: torch.Tensor, xpos: torch.Tensor, ypos: torch.Tensor) -> torch.Tensor:
        x = x + self.attn(self.norm1(x), xpos)
        x = x + self.cross(self.norm2(x), xpos, self.norm_y(y), ypos)
        return x + self.mlp(self.norm3(x))


class TinyDUSt3R(nn.Module):
    """DUSt3R's asymmetric CroCo network with a linear head, at a tiny size (see the module docstring)."""

    def __init__(self, enc_dim: int = 48, enc_depth: int = 2, enc_heads: int = 3, dec_dim: int = 32, dec_depth: int = 2, dec_heads: int = 2, *, seed: int = 0):
        super().__init__()
        torch.manual_seed(seed)
        rope = RoPE2D(100.0)
        self.patch_embed = nn.Conv2d(3, enc_dim, PATCH, stride=PATCH)
        self.enc_blocks = nn.ModuleList(EncoderBlock(enc_dim, enc_heads, rope) for _ in range(enc_depth))
        self.enc_norm = _ln(enc_dim)
        self.decoder_embed = nn.Linear(enc_dim, dec_dim)
        self.dec_blocks = nn.ModuleList(DecoderBlock(dec_dim, dec_heads, rope) for _ in range(dec_depth))
        self.dec_blocks2 = nn.ModuleList(DecoderBlock(dec_dim, dec_heads, rope) for _ in range(dec_depth))
        self.dec_norm = _ln(dec_dim)
        self.head1 = nn.Linear(dec_dim, 4 * PATCH * PATCH)
        self.head2 = nn.Linear(dec_dim, 4 * PATCH * PATCH)
        with torch.no_grad():  # no special values: LayerNorms away from (1, 0), biases non-zero
            for m in self.modules():
                if isinstance(m, nn.LayerNorm):
                    m.weight.normal_(1.0, 0.2)
                    m.bias.normal_(0.0, 0.2)
                elif isinstance(m, nn.Linear):
                    m.bias.normal_(0.0, 0.1)
        self.eval()

    def encode(self, image: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``[B, 3, H, W]`` -> features ``[B, N, enc_dim]``, positions int64 ``[B, N, 2]`` (y, x)."""
        x = self.patch_embed(image)
        b, _, h, w = x.shape
        ys, xs = torch.meshgrid(torch.arange(h), torch.arange(w), indexing="ij")
        pos = torch.stack([ys.reshape(-1), xs.reshape(-1)], -1)[None].expand(b, -1, -1).to(torch.int64)
        x = x.flatten(2).transpose(1, 2)
        for blk in self.enc_blocks:
            x = blk(x, pos)
        return self.enc_norm(x), pos

    def decode(self, f1: torch.Tensor, pos1: torch.Tensor, f2: torch.Tensor, pos2: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Both views' last decoder tokens (after ``dec_norm``)."""
        f1, f2 = self.decoder_embed(f1), self.decoder_embed(f2)
        for b1, b2 in zip(self.dec_blocks, self.dec_blocks2):
            f1, f2 = b1(f1, f2, pos1, pos2), b2(f2, f1, pos2, pos1)  # both from the previous layer
        return self.dec_norm(f1), self.dec_norm(f2)

    @staticmethod
    def _postprocess(out: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        fmap = out.permute(0, 2, 3, 1)
        xyz, c = fmap[..., :3], fmap[..., 3]
        d = xyz.norm(dim=-1, keepdim=True)
        pts = xyz / d.clip(min=1e-8) * torch.expm1(d)
        return pts, 1.0 + c.exp()

    def head(self, k: int, tokens: torch.Tensor, hw: tuple[int, int]) -> tuple[torch.Tensor, torch.Tensor]:
        """``pts3d`` ``[B, H, W, 3]`` and ``conf`` ``[B, H, W]`` from head ``k`` (1 or 2)."""
        lin = self.head1 if k == 1 else self.head2
        b = tokens.shape[0]
        feat = lin(tokens).transpose(-1, -2).reshape(b, -1, hw[0] // PATCH, hw[1] // PATCH)
        return self._postprocess(F.pixel_shuffle(feat, PATCH))

    @torch.no_grad()
    def forward(self, img1: torch.Tensor, img2: torch.Tensor) -> dict[str, torch.Tensor]:
        """DUSt3R's ``forward(view1, view2)`` for one pair: view 1's ``pts3d`` / ``conf`` and view 2's
        ``pts3d_in_other_view`` / ``conf``."""
        hw = (int(img1.shape[2]), int(img1.shape[3]))
        f1, p1 = self.encode(img1)
        f2, p2 = self.encode(img2)
        d1, d2 = self.decode(f1, p1, f2, p2)
        pts1, conf1 = self.head(1, d1, hw)
        pts2, conf2 = self.head(2, d2, hw)
        return {"pts3d": pts1, "conf": conf1, "pts3d_in_other_view": pts2, "conf2": conf2}


# ----------------------------------------------------------------------------- ONNX export (docs/models.md)
class _Encoder(nn.Module):
    def __init__(self, m: TinyDUSt3R):
        super().__init__()
        self.m = m

    def forward(self, image: torch.Tensor, true_shape: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return self.m.encode(image)


class _Decoder(nn.Module):
    def __init__(self, m: TinyDUSt3R, hw: tuple[int, int]):
        super().__init__()
        self.m, self.hw = m, hw

    def forward(self, features1, pos1, features2, pos2, true_shape1, true_shape2):  # noqa: ANN001
        d1, d2 = self.m.decode(features1, pos1, features2, pos2)
        p1, c1 = self.m.head(1, d1, self.hw)  # the head's size is a constant, as DUSt3R's true_shape[0].tolist()
        p2, c2 = self.m.head(2, d2, self.hw)
        return p1, c1, p2, c2


def export_dust3r_onnx(model: TinyDUSt3R, hw: tuple[int, int], folder: Path, *, dynamic_encoder: bool = False) -> Path:
    """``encoder.onnx`` / ``decoder.onnx`` with docs/models.md's names, for the model input ``hw``.

    The legacy (TorchScript) exporter, as the docs' recipe, with its ``aten::expm1``
    symbolic (``exp(x) - 1``). ``dynamic_encoder``: the encoder's H and W are dynamic
    (graphseg then sizes the input with its ``size`` option).
    """
    folder.mkdir(parents=True, exist_ok=True)
    torch.onnx.register_custom_op_symbolic("aten::expm1", lambda g, x: g.op("Sub", g.op("Exp", x), g.op("Constant", value_t=torch.tensor(1.0))), 9)
    img = torch.zeros(1, 3, *hw)
    shape = torch.tensor([list(hw)])
    dyn = {"image": {2: "h", 3: "w"}} if dynamic_encoder else None
    with torch.no_grad(), warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the legacy exporter's deprecation and tracer warnings
        f, p = model.encode(img)
        torch.onnx.export(_Encoder(model), (img, shape), folder / "encoder.onnx", input_names=["image", "true_shape"], output_names=["features", "pos"], dynamic_axes=dyn, dynamo=False)
        torch.onnx.export(
            _Decoder(model, hw), (f, p, f, p, shape, shape), folder / "decoder.onnx",
            input_names=["features1", "pos1", "features2", "pos2", "true_shape1", "true_shape2"],
            output_names=["pts3d1", "conf1", "pts3d2", "conf2"], dynamo=False,
        )
    return folder / "encoder.onnx"
