"""One contract for every registered backend: a pydantic ``Options`` that holds its defaults once.

Every built-in segmenter, matcher, lifter and feature extractor derives from
:class:`graphseg.backends.options.Backend`, is built as ``Backend(options)`` or
``Backend(**kwargs)``, rejects a misspelt option with one line (did-you-mean)
before it touches any file or package, and declares the run-wide settings it
takes (``seed``, ``num_matches``) as ``Options`` fields, which is what the
pipeline reads to pass them.
"""

import inspect

import numpy as np
import pytest
from pydantic import BaseModel

from graphseg.backends import registry
from graphseg.backends.features.color import ColorFeatures
from graphseg.backends.lifters.sfm import SfmLifter, run_sfm
from graphseg.backends.matchers.flow import FlowMatcher, flow_matches
from graphseg.backends.matchers.precomputed import PrecomputedMatcher
from graphseg.backends.matchers.reprojection import ReprojectionMatcher, reprojection_matches
from graphseg.backends.matchers.sift import SiftMatcher, sift_matches
from graphseg.backends.options import Backend, backend_options, option_fields
from graphseg.backends.segmenters.convexity import (
    ConvexitySegmenter,
    concave_creases,
    split_concave,
)
from graphseg.backends.segmenters.geometric import (
    GeometricOptions,
    GeometricSegmenter,
    geometric_segments,
)
from graphseg.backends.segmenters.oracle_parts import OraclePartsSegmenter
from graphseg.backends.segmenters.superpixel import SuperpixelSegmenter
from graphseg.config import Config
from graphseg.pipeline import resolve_backend
from graphseg.scene import SceneError

KINDS = {"segmenter": registry.segmenters, "matcher": registry.matchers, "lifter": registry.lifters, "features": registry.features}
BUILTINS = [(kind, name) for kind, reg in KINDS.items() for name, target in reg._targets.items() if isinstance(target, str) and target.startswith("graphseg.")]


def test_the_builtins_are_all_listed():
    assert len(BUILTINS) == 20
    assert {n for _, n in BUILTINS} >= {"geometric", "superpixel", "sam2", "reprojection", "roma", "rgbd", "sfm", "dust3r", "da3", "color", "dinov2"}


@pytest.mark.parametrize("kind, name", BUILTINS, ids=[n for _, n in BUILTINS])
def test_every_builtin_backend_is_a_backend_with_options(kind, name):
    cls = KINDS[kind].get(name)
    assert issubclass(cls, Backend) and cls.name == name
    assert isinstance(cls.Options, type) and issubclass(cls.Options, BaseModel)
    assert cls.Options.model_config.get("extra") == "forbid"
    # the constructor writes no default of its own: options come through Options alone
    params = inspect.signature(cls.__init__).parameters
    assert [p for p in params if p not in ("self", "options", "kwargs")] == [], params
    assert list(inspect.signature(cls).parameters)[1:] == list(cls.Options.model_fields)


@pytest.mark.parametrize("kind, name", BUILTINS, ids=[n for _, n in BUILTINS])
def test_a_misspelt_option_fails_first_with_one_line(kind, name):
    """Before any checkpoint, folder or package is looked at (model backends included)."""
    with pytest.raises(SceneError) as err:
        KINDS[kind].resolve(name, zz_no_such_option=1)
    msg = str(err.value)
    assert msg.startswith(f"backends.options.{name}.zz_no_such_option: unknown option 'zz_no_such_option'; valid keys: ") and "\n" not in msg
    assert err.value.field == f"backends.options.{name}.zz_no_such_option"


