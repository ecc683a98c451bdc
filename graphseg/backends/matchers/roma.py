"""The ``roma`` matcher: RoMa or tiny RoMa (via ``romatch``) with the user's checkpoints (never downloaded).

The pair is resized to the model's resolution; the dense warp is mapped back
to each image's own pixel coordinates (pixel centres at integers) and up to
``num_matches`` matches are kept by
:func:`~graphseg.backends.matchers.sampling.sample_by_certainty`, RoMa's
sampling. ``romatch`` is imported with a stand-in torchvision when the real
one cannot be imported (:mod:`graphseg.backends.matchers.romatch_compat`).
Extra ``roma``; see docs/models.md.

Examples
--------
>>> RoMaMatcher.Options().coarse_res, RoMaMatcher.extra
(560, 'roma')
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from ...scene import Matches, SceneError, View
from ..imaging import view_rgb
from ..options import ModelBackend, checkpoint_path, require_backend
from ..weights import load_into, load_state_dict_file
from .sampling import ModelMatcherOptions, sample_by_certainty

__all__ = ["RoMaMatcher"]


class RoMaMatcher(ModelBackend):
    """The ``roma`` matcher: RoMa (``roma_outdoor.pth`` + DINOv2 ``dinov2_vitl14_pretrain.pth``) or tiny RoMa.

    Options: ``checkpoint`` (required), ``model`` (``"roma"`` or ``"tiny"``,
    inferred from a file name containing ``tiny``), ``dinov2_checkpoint``
    (required for ``"roma"``), ``coarse_res`` (560 = the paper's 560x560, a
    multiple of 14), ``upsample_res`` (864; None = no refinement pass at high
    resolution), ``symmetric``, ``use_custom_corr`` (romatch's fused CUDA
    correlation kernel, if installed), ``num_matches``, ``sample_threshold``, ``seed``,
    ``device``. Tiny RoMa runs at the image's own size (cut to multiples of 32).
    """

    name = "roma"
    extra = "roma"
    needs_3d = False

    class Options(ModelMatcherOptions):
        model: str | None = Field(None, pattern="^(roma|tiny)$")
        dinov2_checkpoint: str | None = None
        coarse_res: int = Field(560, ge=14, multiple_of=14)
        upsample_res: int | None = Field(864, ge=14)
        symmetric: bool = True
        use_custom_corr: bool = False

    def __init__(self, options: Any = None, /, **kwargs: Any) -> None:
        super().__init__(options, **kwargs)
        o = self.options
        require_backend("torch", "roma", "roma")
        require_backend("kornia", "roma", "roma")
        path = checkpoint_path(o.checkpoint, "roma", "roma")
        self.kind = o.model or ("tiny" if "tiny" in path.name.lower() else "roma")
        dino = checkpoint_path(o.dinov2_checkpoint, "roma", "roma", option="dinov2_checkpoint") if self.kind == "roma" else None
        from .romatch_compat import import_romatch

        import_romatch()
        state = load_state_dict_file(path, "roma")
        if self.kind == "tiny":
            self.model = _build_tiny_roma(state, path)
        else:
            dino_state = load_state_dict_file(dino, "roma", option="dinov2_checkpoint")
            self.model = _build_roma(state, dino_state, path, dino, o)
        self.model = self.model.to(o.device).eval()

    def warp(self, rgb_i: np.ndarray, rgb_j: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Dense warp ``[h, w', 4]`` (normalised ``x_i, y_i, x_j, y_j`` in ``[-1, 1]``) and certainty ``[h, w']``."""
        import torch

        dev = self.options.device
        if self.kind == "tiny":
            a = _tensor(rgb_i, None, dev, normalize=False)
            b = _tensor(rgb_j, (rgb_i.shape[1], rgb_i.shape[0]), dev, normalize=False)
            with torch.inference_mode():
                warp, cert = self.model.match(a, b, batched=False)
        else:
            c = self.options.coarse_res
            a, b = _tensor(rgb_i, (c, c), dev), _tensor(rgb_j, (c, c), dev)
            kw: dict[str, Any] = {}
            if self.options.upsample_res:
                u = self.options.upsample_res
                kw = {"im_A_high_res": _tensor(rgb_i, (u, u), dev), "im_B_high_res": _tensor(rgb_j, (u, u), dev)}
            with torch.inference_mode():
                warp, cert = self.model.match(a, b, **kw)
            warp, cert = warp[0] if warp.ndim == 4 else warp, cert[0] if cert.ndim == 3 else cert
        return warp.float().cpu().numpy(), cert.float().cpu().numpy()

    def raw_matches(self, view_i: View, view_j: View) -> Matches:
        """One match per warp pixel (both directions when symmetric), in original pixels."""
        ri, rj = view_rgb(view_i), view_rgb(view_j)
        warp, cert = self.warp(ri, rj)
        warp = warp.reshape(-1, 4).astype(np.float64)
        (hi, wi), (hj, wj) = ri.shape[:2], rj.shape[:2]
        xi = np.stack([(warp[:, 0] + 1) * wi / 2 - 0.5, (warp[:, 1] + 1) * hi / 2 - 0.5], 1)
        xj = np.stack([(warp[:, 2] + 1) * wj / 2 - 0.5, (warp[:, 3] + 1) * hj / 2 - 0.5], 1)
        c = cert.reshape(-1)
        inside = (xj[:, 0] >= -0.5) & (xj[:, 0] <= wj - 0.5) & (xj[:, 1] >= -0.5) & (xj[:, 1] <= hj - 0.5)
        inside &= (xi[:, 0] >= -0.5) & (xi[:, 0] <= wi - 0.5) & (xi[:, 1] >= -0.5) & (xi[:, 1] <= hi - 0.5)
        return Matches(xi[inside].astype(np.float32), xj[inside].astype(np.float32), c[inside].astype(np.float32))

    def __call__(self, view_i: View, view_j: View) -> Matches:
        o = self.options
        return sample_by_certainty(self.raw_matches(view_i, view_j), o.num_matches, threshold=o.sample_threshold, rng=o.seed)


