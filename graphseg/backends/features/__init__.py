"""Feature extractors for the ``dino`` edge adder: a view -> features ``[h, w, D]``.

* ``color`` (:mod:`.color`): weight-free, blurred CIE Lab colour per pixel.
* ``dinov2`` (:mod:`.dino`): DINOv2 patch features from the user's checkpoint.

This package re-exports the public names of the old
``graphseg.backends.features`` module and every feature extractor class.

Examples
--------
>>> import numpy as np
>>> from graphseg.scene import View
>>> ColorFeatures(downsample=2)(View("0", np.zeros((8, 8, 3), np.uint8))).shape
(4, 4, 3)
"""

from .color import ColorFeatures
from .dino import DINOv2Features

__all__ = ["ColorFeatures", "DINOv2Features"]