def test_did_you_mean_and_bad_values():
    with pytest.raises(SceneError, match=r"^backends.options.geometric.min_aera: unknown option 'min_aera'; valid keys: .*; did you mean 'min_area'\?$"):
        GeometricSegmenter(min_aera=5)
    with pytest.raises(SceneError, match=r"^backends.options.reprojection.stride: Input should be greater than or equal to 1 \(got 0\)$"):
        ReprojectionMatcher(stride=0)
    with pytest.raises(SceneError, match=r"^backends.options.sfm.camera_model: unknown camera_model 'FISHEYE'; choose one of SIMPLE_PINHOLE, "):
        SfmLifter(camera_model="FISHEYE")
    with pytest.raises(SceneError, match=r"^backends.options.sift.ransac_threshold: expected a finite number \(got inf\)$"):
        SiftMatcher(ransac_threshold=float("inf"))
    with pytest.raises(SceneError, match=r"^backends.options.color.blur: Input should be greater than or equal to 0 \(got nan\)$"):
        ColorFeatures(blur=float("nan"))
    with pytest.raises(SceneError, match=r"backends.options.geometric.background.plane_tolerance: "):
        GeometricSegmenter(background={"plane_tolerance": -1})


def test_built_from_options_or_keywords_alike():
    a = ReprojectionMatcher(ReprojectionMatcher.Options(stride=2, seed=4))
    b = ReprojectionMatcher(stride=2, seed=4)
    c = ReprojectionMatcher({"stride": 2, "seed": 4})
    assert a.options == b.options == c.options
    assert repr(b) == "ReprojectionMatcher(Options(num_matches=10000, seed=4, abs_tol=0.005, rel_tol=0.01, stride=2, max_color_distance=None, color_blur=2.0))"
    with pytest.raises(TypeError, match="either as an Options instance or as keywords, not both"):
        ReprojectionMatcher(ReprojectionMatcher.Options(), seed=1)
    with pytest.raises(TypeError, match="expected Options options \\(got Options\\)"):
        ReprojectionMatcher(FlowMatcher.Options())
    opts = ReprojectionMatcher.Options.model_construct(abs_tol=float("inf"))
    with pytest.raises(SceneError, match="abs_tol: expected a finite number"):
        backend_options(ReprojectionMatcher, opts, {})


def test_a_geometric_background_dict_becomes_a_background_config():
    from graphseg.background_config import BackgroundConfig

    seg = GeometricSegmenter(background={"plane": False, "max_distance": None})
    assert isinstance(seg.options.background, BackgroundConfig) and seg.options.background.plane is False


def test_the_defaults_are_the_former_constructor_defaults():
    """The literals the constructors' signatures carried before they moved into Options."""
    assert SuperpixelSegmenter.Options().model_dump() == {"method": "felzenszwalb", "scale": 400.0, "sigma": 0.8, "min_size": 400, "n_segments": 150}
    assert GeometricSegmenter.Options().model_dump() == {
        "background": None, "depth_abs": 0.01, "depth_rel": 0.02, "normal_angle": None, "color_threshold": 40.0, "color_blur": 2.0,
        "min_area": 60, "fill_radius": 4, "color_regions": 16.0, "region_scale": 100.0, "edge_threshold": 0.5,
        "seed": 0, "edges": None, "hed_weights": None,
    }  # fmt: skip
    assert OraclePartsSegmenter.Options().model_dump() == {"parts": 2, "seed": 0}
    assert ReprojectionMatcher.Options().model_dump() == {
        "num_matches": 10_000, "seed": 0, "abs_tol": 0.005, "rel_tol": 0.01, "stride": 1, "max_color_distance": None, "color_blur": 2.0,
    }  # fmt: skip
    assert FlowMatcher.Options().model_dump() == {"num_matches": 10_000, "seed": 0, "max_fb_error": 1.0, "stride": 2}
    assert SiftMatcher.Options().model_dump() == {"num_matches": 10_000, "seed": 0, "ratio": 0.8, "ransac_threshold": 1.5}
    assert PrecomputedMatcher.Options().model_dump() == {"folder": None, "missing": "empty", "num_matches": None}
    assert ColorFeatures.Options().model_dump() == {"downsample": 4, "blur": 1.0}
    assert SfmLifter.Options().model_dump() == {
        "peak_threshold": 0.002, "min_tri_angle": 2.0, "num_threads": 2, "stereo": True, "max_pair_angle": 45.0, "max_neighbours": 4,
        "sparse_radius": 1, "fill": "planes", "fill_confidence": 0.25, "seed": 0, "ransac_seed": None, "consistency": False,
        "transfer": True, "transfer_min_confidence": 0.5, "transfer_color_distance": 30.0, "camera_model": "SIMPLE_PINHOLE",
        "fov_range": (35.0, 110.0), "redraws": 2, "use_poses": True, "min_span": 2.0, "stereo_check": 0.2, "focal_starts": (), "prior_fov": 65.0,
    }  # fmt: skip


