"""Learned matchers: ``loftr`` (kornia's LoFTR) and ``roma`` (RoMa / tiny RoMa via ``romatch``).

Both load the user's checkpoint (never download), run on the pair resized to
the model's resolution, map the matches back to each image's own pixel
coordinates (pixel centres at integers) and keep up to ``num_matches`` by
:func:`sample_by_certainty`, RoMa's sampling: certainties above
``sample_threshold`` count as 1, and matches are drawn without replacement with
probability proportional to that weight. (RoMa's optional kernel-density
"balanced" step is not applied.)

Examples
--------
>>> import numpy as np
>>> from graphseg.scene import Matches
>>> m = Matches(np.zeros((4, 2)), np.zeros((4, 2)), [0.9, 0.0, 0.01, 0.5])
>>> s = sample_by_certainty(m, 2, rng=0)
>>> len(s), bool((s.certainty > 0).all())
(2, True)
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator

from ..scene import Matches, SceneError, View
from .options import ModelBackend, checkpoint_path, require_backend
from .sam import _rgb
from .weights import load_into, load_state_dict_file

__all__ = ["sample_by_certainty", "LoFTRMatcher", "RoMaMatcher"]


def sample_by_certainty(m: Matches, n: int | None, *, threshold: float = 0.05, rng: Any = None) -> Matches:
    """Draw up to ``n`` matches without replacement, weight ``min(certainty / threshold, 1)``-like as RoMa.

    Weights are ``1`` for certainty ``> threshold`` and the certainty itself
    otherwise (RoMa's ``threshold`` sampling); matches with certainty ``<= 0`` are
    never drawn. Sampling uses Gumbel top-k, which equals sequential sampling
    without replacement proportional to the weights. O(M) for M matches.

    Parameters
    ----------
    m : Matches
    n : int or None
        None keeps every match with positive certainty.
    threshold : float
    rng : seed or Generator

    Returns
    -------
    Matches
        In their original order; ``certainty`` is the model's (not the weight).

    Examples
    --------
    >>> m = Matches(np.zeros((3, 2)), np.zeros((3, 2)), [0.5, 0.6, 0.0])
    >>> sample_by_certainty(m, 5).certainty.tolist()  # the zero-certainty match is never kept
    [0.5, 0.6000000238418579]
    """
    cert = np.asarray(m.certainty, np.float64)
    pos = np.flatnonzero(cert > 0)
    if n is None or len(pos) <= n:
        idx = pos
    else:
        w = np.where(cert[pos] > threshold, 1.0, cert[pos])
        gen = np.random.default_rng(rng)
        key = np.log(w) + gen.gumbel(size=len(w))
        idx = np.sort(pos[np.argpartition(-key, n - 1)[:n]])
    return Matches(m.xy_i[idx], m.xy_j[idx], m.certainty[idx])


def _to_pixels(xy_px: np.ndarray, src_wh: tuple[int, int], dst_wh: tuple[int, int]) -> np.ndarray:
    """Map pixel-centre coordinates from an image of size ``src_wh`` to one of ``dst_wh`` (half-pixel rule)."""
    s = np.array([dst_wh[0] / src_wh[0], dst_wh[1] / src_wh[1]])
    return ((np.asarray(xy_px, np.float64) + 0.5) * s - 0.5).astype(np.float32)


class _MatcherOptions(BaseModel):
    model_config = ConfigDict(extra="forbid")
    checkpoint: str | None = None
    num_matches: int | None = Field(10_000, ge=1)
    sample_threshold: float = Field(0.05, gt=0)
    seed: int | None = 0
    device: str = "cpu"


class LoFTRMatcher(ModelBackend):
    """The ``loftr`` matcher: kornia's LoFTR with the user's weights (``loftr_outdoor.ckpt`` ...).

    Both images are resized to ``image_size`` (W, H; the paper's 640x480, each a
    multiple of 8) and converted to grey. Options: ``checkpoint`` (required),
    ``image_size``, ``match_threshold`` (LoFTR's coarse confidence threshold,
    0.2), ``temp_bug_fix`` (True for LoFTR's ``indoor_ds_new.ckpt``),
    ``num_matches``, ``sample_threshold``, ``seed``, ``device``.
    """

    name = "loftr"
    extra = "loftr"
    needs_3d = False

    class Options(_MatcherOptions):
        image_size: tuple[int, int] = (640, 480)
        match_threshold: float = Field(0.2, ge=0, le=1)
        temp_bug_fix: bool = False

        @field_validator("image_size")
        @classmethod
        def _mult8(cls, v: tuple[int, int]) -> tuple[int, int]:
            if v[0] % 8 or v[1] % 8 or min(v) < 32:
                raise ValueError(f"expected a width and height that are multiples of 8 and >= 32 (got {list(v)})")
            return v

    def __init__(self, options: Any = None, /, **kwargs: Any) -> None:
        super().__init__(options, **kwargs)
        o = self.options
        require_backend("kornia", "loftr", "loftr")
        torch = require_backend("torch", "loftr", "loftr")
        path = checkpoint_path(o.checkpoint, "loftr", "loftr")
        import copy

        from kornia.feature import LoFTR
        from kornia.feature.loftr.loftr import default_cfg

        state = load_state_dict_file(path, "loftr")
        if state and all(k.startswith("matcher.") for k in state):
            state = {k[len("matcher.") :]: v for k, v in state.items()}
        cfg: Any = copy.deepcopy(default_cfg)
        cfg["match_coarse"]["thr"] = o.match_threshold
        cfg["coarse"]["temp_bug_fix"] = o.temp_bug_fix
        self.model = LoFTR(pretrained=None, config=cfg)
        load_into(self.model, state, path, "loftr", what="kornia's LoFTR")
        self.model = self.model.to(o.device).eval()
        self._torch = torch

    def _gray(self, rgb: np.ndarray) -> Any:
        import cv2

        w, h = self.options.image_size
        g = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)
        g = cv2.resize(g, (w, h), interpolation=cv2.INTER_AREA if g.shape[1] > w else cv2.INTER_LINEAR)
        return self._torch.from_numpy(g).float().div(255.0)[None, None].to(self.options.device)

    def raw_matches(self, view_i: View, view_j: View) -> Matches:
        """Every match LoFTR returns (confidence above its coarse threshold), in original pixels.

        LoFTR's keypoints put the centre of model pixel ``(x, y)`` at
        ``(x + 0.5, y + 0.5)`` (the reference implementation's frame, as kornia
        documents); minus 0.5 they are in graphseg's frame (integer pixel
        centres), then the half-pixel rule maps them to each image's size.
        """
        ri, rj = _rgb(view_i), _rgb(view_j)
        with self._torch.inference_mode():
            out = self.model({"image0": self._gray(ri), "image1": self._gray(rj)})
        size = self.options.image_size
        xi = _to_pixels(out["keypoints0"].cpu().numpy() - 0.5, size, (ri.shape[1], ri.shape[0]))
        xj = _to_pixels(out["keypoints1"].cpu().numpy() - 0.5, size, (rj.shape[1], rj.shape[0]))
        return Matches(xi, xj, out["confidence"].float().cpu().numpy())

    def __call__(self, view_i: View, view_j: View) -> Matches:
        o = self.options
        return sample_by_certainty(self.raw_matches(view_i, view_j), o.num_matches, threshold=o.sample_threshold, rng=o.seed)


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

    class Options(_MatcherOptions):
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
        ri, rj = _rgb(view_i), _rgb(view_j)
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
        from .sam import IMAGENET_MEAN, IMAGENET_STD

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
