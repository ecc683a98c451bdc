"""Kept for one release: ``graphseg.backends.sam`` moved to :mod:`graphseg.backends.segmenters.sam`.

This module only re-exports the public names of the new one; import them from
there (patch functions there too: this module's names are the same objects,
but the backends look them up in their own module). It will be removed in the
next release.

Examples
--------
>>> from graphseg.backends.segmenters import sam
>>> SAM2Segmenter is sam.SAM2Segmenter
True
"""

from .segmenters.sam import (
    IMAGENET_MEAN,
    IMAGENET_STD,
    AutomaskOptions,
    SAM2Segmenter,
    SamOnnxSegmenter,
    load_sam2,
    sam2_config_name,
    sam2_predictor,
)

__all__ = ["AutomaskOptions", "SAM2Segmenter", "SamOnnxSegmenter", "sam2_config_name", "sam2_predictor", "load_sam2", "IMAGENET_MEAN", "IMAGENET_STD"]
