"""Kept for one release: ``graphseg.backends.convexity`` moved to :mod:`graphseg.backends.segmenters.convexity`.

This module only re-exports the public names of the new one; import them from
there (patch functions there too: this module's names are the same objects,
but the backends look them up in their own module). It will be removed in the
next release.

Examples
--------
>>> from graphseg.backends.segmenters import convexity
>>> ConvexitySegmenter is convexity.ConvexitySegmenter
True
"""

from .segmenters.convexity import ConvexitySegmenter, concave_creases, split_concave

__all__ = ["concave_creases", "split_concave", "ConvexitySegmenter"]
