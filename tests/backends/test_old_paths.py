"""The import paths of the flat ``graphseg/backends/`` folder keep working for one release.

``graphseg/backends/`` is split by kind (``segmenters/``, ``matchers/``,
``lifters/``, ``features/``). Every old module path is kept: the four kind
packages re-export the old modules' names, and the other old modules are
shims that re-export the public names of their new home. Each re-exported
name must be the very object at its new home (so ``isinstance``, pickles and
registry lookups agree), and importing the old paths must import no torch and
raise no warning.
"""

from __future__ import annotations

import importlib
import subprocess
import sys

import pytest

#: old module -> {public name (the old module's ``__all__`` and other public names): new home}.
OLD_PATHS: dict[str, dict[str, str]] = {
    "segmenters": {
        "SuperpixelSegmenter": "segmenters.superpixel",
        "GeometricSegmenter": "segmenters.geometric",
        "GeometricOptions": "segmenters.geometric",
        "check_geometric_options": "segmenters.geometric",
        "PrecomputedSegmenter": "segmenters.precomputed",
        "OraclePartsSegmenter": "segmenters.oracle_parts",
        "geometric_segments": "segmenters.geometric",
        "SEGMENTER_PLANE": "segmenters.geometric",
        "save_precomputed": "segmenters.precomputed",
        "load_precomputed": "segmenters.precomputed",
    },
    "matchers": {
        "reprojection_matches": "matchers.reprojection",
        "flow_matches": "matchers.flow",
        "sift_matches": "matchers.sift",
        "subsample_matches": "matchers.sampling",
        "ReprojectionMatcher": "matchers.reprojection",
        "FlowMatcher": "matchers.flow",
        "SiftMatcher": "matchers.sift",
    },
    "lifters": {"RGBDLifter": "lifters.rgbd", "NO_DEPTH_MESSAGE": "lifters.rgbd"},
    "features": {"ColorFeatures": "features.color"},
    "sam": {
        **dict.fromkeys(["AutomaskOptions", "SAM2Segmenter", "SamOnnxSegmenter", "sam2_config_name", "sam2_predictor", "load_sam2"], "segmenters.sam"),
        **dict.fromkeys(["IMAGENET_MEAN", "IMAGENET_STD"], "imaging"),
    },
    "automask": dict.fromkeys(
        ["Proposals", "point_grid", "stability_score", "masks_to_boxes", "box_iou", "box_nms", "remove_small_regions", "crop_boxes", "generate_masks", "Predict"],
        "segmenters.automask",
    ),
    "hed": dict.fromkeys(["HED_MEAN_BGR", "bundled_weights", "build_hed", "load_hed_weights", "hed_edges", "HEDEdges"], "segmenters.hed"),
    "convexity": dict.fromkeys(["concave_creases", "split_concave", "ConvexitySegmenter"], "segmenters.convexity"),
    "parts": {"split_mask": "segmenters.oracle_parts"},
    "dense_matchers": {"sample_by_certainty": "matchers.sampling", "LoFTRMatcher": "matchers.loftr", "RoMaMatcher": "matchers.roma"},
    "romatch_compat": dict.fromkeys(["import_romatch", "vgg19_bn_features"], "matchers.romatch_compat"),
    "precomputed": {
        "PrecomputedLifter": "lifters.precomputed",
        "PrecomputedMatcher": "matchers.precomputed",
        "precomputed_choice": "precomputed_folders",
        "FLAGS": "precomputed_folders",
    },
    "sfm": dict.fromkeys(
        ["SfmLifter", "SfmReconstruction", "run_sfm", "NOMINAL_DISTANCE", "CAMERA_MODELS", "not_registered_message", "scale_reconstruction"], "lifters.sfm"
    ),
    "stereo": dict.fromkeys(["pair_points", "stereo_depths", "fuse_depths", "sparse_point_maps", "select_neighbours", "view_consistency"], "lifters.stereo"),
    "densify": dict.fromkeys(["fill_depth_by_regions", "color_regions"], "lifters.densify"),
    "align": dict.fromkeys(
        [
            "umeyama",
            "PairPointMaps",
            "Alignment",
            "global_align",
            "estimate_focal",
            "similarity_to_known_poses",
            "apply_similarity",
            "metric_scale",
            "NOMINAL_WORKING_DISTANCE",
            "finish_lift",
            "lift_from_alignment",
        ],
        "lifters.align",
    ),
    "dust3r": dict.fromkeys(["DUSt3RLifter", "ROLES", "InputGeometry", "input_geometry", "model_size", "preprocess", "uncrop"], "lifters.dust3r"),
    "da3": dict.fromkeys(["DA3Lifter", "load_da3", "model_size_14", "resize_for_da3", "INSTALL"], "lifters.da3"),
    "dino": dict.fromkeys(["DINOv2Features", "dinov2_arch", "patch_grid", "build_dinov2"], "features.dino"),
}

