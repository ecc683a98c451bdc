"""The ``color`` feature extractor for the ``dino`` edge adder: a weight-free stand-in.

Per-pixel CIE Lab colour, blurred, at a reduced resolution. Real DINO
features come from the ``dinov2`` model adapter (:mod:`graphseg.backends.features.dino`).

Examples
--------
>>> import numpy as np
>>> from graphseg.scene import View
>>> f = ColorFeatures(downsample=2)(View("0", np.zeros((8, 8, 3), np.uint8)))
>>> f.shape
(4, 4, 3)
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from ...scene import View
from ..options import Backend

__all__ = ["ColorFeatures"]


class ColorFeatures(Backend):
    """Blurred CIE Lab colour per pixel, ``[H / downsample, W / downsample, 3]``, shifted so black is not the zero vector."""

    name = "color"

    class Options(BaseModel):
        model_config = ConfigDict(extra="forbid")
        downsample: int = Field(4, ge=1, description="output pixels are downsample x downsample image pixels")
        blur: float = Field(1.0, ge=0, description="Gaussian sigma in pixels before downsampling (0: none)")

    def __call__(self, view: View) -> np.ndarray:
        import cv2

        o = self.options
        rgb = np.ascontiguousarray(view.rgb)
        lab: np.ndarray = cv2.cvtColor(rgb, cv2.COLOR_RGB2LAB).astype(np.float32)
        if o.blur > 0:
            lab = cv2.GaussianBlur(lab, (0, 0), o.blur)
        h, w = lab.shape[:2]
        small = cv2.resize(lab, (max(1, w // o.downsample), max(1, h // o.downsample)), interpolation=cv2.INTER_AREA)
        return small + np.array([1.0, 0.0, 0.0], np.float32)
