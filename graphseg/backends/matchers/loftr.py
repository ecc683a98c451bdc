"""The ``loftr`` matcher: kornia's LoFTR with the user's checkpoint (never downloaded).

Both images are resized to the model's resolution; the matches are mapped
back to each image's own pixel coordinates (pixel centres at integers) and up
to ``num_matches`` are kept by
:func:`~graphseg.backends.matchers.sampling.sample_by_certainty` (RoMa's
sampling). Extra ``loftr``; see docs/models.md.

Examples
--------
>>> LoFTRMatcher.Options().image_size, LoFTRMatcher.extra
((640, 480), 'loftr')
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field, field_validator

from ...scene import Matches, View
from ..imaging import view_rgb
from ..options import ModelBackend, checkpoint_path, require_backend
from ..weights import load_into, load_state_dict_file
from .sampling import ModelMatcherOptions, sample_by_certainty

__all__ = ["LoFTRMatcher"]


def _to_pixels(xy_px: np.ndarray, src_wh: tuple[int, int], dst_wh: tuple[int, int]) -> np.ndarray:
    """Map pixel-centre coordinates from an image of size ``src_wh`` to one of ``dst_wh`` (half-pixel rule)."""
    s = np.array([dst_wh[0] / src_wh[0], dst_wh[1] / src_wh[1]])
    return ((np.asarray(xy_px, np.float64) + 0.5) * s - 0.5).astype(np.float32)


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

    class Options(ModelMatcherOptions):
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
        ri, rj = view_rgb(view_i), view_rgb(view_j)
        with self._torch.inference_mode():
            out = self.model({"image0": self._gray(ri), "image1": self._gray(rj)})
        size = self.options.image_size
        xi = _to_pixels(out["keypoints0"].cpu().numpy() - 0.5, size, (ri.shape[1], ri.shape[0]))
        xj = _to_pixels(out["keypoints1"].cpu().numpy() - 0.5, size, (rj.shape[1], rj.shape[0]))
        return Matches(xi, xj, out["confidence"].float().cpu().numpy())

    def __call__(self, view_i: View, view_j: View) -> Matches:
        o = self.options
        return sample_by_certainty(self.raw_matches(view_i, view_j), o.num_matches, threshold=o.sample_threshold, rng=o.seed)