#: (backend class, pure function it wraps, function parameters that are its options)
PURE = [
    (ReprojectionMatcher, reprojection_matches, ("abs_tol", "rel_tol", "stride", "max_color_distance", "color_blur")),
    (FlowMatcher, flow_matches, ("max_fb_error", "stride")),
    (SiftMatcher, sift_matches, ("ratio", "ransac_threshold")),
    (GeometricSegmenter, geometric_segments, tuple(GeometricOptions.model_fields)),
    (ConvexitySegmenter, concave_creases, ("threshold", "normal_step", "reach")),
    (ConvexitySegmenter, split_concave, ("threshold", "normal_step", "reach", "min_area")),
    (SfmLifter, run_sfm, ("peak_threshold", "min_tri_angle", "seed", "camera_model")),
]


@pytest.mark.parametrize("owner, fn, names", PURE, ids=[f.__name__ for _, f, _ in PURE])
def test_pure_functions_take_the_options_as_required_keywords_or_as_one_object(owner, fn, names):
    params = inspect.signature(fn).parameters
    assert set(names) <= set(owner.Options.model_fields)
    if "options" in params:  # the options object itself (the Options, or what it gives): none of its fields beside it
        assert not set(names) & set(params), f"{fn.__name__} takes options and some of their fields"
        return
    assert set(names) <= set(params)
    written_twice = [f"{p}={params[p].default!r}" for p in names if params[p].default is not inspect.Parameter.empty]
    assert not written_twice, f"{fn.__name__}: defaults also in {owner.__name__}.Options: {written_twice}"


def test_run_wide_settings_come_from_the_options_fields():
    assert option_fields(GeometricSegmenter) >= {"seed"} and "seed" not in option_fields(SuperpixelSegmenter)
    assert {"seed", "num_matches"} <= option_fields(ReprojectionMatcher)
    assert option_fields(PrecomputedMatcher) & {"seed", "num_matches"} == {"num_matches"}
    cfg = Config(seed=7, backends={"num_matches": 123})
    assert resolve_backend("segmenter", "geometric", cfg).options.seed == 7
    assert resolve_backend("segmenter", "superpixel", cfg).options.scale == 400.0  # takes no seed: none passed
    m = resolve_backend("matcher", "reprojection", cfg)
    assert (m.options.seed, m.options.num_matches) == (7, 123)
    over = Config(seed=7, backends={"options": {"reprojection": {"seed": 2}}})
    assert resolve_backend("matcher", "reprojection", over).options.seed == 2  # the backend's own option wins
    assert resolve_backend("lifter", "sfm", cfg).options.seed == 0  # lifters get no run-wide settings


def test_a_class_without_options_gets_no_run_wide_settings():
    class Legacy:  # a plain third-party class: no Options, so nothing is injected
        name = "legacy"

        def __init__(self, seed=5):
            self.seed = seed

        def __call__(self, view):
            return np.zeros(view.shape, np.int32)

    registry.segmenters.register("testing_legacy", Legacy)
    try:
        assert resolve_backend("segmenter", "testing_legacy", Config(seed=9)).seed == 5
    finally:
        registry.segmenters.unregister("testing_legacy")


def test_job_reports_a_misspelt_option_before_reading_images():
    from graphseg.pipeline import resolve_backends

    cfg = Config(backends={"options": {"geometric": {"min_aera": 5}}})
    with pytest.raises(SceneError, match="backends.options.geometric.min_aera: unknown option 'min_aera'.*did you mean 'min_area'"):
        resolve_backends(cfg)
