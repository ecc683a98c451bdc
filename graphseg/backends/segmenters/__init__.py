"""Segmenters: a view -> over-segmentation masks (a list of boolean ``[H, W]`` masks or a label image).

One module per segmenter; the classical ones need no weights, the model
adapters load the user's files and import their packages only when built.

When to use which
-----------------
``geometric`` (default; :mod:`.geometric`)
    RGB-D tabletop scenes (depth or point maps available). Removes the table
    plane, then cuts the rest at depth discontinuities (and, optionally, at
    normal and strong colour edges). Parts rarely cross object boundaries
    because objects are separated in depth; objects that touch and share a
    depth band can merge.
``convexity`` (:mod:`.convexity`)
    ``geometric`` segments split again along concave creases.
``superpixel`` (:mod:`.superpixel`)
    RGB only. Felzenszwalb graph-based superpixels (scikit-image), a SAM-like
    over-segmentation with no geometry; parts straddling object and table are
    dropped by the background rule.
``precomputed`` (:mod:`.precomputed`)
    Masks made elsewhere (for example SAM run on a GPU machine): per-view
    label PNGs or NPZ stacks of boolean masks in a folder.
``oracle-parts`` (:mod:`.oracle_parts`)
    Evaluation only, needs ground-truth instances: every object's mask is cut
    into ``parts`` pieces by random straight cuts, so the graph stage can be
    measured apart from the segmenter.
``sam2``, ``sam-onnx`` (:mod:`.sam`, with the mask generator :mod:`.automask`)
    SAM 2 "segment everything" from the user's checkpoint or ONNX export.
HED edges (:mod:`.hed`)
    A learned edge map the ``geometric`` segmenter can also cut at (``edges="hed"``).

Every segmenter is a :class:`~graphseg.backends.options.Backend`: its
``Options`` hold the defaults (``GeometricSegmenter.Options`` the ones of
:func:`geometric_segments`, which takes them as required keywords). This
package re-exports the public names of the old ``graphseg.backends.segmenters``
module and every segmenter class.

Examples
--------
>>> import numpy as np
>>> from graphseg.scene import View
>>> rgb = np.zeros((20, 20, 3), np.uint8); rgb[:, 10:] = 255
>>> lab = SuperpixelSegmenter(scale=50, min_size=10)(View("0", rgb))
>>> lab.shape, set(lab[:, :10].ravel()).isdisjoint(lab[:, 10:].ravel())  # no part crosses the edge
((20, 20), True)
"""

from .convexity import ConvexitySegmenter
from .geometric import (
    SEGMENTER_PLANE,
    GeometricOptions,
    GeometricSegmenter,
    check_geometric_options,
    geometric_segments,
)
from .oracle_parts import OraclePartsSegmenter
from .precomputed import PrecomputedSegmenter, load_precomputed, save_precomputed
from .sam import SAM2Segmenter, SamOnnxSegmenter
from .superpixel import SuperpixelSegmenter

__all__ = [
    "SuperpixelSegmenter",
    "GeometricSegmenter",
    "GeometricOptions",
    "check_geometric_options",
    "PrecomputedSegmenter",
    "OraclePartsSegmenter",
    "geometric_segments",
    "SEGMENTER_PLANE",
    "save_precomputed",
    "load_precomputed",
    "ConvexitySegmenter",
    "SAM2Segmenter",
    "SamOnnxSegmenter",
]