#: The registry's ``"module:Class"`` strings before the split (a user's entry point may copy one).
OLD_TARGETS = {
    ("segmenters", "superpixel"): "graphseg.backends.segmenters:SuperpixelSegmenter",
    ("segmenters", "geometric"): "graphseg.backends.segmenters:GeometricSegmenter",
    ("segmenters", "precomputed"): "graphseg.backends.segmenters:PrecomputedSegmenter",
    ("segmenters", "oracle-parts"): "graphseg.backends.segmenters:OraclePartsSegmenter",
    ("segmenters", "sam2"): "graphseg.backends.sam:SAM2Segmenter",
    ("segmenters", "sam-onnx"): "graphseg.backends.sam:SamOnnxSegmenter",
    ("segmenters", "convexity"): "graphseg.backends.convexity:ConvexitySegmenter",
    ("matchers", "reprojection"): "graphseg.backends.matchers:ReprojectionMatcher",
    ("matchers", "flow"): "graphseg.backends.matchers:FlowMatcher",
    ("matchers", "sift"): "graphseg.backends.matchers:SiftMatcher",
    ("matchers", "precomputed-matches"): "graphseg.backends.precomputed:PrecomputedMatcher",
    ("matchers", "loftr"): "graphseg.backends.dense_matchers:LoFTRMatcher",
    ("matchers", "roma"): "graphseg.backends.dense_matchers:RoMaMatcher",
    ("lifters", "rgbd"): "graphseg.backends.lifters:RGBDLifter",
    ("lifters", "precomputed-points"): "graphseg.backends.precomputed:PrecomputedLifter",
    ("lifters", "dust3r"): "graphseg.backends.dust3r:DUSt3RLifter",
    ("lifters", "da3"): "graphseg.backends.da3:DA3Lifter",
    ("lifters", "sfm"): "graphseg.backends.sfm:SfmLifter",
    ("features", "color"): "graphseg.backends.features:ColorFeatures",
    ("features", "dinov2"): "graphseg.backends.dino:DINOv2Features",
}


@pytest.mark.parametrize("old", sorted(OLD_PATHS))
def test_old_path_reexports_the_objects_of_the_new_home(old):
    mod = importlib.import_module(f"graphseg.backends.{old}")
    names = OLD_PATHS[old]
    missing = sorted(set(names) - set(mod.__all__))
    assert not missing, f"graphseg.backends.{old} no longer exports {missing}"
    for name, home in names.items():
        new = importlib.import_module(f"graphseg.backends.{home}")
        assert getattr(mod, name) is getattr(new, name), f"graphseg.backends.{old}.{name} is not graphseg.backends.{home}.{name}"
    star: dict[str, object] = {}
    exec(f"from graphseg.backends.{old} import *", star)  # every name in __all__ exists
    assert set(names) <= set(star)


def test_shims_are_modules_and_kinds_are_packages():
    kinds = {"segmenters", "matchers", "lifters", "features"}
    for old in OLD_PATHS:
        mod = importlib.import_module(f"graphseg.backends.{old}")
        assert hasattr(mod, "__path__") == (old in kinds), old
        if old not in kinds:
            assert "one release" in (mod.__doc__ or ""), f"graphseg.backends.{old} does not say it is kept for one release"
            # a shim defines nothing: every public name it holds comes from elsewhere
            own = [n for n in mod.__all__ if getattr(getattr(mod, n), "__module__", None) == mod.__name__]
            assert not own, f"graphseg.backends.{old} defines {own}"


def test_backend_classes_live_in_their_kind_package():
    from graphseg.backends import registry

    for kind in ("segmenters", "matchers", "lifters", "features"):
        reg = getattr(registry, kind)
        for name in reg.names():
            cls = reg.get(name)
            assert cls.__module__.startswith(f"graphseg.backends.{kind}."), (kind, name, cls.__module__)
            assert getattr(importlib.import_module(f"graphseg.backends.{kind}"), cls.__name__) is cls


@pytest.mark.parametrize(("kind", "name"), sorted(OLD_TARGETS))
def test_old_registry_targets_resolve_to_the_registered_class(kind, name):
    from graphseg.backends import registry

    module, _, attr = OLD_TARGETS[(kind, name)].partition(":")
    assert getattr(importlib.import_module(module), attr) is getattr(registry, kind).get(name)


def test_old_and_new_paths_import_no_torch_and_warn_nothing():
    mods = [f"graphseg.backends.{m}" for m in OLD_PATHS] + ["graphseg.backends.registry", "graphseg.backends.onnx_export"]
    code = "import sys\n" + "".join(f"import {m}\n" for m in mods) + "heavy = [m for m in ('torch', 'onnxruntime', 'pycolmap', 'cv2', 'kornia') if m in sys.modules]\nassert not heavy, heavy\n"
    out = subprocess.run([sys.executable, "-W", "error", "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
