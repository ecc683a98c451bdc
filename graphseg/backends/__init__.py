"""Backends: segmenters, matchers, lifters and feature extractors behind protocols and registries.

One subpackage per kind, one module per backend, the model adapters beside
the classical ones of their kind:

* :mod:`graphseg.backends.segmenters`: ``geometric``, ``superpixel``,
  ``precomputed``, ``oracle_parts``, ``convexity``; ``sam`` (+ ``automask``), ``hed``;
* :mod:`graphseg.backends.matchers`: ``reprojection``, ``flow``, ``sift``,
  ``precomputed``, ``sampling``; ``loftr``, ``roma`` (+ ``romatch_compat``);
* :mod:`graphseg.backends.lifters`: ``rgbd``, ``precomputed``, ``sfm`` (+ ``stereo``,
  ``densify``); ``dust3r``, ``da3`` (+ ``align``);
* :mod:`graphseg.backends.features`: ``color``; ``dino``.

What every kind shares stays here: ``options`` (the :class:`Backend` base),
``protocols``, ``registry``, ``weights``, ``imaging``, ``precomputed_folders``,
``onnx_export``.

The classical backends are weight-free; model adapters load the user's files
and import their packages only when built. The registries live in
:mod:`graphseg.backends.registry` and resolve a name, a class or an instance:

>>> from graphseg.backends.registry import segmenters, matchers
>>> segmenters.names()[:2], type(matchers.resolve("reprojection")).__name__
(['superpixel', 'geometric'], 'ReprojectionMatcher')

Every backend is a :class:`Backend`: a ``name``, one pydantic ``Options``
model that holds its defaults, built as ``Backend(options)`` or
``Backend(**kwargs)`` (see :mod:`graphseg.backends.options`).
"""

from .options import Backend
from .protocols import FeatureExtractor, Lifter, Matcher, Segmenter

__all__ = ["Backend", "Segmenter", "Matcher", "Lifter", "FeatureExtractor"]
