"""Registries of backends (entry-point groups ``graphseg.segmenters``,
``graphseg.matchers``, ``graphseg.lifters``, ``graphseg.features``).

Model adapters (SAM, RoMa, DUSt3R, DINO) register here under their names once
they exist; they load weights only from files the user supplies.

Examples
--------
>>> segmenters.names()[:4]
['superpixel', 'geometric', 'precomputed', 'oracle-parts']
>>> type(matchers.resolve("reprojection", num_matches=5)).__name__
'ReprojectionMatcher'
"""

from __future__ import annotations

from ..registry import Registry

__all__ = ["segmenters", "matchers", "lifters", "features"]

segmenters = Registry("segmenter", group="graphseg.segmenters")
segmenters.register("superpixel", "graphseg.backends.segmenters:SuperpixelSegmenter")
segmenters.register("geometric", "graphseg.backends.segmenters:GeometricSegmenter")
segmenters.register("precomputed", "graphseg.backends.segmenters:PrecomputedSegmenter")
segmenters.register("oracle-parts", "graphseg.backends.segmenters:OraclePartsSegmenter")
segmenters.register("convexity", "graphseg.backends.convexity:ConvexitySegmenter")

matchers = Registry("matcher", group="graphseg.matchers")
matchers.register("reprojection", "graphseg.backends.matchers:ReprojectionMatcher")
matchers.register("flow", "graphseg.backends.matchers:FlowMatcher")
matchers.register("sift", "graphseg.backends.matchers:SiftMatcher")

lifters = Registry("lifter", group="graphseg.lifters")
lifters.register("rgbd", "graphseg.backends.lifters:RGBDLifter")

features = Registry("feature extractor", group="graphseg.features")
features.register("color", "graphseg.backends.features:ColorFeatures")
