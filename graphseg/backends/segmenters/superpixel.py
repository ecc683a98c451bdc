"""The ``superpixel`` segmenter: Felzenszwalb superpixels or SLIC (scikit-image), RGB only.

A SAM-like over-segmentation with no geometry; parts straddling object and
table are dropped by the background rule.

Examples
--------
>>> import numpy as np
>>> from graphseg.scene import View
>>> rgb = np.zeros((20, 20, 3), np.uint8); rgb[:, 10:] = 255
>>> lab = SuperpixelSegmenter(scale=50, min_size=10)(View("0", rgb))
>>> lab.shape, set(lab[:, :10].ravel()).isdisjoint(lab[:, 10:].ravel())  # no part crosses the edge
((20, 20), True)
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator

from ...scene import View
from ..options import Backend

__all__ = ["SuperpixelSegmenter"]


class SuperpixelSegmenter(Backend):
    """Felzenszwalb superpixels (``method="felzenszwalb"``) or SLIC (``method="slic"``).

    ``scale`` and ``min_size`` are given for 640x480 and scaled with the image area.
    """
    parallel = True  # weight-free: views (pairs) may run in worker processes

    name = "superpixel"

    class Options(BaseModel):
        model_config = ConfigDict(extra="forbid")
        method: str = Field("felzenszwalb", description="'felzenszwalb' or 'slic'")
        scale: float = Field(400.0, ge=0, description="felzenszwalb: larger = larger segments")
        sigma: float = Field(0.8, ge=0, description="felzenszwalb: Gaussian pre-smoothing (pixels)")
        min_size: int = Field(400, ge=0, description="felzenszwalb: smallest segment (pixels at 640x480)")
        n_segments: int = Field(150, ge=1, description="slic: about this many segments")

        @field_validator("method")
        @classmethod
        def _known(cls, v: str) -> str:
            if v not in ("felzenszwalb", "slic"):
                raise ValueError(f"unknown superpixel method {v!r}; choose 'felzenszwalb' or 'slic'")
            return v

    def __call__(self, view: View) -> np.ndarray:
        from skimage.segmentation import felzenszwalb, slic

        o = self.options
        rgb = np.asarray(view.rgb)
        area = rgb.shape[0] * rgb.shape[1] / (640 * 480)
        if o.method == "felzenszwalb":
            lab = felzenszwalb(rgb, scale=o.scale, sigma=o.sigma, min_size=max(4, int(o.min_size * area)))
        else:
            lab = slic(rgb, n_segments=o.n_segments, compactness=10, start_label=0)
        return (lab + 1).astype(np.int32)
