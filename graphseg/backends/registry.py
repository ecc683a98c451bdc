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
segmenters.register("sam2", "graphseg.backends.sam:SAM2Segmenter")
segmenters.register("sam-onnx", "graphseg.backends.sam:SamOnnxSegmenter")
segmenters.register("convexity", "graphseg.backends.convexity:ConvexitySegmenter")

matchers = Registry("matcher", group="graphseg.matchers")
matchers.register("reprojection", "graphseg.backends.matchers:ReprojectionMatcher")
matchers.register("flow", "graphseg.backends.matchers:FlowMatcher")
matchers.register("sift", "graphseg.backends.matchers:SiftMatcher")
matchers.register("precomputed-matches", "graphseg.backends.precomputed:PrecomputedMatcher")
matchers.register("loftr", "graphseg.backends.dense_matchers:LoFTRMatcher")
matchers.register("roma", "graphseg.backends.dense_matchers:RoMaMatcher")

lifters = Registry("lifter", group="graphseg.lifters")
lifters.register("rgbd", "graphseg.backends.lifters:RGBDLifter")
lifters.register("precomputed-points", "graphseg.backends.precomputed:PrecomputedLifter")
lifters.register("dust3r", "graphseg.backends.dust3r:DUSt3RLifter")
lifters.register("da3", "graphseg.backends.da3:DA3Lifter")
lifters.register("sfm", "graphseg.backends.sfm:SfmLifter")

features = Registry("feature extractor", group="graphseg.features")
features.register("color", "graphseg.backends.features:ColorFeatures")
features.register("dinov2", "graphseg.backends.dino:DINOv2Features")
