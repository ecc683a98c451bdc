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
segmenters.register("superpixel", "graphseg.backends.segmenters.superpixel:SuperpixelSegmenter")
segmenters.register("geometric", "graphseg.backends.segmenters.geometric:GeometricSegmenter")
segmenters.register("precomputed", "graphseg.backends.segmenters.precomputed:PrecomputedSegmenter")
segmenters.register("oracle-parts", "graphseg.backends.segmenters.oracle_parts:OraclePartsSegmenter")
segmenters.register("sam2", "graphseg.backends.segmenters.sam:SAM2Segmenter")
segmenters.register("sam-onnx", "graphseg.backends.segmenters.sam:SamOnnxSegmenter")
segmenters.register("convexity", "graphseg.backends.segmenters.convexity:ConvexitySegmenter")

matchers = Registry("matcher", group="graphseg.matchers")
matchers.register("reprojection", "graphseg.backends.matchers.reprojection:ReprojectionMatcher")
matchers.register("flow", "graphseg.backends.matchers.flow:FlowMatcher")
matchers.register("sift", "graphseg.backends.matchers.sift:SiftMatcher")
matchers.register("precomputed-matches", "graphseg.backends.matchers.precomputed:PrecomputedMatcher")
matchers.register("loftr", "graphseg.backends.matchers.loftr:LoFTRMatcher")
matchers.register("roma", "graphseg.backends.matchers.roma:RoMaMatcher")

lifters = Registry("lifter", group="graphseg.lifters")
lifters.register("rgbd", "graphseg.backends.lifters.rgbd:RGBDLifter")
lifters.register("precomputed-points", "graphseg.backends.lifters.precomputed:PrecomputedLifter")
lifters.register("dust3r", "graphseg.backends.lifters.dust3r:DUSt3RLifter")
lifters.register("da3", "graphseg.backends.lifters.da3:DA3Lifter")
lifters.register("sfm", "graphseg.backends.lifters.sfm:SfmLifter")

features = Registry("feature extractor", group="graphseg.features")
features.register("color", "graphseg.backends.features.color:ColorFeatures")
features.register("dinov2", "graphseg.backends.features.dino:DINOv2Features")
