"""Backend protocols: what a segmenter, matcher, lifter or feature extractor must provide.

Backends return plain arrays and :mod:`graphseg.scene` types; they never
import the graph package.

Examples
--------
>>> from graphseg.backends.segmenters.superpixel import SuperpixelSegmenter
>>> isinstance(SuperpixelSegmenter(), Segmenter)
True
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from ..scene import Matches, Scene, View

__all__ = ["Segmenter", "Matcher", "Lifter", "FeatureExtractor"]


@runtime_checkable
class Segmenter(Protocol):
    """``view -> masks``: a list of boolean ``[H, W]`` masks (may overlap) or an int label image ``[H, W]``."""

    name: str

    def __call__(self, view: View) -> list[np.ndarray] | np.ndarray: ...


@runtime_checkable
class Matcher(Protocol):
    """``(view_i, view_j) -> Matches`` (pixel coordinates in each image + certainty)."""

    name: str

    def __call__(self, view_i: View, view_j: View) -> Matches: ...


@runtime_checkable
class Lifter(Protocol):
    """``scene -> scene`` whose views carry ``points`` (world, NaN = invalid), ``confidence``, ``K`` and ``cam_to_world``."""

    name: str

    def __call__(self, scene: Scene) -> Scene: ...


@runtime_checkable
class FeatureExtractor(Protocol):
    """``view -> features`` float ``[h, w, D]`` (any resolution), for the ``dino`` edge adder."""

    name: str

    def __call__(self, view: View) -> np.ndarray: ...


