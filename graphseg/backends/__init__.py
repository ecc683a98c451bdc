"""Backends: segmenters, matchers, lifters and feature extractors behind protocols and registries.

Built-ins are weight-free (see each module); model adapters register under the
same entry-point groups. The registries live in :mod:`graphseg.backends.registry`
and resolve a name, a class or an instance:

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