def _tensor(rgb: np.ndarray, size: tuple[int, int] | None, device: str, normalize: bool = True) -> Any:
    """uint8 ``[H, W, 3]`` -> float ``[1, 3, h, w]`` in 0..1 (ImageNet-normalised when ``normalize``)."""
    import torch
    import torch.nn.functional as F

    x = torch.from_numpy(np.ascontiguousarray(rgb)).permute(2, 0, 1)[None].float().div(255.0)
    if size is not None and (x.shape[-1], x.shape[-2]) != tuple(size):
        x = F.interpolate(x, (size[1], size[0]), mode="bicubic", align_corners=False, antialias=True).clamp(0, 1)
    if normalize:
        from ..imaging import IMAGENET_MEAN, IMAGENET_STD

        mean = torch.tensor(IMAGENET_MEAN)[:, None, None]
        std = torch.tensor(IMAGENET_STD)[:, None, None]
        x = (x - mean) / std
    return x.to(device)


def _build_roma(state: dict[str, Any], dino_state: dict[str, Any], path: Any, dino_path: Any, o: Any) -> Any:
    import warnings

    import torch
    from romatch.models.model_zoo.roma_models import roma_model

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            return roma_model(
                resolution=(o.coarse_res, o.coarse_res),
                upsample_preds=o.upsample_res is not None,
                device=o.device,
                weights=state,
                dinov2_weights=dino_state,
                amp_dtype=torch.float16 if str(o.device).startswith("cuda") else torch.float32,
                symmetric=o.symmetric,
                use_custom_corr=o.use_custom_corr,
                upsample_res=(o.upsample_res, o.upsample_res) if o.upsample_res else None,
            )
        except RuntimeError as err:
            lines = [ln.strip() for ln in str(err).splitlines() if ln.strip()]
            detail = (lines[1] if len(lines) > 1 else lines[0])[:200]
            if "DinoVisionTransformer" in lines[0]:
                raise SceneError(f"weights do not fit DINOv2 ViT-L/14 ({detail})", where=str(dino_path), field="backends.options.roma.dinov2_checkpoint") from None
            raise SceneError(f"weights do not fit RoMa ({detail})", where=str(path), field="backends.options.roma.checkpoint") from None


def _build_tiny_roma(state: dict[str, Any], path: Any) -> Any:
    from kornia.feature import XFeatModel
    from romatch.models.model_zoo.roma_models import tiny_roma_v1_model

    model = tiny_roma_v1_model(weights=None, xfeat=XFeatModel())
    load_into(model, state, path, "roma", what="tiny RoMa v1")
    return model
