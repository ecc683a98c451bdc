"""Configuration of a GraphSeg run: every threshold, the stages, the contractor, the seed.

A :class:`Config` is a pydantic model, so it validates on construction, rejects
unknown keys (typos fail loudly), and loads from / saves to YAML or JSON.

``stages`` is the whole method, one ordered list of steps. First the edge
stages: each a list of edge criteria, given by name or as ``{name:
{options}}``, followed by a contraction. Then the graph operations
(:mod:`graphseg.method.operations`), by name: the minimum support, the 3D split,
the joins, and last the pixel refiners. A list of edge stages alone gets the
minimum support (``support``, ``support_final``). Options are validated
against the installed criterion's or operation's ``Options`` model when the
config is built, so a misspelt option or an unknown name fails at once,
naming the key and listing the valid ones::

    stages:
      - [pixel_match]
      - [{chamfer_3d: {tau: 5.0e-5}}, {my_criterion: {k: 3}}]
      - support
      - split                   # its options: the split section
      - support_final
    contractor: star            # or {name: {options}}

Old config files still load (:func:`migrate_config`): top-level
``pixel_match:``, ``chamfer_3d:``, ``dino:`` or ``adder_options:`` sections
move into the stage entries of that criterion, and ``enabled`` in the
``split``, ``refine``, ``grow`` and ``trim`` sections becomes those
operations in ``stages``.

Examples
--------
>>> cfg = Config()
>>> cfg.stage_names()
[['pixel_match'], ['chamfer_3d']]
>>> cfg.step_names()                       # the whole method: edge stages, then graph operations
[['pixel_match'], ['chamfer_3d'], 'support', 'split', 'merge', 'join_shared', 'mask_join', 'snap', 'support_final']
>>> Config.minus().stage_names()          # GraphSeg-minus: no 3D stage
[['pixel_match']]
>>> cfg.criterion_options("chamfer_3d")["tau"]        # the official code's tau_3D, measured for metric RGB-D input
5e-05
>>> Config.preset("paper").criterion_options("chamfer_3d")["tau"]   # the paper's
0.0005
>>> Config(stages=[["pixel_match"], [{"chamfer_3d": {"taus": 1}}]])
Traceback (most recent call last):
...
pydantic_core._pydantic_core.ValidationError: 1 validation error for Config
stages.1.edges.0
  chamfer_3d: unknown option 'taus'; valid options: tau, voxel_size, stride, outliers, outlier_k, outlier_std_ratio, dbscan_eps, dbscan_min_samples, prune, min_confidence, spacing_factor, fragment_ratio; did you mean 'tau'? [type=criterion_options, input_value={'chamfer_3d': {'taus': 1}}, input_type=dict]

Every number must be finite (``.inf`` and ``.nan`` are refused), and
:func:`validation_message` turns a validation error into the one line the
command line prints::

    >>> from pydantic import ValidationError
    >>> try:
    ...     Config(background={"plane_tolerence": 0.02})
    ... except ValidationError as err:
    ...     print(validation_message(err))  # doctest: +ELLIPSIS
    background.plane_tolerence: unknown key 'plane_tolerence'; did you mean 'plane_tolerance'? valid keys: enabled, plane, plane_tolerance, ...
"""

from __future__ import annotations

import json
import types
import typing
from os import PathLike
from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Discriminator,
    Field,
    Tag,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_serializer,
    model_validator,
)
from pydantic_core import PydanticCustomError

from .background_config import BackgroundConfig
from .background_config import SectionModel as _Model
from .presets import (
    BASE_STAGES,
    CANONICAL_ORDER,
    DEFAULT_PRESET,
    MINIMUM_SUPPORT,
    PRESET_NAMES,
    PRESETS,
    SPLIT_FAMILY,
)

__all__ = [
    "Config",
    "BackgroundConfig",
    "MaskConfig",
    "ObjectConfig",
    "LiftedConfig",
    "PairConfig",
    "CriterionSpec",
    "ContractorSpec",
    "migrate_config",
    "OutputConfig",
    "RefineConfig",
    "SplitConfig",
    "TrimConfig",
    "GrowConfig",
    "BackendConfig",
    "PRESETS",
    "DEFAULT_PRESET",
    "PRESET_NAMES",
    "load_yaml_text",
    "validation_message",
    "load_error_message",
]


class MaskConfig(_Model):
    """Mask composition."""

    min_area: int = Field(20, ge=1, description="composed masks with fewer visible pixels are dropped")


class ObjectConfig(_Model):
    """The minimum support of an object; objects below it become background.

    A final super-vertex is kept as an object only if it has at least
    ``min_point_fraction`` of one view's pixels in valid 3D points over all
    views (3e-4: 92 points at 640x480; fractions, so the rules do not depend on
    the image size) and it is seen in at least ``min(min_views, number of
    views)`` views: the views it has masks in, plus, for an object of at least
    ``confirm_fraction`` of a view's pixels, the other views that see its
    points where they are (foreground at the same depth; a graph that left an
    object unmerged does not lose it). Below that it is a stray fragment (a
    patch of table texture, a floor tile lifted to the wrong depth), not an
    object: its masks get object id 0 and ``Result.info["support"]`` lists it.
    With ``merge_seen``, such a one-view object joins the object with full
    support that most of its confirming pixels belong to (the graph missed
    the edge): 38 of the 76 rows of ``bench_quality.py`` rose, none fell.
    The final objects, after the split and the joins, need the same support
    again (the split's parts are often strips of table), and at least
    ``min_object_fraction`` of one view's pixels in valid points over all
    views (0, the default: ``min_point_fraction`` only; a prior on how small
    an object looks, for estimated points, whose fragments the graph cannot
    join). ``min_measured`` is for estimated points: a lifter that fills holes
    (the ``sfm`` lifter's colour-region planes) records the confidence it gives
    a point that nothing measured (``View.meta["fill_confidence"]``), and an
    object of which less than this share has a point above it, so mostly
    surfaces the fill invented, is background (0, the default, turns it off;
    views without the record count as measured).
    """

    min_views: int = Field(2, ge=1, description="views an object must be seen in (capped at the number of views)")
    min_point_fraction: float = Field(3e-4, ge=0, le=1, description="valid 3D points an object needs over all views, as a fraction of one view's pixels")
    confirm_fraction: float = Field(
        2e-3, ge=0, le=1, description="an object in fewer views than min_views may count the other views that see it only from this size up (fraction of one view's pixels)"
    )
    merge_seen: bool = Field(True, description="a one-view object that the other views see as one object with full support joins it")
    min_object_fraction: float = Field(
        0.0,
        ge=0,
        le=1,
        description="valid 3D points every final object (after the split and the joins) needs over all views, as a fraction of one view's pixels (at least min_point_fraction; smaller final objects become background)",
    )
    min_measured: float = Field(
        0.0,
        ge=0,
        le=1,
        description="share of an object's points that measurement must support (confidence above the lifter's fill confidence, View.meta['fill_confidence']); below it the object is background (0: off; views without the record count as measured)",
    )


#: ``LiftedConfig.split``'s default: estimated points never join objects by their 3D cut, split below 0.025, and join by border at 0.3.
_DEFAULT_LIFTED_SPLIT: dict[str, Any] = {"merge_ncut": None, "max_ncut": 0.025, "join_shared": 0.3}
_DEFAULT_LIFTED_TRIM: dict[str, Any] = {"enabled": True}
#: ``LiftedConfig.objects``' default: an object mostly of filled-in points, and a final object under 0.8% of a view's pixels, is not one.
_DEFAULT_LIFTED_OBJECTS: dict[str, Any] = {"min_measured": 0.1, "min_object_fraction": 0.008}


class TrimConfig(_Model):
    """Rim trimming after segmentation (:func:`graphseg.method.trim.trim_rims`).

    A labelled pixel within ``rim`` pixels of an unlabelled one loses its label
    when its colour is closer to the unlabelled pixels around it than to the
    objects' interior. Off for measured depth; on for estimated points
    (``lifted.trim``), whose depth runs a few pixels over object silhouettes
    (the band of table pixels labelled with an object held 3.1% of the object
    pixels on the tuning half of ``bench_rgb_only.py``; ``docs/results.md``).
    """

    window: int = Field(7, ge=1, description="pixels, odd: window of the background colour (the interior's is 3 times as wide)")
    rim: int = Field(3, ge=1, description="pixels: only labelled pixels this close to an unlabelled one are tested")
    blur: float = Field(1.0, ge=0, description="pixels: Gaussian blur before the colours are read")

    @field_validator("window")
    @classmethod
    def _odd_window(cls, v: int) -> int:
        if v % 2 == 0:
            raise ValueError(f"expected an odd window, so that it is centred on the pixel (got {v})")
        return v


_DEFAULT_LIFTED_GROW: dict[str, Any] = {"enabled": True}


class GrowConfig(_Model):
    """Rim growing after segmentation (:func:`graphseg.method.grow.grow_rims`).

    Every unlabelled pixel within ``band`` pixels of an object goes to it when
    the object floods it first on the colour gradient, so the object's border
    moves out to the strongest colour edge in that ring. On for estimated
    points (``lifted.grow``; there it runs before the trim: the tune half of
    ``bench_rgb_only.py``, two RANSAC draws, 0.8006 -> 0.8192 and 0.7574 ->
    0.7748). Off for measured depth in every preset: on YCB-Video, whose depth
    is shifted by a few pixels against colour at object rims, it raised the
    tune half of ``bench_ycb_views.py`` (geometric masks, mean over 3, 5 and
    10 views) from 0.8871 to 0.8976, but lowered the
    YCB-Video rows of ``bench_quality.py`` whose masks are the ground truth
    (oracle parts, 0.960 -> 0.948), where the ground truth's silhouettes stop a
    pixel or two short of the colour edge (``docs/results.md``, round 22).
    """

    band: int = Field(6, ge=1, description="pixels: width of the ring around the objects that is flooded again")
    blur: float = Field(1.0, ge=0, description="pixels: Gaussian blur before the colour gradient is taken")


class LiftedConfig(_Model):
    """Criterion and object options for point maps that a lifter estimated from images (not measured depth).

    Points from structure from motion or a learned lifter are noisier near
    object borders than measured depth, and small noisy super-vertices then
    bridge two objects in the 3D stage. When the scene was lifted by one of
    ``lifters``, every stage entry of a criterion named in ``criteria`` gets
    those options on top of its own (:meth:`Config.for_lifter`; the options are
    validated like any stage entry). The default gives ``chamfer_3d`` a
    ``fragment_ratio`` of 0.5, chosen on the tuning half of
    ``bench_rgb_only.py``; measured depth keeps the preset's options (the same
    rule lowered YCB-Video 0001 at 3 and 5 views; ``docs/results.md``).
    ``objects`` goes on top of :class:`ObjectConfig` the same way. Its
    default, ``{min_measured: 0.1, min_object_fraction: 0.008}``, keeps the
    surfaces that structure from motion's hole filling invented, and the
    strips of table that the split cut off an object, from counting as
    objects: photos only, ``bench_rgb_only.py`` scenes gave up to 38 objects
    for 8 and 93 for 6, nearly all of them floor, wall or table pieces. An
    object less than 10% of whose points stereo or triangulation measured is
    background, and so is a final object (after the split and the joins)
    with fewer valid points than 0.8% of one view's pixels over all views.
    Chosen on the tuning half (issue 52, segmenting the same lifts): 3 -> 13
    of 15 scenes within one object of the true count, mean |predicted -
    true| 12.8 -> 0.7, mean IoU 0.755 -> 0.757 (the extra pool: 3 -> 10 of
    15, IoU 0.685 -> 0.683). ``min_measured`` 0.2 did as well there (12 of
    15, IoU 0.762) but dropped real objects on the check half where
    structure from motion measured little of them (``arc20-3v-mixed-s2005``:
    IoU 0.82 -> 0.45); the tuning half's real objects were measured down to
    22%, and 0.1 leaves that margin. The size threshold applied before the
    split instead (``min_point_fraction``) lost pieces of real objects before
    the joins could put them together (tuning half IoU 0.747). This default
    yields to the ``objects`` fields the user changed, like ``split`` below;
    a ``lifted.objects`` given by the user replaces it.
    ``split`` goes on top of :class:`SplitConfig`: by default estimated points
    never join objects (``merge_ncut`` None), since their smoothed surfaces make
    touching objects look like one body (the join lowered the tuning half of
    ``bench_rgb_only.py`` from 0.686 to 0.659), and they are split at cuts
    below ``max_ncut`` 0.025 instead of 0.012. The likely reason: the same
    smoothing makes the crease between two touching objects shallower, so the
    convexity graph links strongly across it and the cut between them costs
    more than on measured depth (tuning half 0.686 -> 0.704; 0.015, 0.02 and
    0.03 gave 0.689, 0.696 and 0.695; measured with ``sfm`` only;
    ``docs/results.md``). Pieces of one object that share most of their image
    border, with no depth step across it, are joined instead (``join_shared``
    0.3, :func:`graphseg.method.join.join_objects`: tuning half 0.783 -> 0.800;
    0.35 and 0.4 gave 0.795 and 0.791). This default yields to the ``split`` section: a
    field the user changed there from its :class:`SplitConfig` default (say
    ``split.max_ncut``) keeps the user's value for estimated points too. A
    ``lifted.split`` given by the user replaces the whole default and goes on
    top of ``split``: ``{"max_ncut": 0.02}`` alone turns the join back on for
    estimated points.
    ``trim`` goes on top of :class:`TrimConfig` (default ``{enabled: true}``:
    estimated points have their object rims trimmed by colour; tuning half
    0.751 -> 0.769, ``docs/results.md``). The other ``trim`` fields (window,
    rim, blur) come from the ``trim`` section; ``trim.enabled: false`` there
    does not turn it off for estimated points, ``lifted.trim: {enabled: false}``
    does. ``grow`` goes on top of :class:`GrowConfig` the same way (default
    ``{enabled: true}``: objects on estimated points first take the unlabelled
    pixels at their rims up to the colour edge, then the trim takes off what
    looks like the background; tuning half 0.8006 -> 0.8192).
    ``preset`` (None by default) replaces the stages and the contractor with
    those of a preset before ``criteria`` apply. ``backend_options`` gives the
    segmenter and matcher that run on the estimated points their defaults; an
    option set in ``backends.options`` (or with ``--backend-option``) still
    wins. The default gives the ``reprojection`` matcher a colour test
    (``max_color_distance`` 30, CIE Lab): estimated points put some pixels on
    the wrong surface, and their reprojections land on another object.
    Chosen on the tuning half of ``bench_rgb_only.py`` (mean IoU 0.665 -> 0.679;
    20 gave the same, 45 gave 0.666; ``docs/results.md``).
    """

    lifters: list[str] = Field(default_factory=lambda: ["sfm", "dust3r", "da3"], description="lifters whose points get these options")
    preset: str | None = Field(None, description="a preset whose stages and contractor estimated points run with (None: the configuration's own)")
    criteria: dict[str, dict[str, Any]] = Field(
        default_factory=lambda: {"chamfer_3d": {"fragment_ratio": 0.5}}, description="criterion name -> options applied on top of its stage entries"
    )
    objects: dict[str, Any] = Field(
        default_factory=lambda: dict(_DEFAULT_LIFTED_OBJECTS),
        description="ObjectConfig fields applied on top of the objects section (default: min_measured 0.1 and min_object_fraction 0.008, unless the objects section changed those fields)",
    )
    split: dict[str, Any] = Field(
        default_factory=lambda: dict(_DEFAULT_LIFTED_SPLIT),
        description="SplitConfig fields applied on top of the split section (default: estimated points never join objects by their 3D cut, split below 0.025 and join pieces by border at 0.3, unless the split section changed those fields)",
    )
    backend_options: dict[str, dict[str, Any]] = Field(
        default_factory=lambda: {"reprojection": {"max_color_distance": 30.0}}, description="backend name -> options for estimated points (backends.options still wins)"
    )
    trim: dict[str, Any] = Field(
        default_factory=lambda: dict(_DEFAULT_LIFTED_TRIM),
        description="TrimConfig fields applied on top of the trim section (default: rims trimmed; {enabled: false} turns it off for estimated points)",
    )

    grow: dict[str, Any] = Field(
        default_factory=lambda: dict(_DEFAULT_LIFTED_GROW),
        description="GrowConfig fields applied on top of the grow section (default: rims grown; {enabled: false} turns it off for estimated points)",
    )

    @field_validator("trim", "grow")
    @classmethod
    def _known_rim_fields(cls, v: dict[str, Any], info: ValidationInfo) -> dict[str, Any]:
        if not isinstance(v.get("enabled", False), bool):
            raise ValueError(f"enabled: expected true or false (got {v['enabled']!r})")
        {"trim": TrimConfig, "grow": GrowConfig}[str(info.field_name)].model_validate({k: x for k, x in v.items() if k != "enabled"})  # enabled: the operation on or off
        return v

    @field_validator("objects")
    @classmethod
    def _known_object_fields(cls, v: dict[str, Any]) -> dict[str, Any]:
        ObjectConfig.model_validate(v)  # unknown field or bad value: one line naming it
        return v

    @field_validator("split")
    @classmethod
    def _known_split_fields(cls, v: dict[str, Any]) -> dict[str, Any]:
        if not isinstance(v.get("enabled", False), bool):
            raise ValueError(f"enabled: expected true or false (got {v['enabled']!r})")
        SplitConfig.model_validate({k: x for k, x in v.items() if k != "enabled"})  # enabled: the split's operations on or off
        return v

    @field_validator("preset")
    @classmethod
    def _known_preset(cls, v: str | None) -> str | None:
        if v is not None and v not in PRESETS:
            raise ValueError(f"unknown preset {v!r}; choose one of {', '.join(PRESETS)}")
        return v

    @field_validator("criteria")
    @classmethod
    def _known_criteria(cls, v: dict[str, dict[str, Any]]) -> dict[str, dict[str, Any]]:
        for name, opts in v.items():
            CriterionSpec.model_validate({name: opts})  # unknown criterion or option: one line naming it
        return v


class PairConfig(_Model):
    """Which view pairs are matched."""

    mode: Literal["auto", "pose", "all"] = Field("auto", description="'pose': close camera poses only; 'all': every pair; 'auto': 'all' up to auto_max_views views, else 'pose'")
    auto_max_views: int = Field(8, ge=2)
    max_rotation: float = Field(1.2, gt=0, description="radians")
    max_translation: float | None = Field(None, gt=0, description="metres; None: translation_scale x scene scale")
    translation_scale: float = Field(1.0, gt=0)


class RefineConfig(_Model):
    """Per-pixel refinement after contraction (:func:`graphseg.method.refine.refine_labels`).

    Every object pixel is relabelled by the objects that the other views give
    its 3D point, when at least ``min_views`` views agree and outweigh its own
    label. Off by default: on YCB-Video (``benchmarks/bench_ycb_views.py``) it
    moved the mean IoU by -0.003 to +0.007 and costs 0.2-0.5 s per 10 views
    (docs/results.md); the errors there are whole masks, not pixels.
    """

    tolerance: float = Field(0.02, gt=0, description="relative depth agreement for another view to see a pixel's point")
    self_weight: float = Field(1.0, ge=0, description="weight of a pixel's own label against the other views' votes")
    min_views: int = Field(2, ge=1, description="other views that must vote for a new object")


class SplitConfig(_Model):
    """Options of the 3D split and its joins: the graph operations ``split``, ``merge``, ``join_shared``, ``mask_join`` and ``snap``.

    Each operation runs where the step list names it (:mod:`graphseg.method.operations`);
    a threshold of None makes its operation join nothing.

    Each object's points from every view are fused into voxels; neighbouring
    voxels are linked, weakly across concave creases, and the graph is cut in
    two by normalized cut while the best cut costs less than ``max_ncut``.
    Touching objects whose masks were joined come apart; every pixel follows
    its voxel. A second pass on a finer grid (``fine_voxel_size``, parts of the
    same surface area) resolves the narrow seam where two objects touch; there a
    cut stands only where the views' masks own its parts (``fine_own_fraction``,
    ``own_cover``), so the finer grid never cuts a surface the masks see as one.
    ``settle_band`` (0 = off, in every preset) then draws each cut's border
    again: the voxels of two touching parts within that many links of their
    border are divided by a minimum cut of the link weights, so the border
    follows the weak links across the crease
    (:func:`graphseg.method.split.settle_parts`). It raised YCB-Video 0002 on
    the tune half, but moved a box's rim into its taller neighbour on the
    touching boxes of the tests (``docs/results.md``, round 18).
    Then touching objects whose union no cut below ``merge_ncut``
    separates are joined (:func:`graphseg.method.split.merge_objects`, on the
    ``voxel_size`` grid): the pieces of one object that the masks and matches
    left apart. Last, two objects whose border in the images, with no depth
    step across it, is at least ``join_shared`` of the smaller one's outline
    are joined (:func:`graphseg.method.join.join_objects`): pieces too small
    or too interleaved (the stripes of one box) for the 3D cut. Off for
    measured depth, on for estimated points (``lifted.split``). Then an
    object whose pixels lie mostly (``mask_join``) in masks that hold another,
    larger object of the same mean colour (``mask_join_color``) joins it
    (:func:`graphseg.method.join.join_by_masks`): the split cut one object
    along a crease of its own surface that no view's mask follows. 0.5 by
    default (the ``rgbd`` method), None (off) in the other presets. Then, in every
    mask with at least ``snap_share`` of its labelled pixels in one object,
    the other pixels go to that object where the other views' masks agree at
    the same voxel (:func:`graphseg.method.masks.snap_to_masks` with the
    points, on the ``voxel_size`` grid): the voxel border cut a few pixels off
    a mask that lies in one object. 0.85 by default (the ``rgbd`` method),
    None in the other presets: it raised masks cut along the ground truth on YCB-Video 0002 by
    0.02-0.04. Without the other views' agreement it lowered the
    ``superpixel`` rows of ``bench_quality.py``; with it, ``robust`` on 0002
    at 10 views still falls, so ``robust`` keeps it off. Chosen
    on the tune halves of ``bench_ycb_views.py`` and ``bench_rgb_only.py``
    (``docs/results.md``).
    """

    voxel_size: float = Field(0.006, gt=0, description="voxel edge (metres); voxels up to 3 edges apart are linked")
    max_ncut: float = Field(0.012, ge=0, description="cut while the best normalized cut of a part is below this")
    min_voxels: int = Field(200, ge=1, description="voxels every part keeps at least")
    concave_weight: float = Field(0.1, ge=0, le=1, description="weight of a link across a concave crease (others weigh 1)")
    concave_angle: float = Field(10.0, ge=0, le=180, description="degrees; links between normals closer than this are never concave")
    concave_margin: float = Field(0.05, ge=0, description="a link is concave when (n_a - n_b) . unit(x_a - x_b) < -concave_margin")
    settle_band: int = Field(
        0, ge=0, description="after the cuts, the voxels within this many links of the border between two parts are divided again by a minimum cut of the link weights (0: off)"
    )
    own_fraction: float | None = Field(None, gt=0, le=1, description="a mask belongs to a part when this share of its pixels lies in it (None: every cut stands)")
    own_cover: float = Field(0.5, ge=0, le=1, description="a part stands only if masks that belong to it cover this share of its pixels")
    fine_voxel_size: float | None = Field(
        0.005, gt=0, description="then split again on this finer grid (metres), each part keeping the same surface area (None, or not below voxel_size: one pass)"
    )
    fine_own_fraction: float = Field(0.8, gt=0, le=1, description="a fine cut stands only where masks with this share of their pixels in one part cover it")
    merge_ncut: float | None = Field(
        0.022, ge=0, description="then join two touching objects when the cheapest normalized cut found in their union costs at least this (None: never join)"
    )
    join_shared: float | None = Field(
        None,
        ge=0,
        description="last, join two objects whose border without a depth step is at least this share of the smaller one's outline in the views (None: never)",
    )
    mask_join: float | None = Field(
        0.5,
        ge=0,
        le=1,
        description="then join an object to the larger object whose masks (those with at least 30% of their labelled pixels in that object) hold at least this share of its pixels, when their mean colours are within mask_join_color (None: never)",
    )
    mask_join_color: float = Field(10.0, ge=0, description="mask_join's largest distance of the two objects' mean CIE Lab colours (L 0..100)")
    snap_share: float | None = Field(
        0.85,
        gt=0.5,
        le=1,
        description="then a mask with at least this share of its labelled pixels in one object gets its other pixels back where the other views' masks agree (None: the per-pixel labels stay)",
    )


class OutputConfig(_Model):
    """What the result keeps."""

    voxel_size: float | None = Field(0.003, gt=0, description="object clouds are voxel-downsampled to this size (metres)")
    stride: int = Field(2, ge=1, description="pixel stride when gathering the object clouds")


class BackendConfig(_Model):
    """Backends used by the pipeline (names from the registries)."""

    segmenter: str = "geometric"
    matcher: str = "reprojection"
    lifter: str = "rgbd"
    num_matches: int | None = Field(10_000, ge=1, description="matches kept per pair, most certain first")
    features: str = Field("color", description="feature extractor, run only when a criterion requires 'features'")
    options: dict[str, dict[str, Any]] = Field(default_factory=dict, description="constructor options by backend name")

    @field_validator("options")
    @classmethod
    def _finite_options(cls, v: dict[str, dict[str, Any]]) -> dict[str, dict[str, Any]]:
        from .graphs.criterion import non_finite

        bad = non_finite(v)
        if bad is not None:
            raise PydanticCustomError("finite_number", "{key}: expected a finite number (got {value})", {"key": bad[0], "value": repr(bad[1])})
        return v


def _split_spec(value: Any, what: str) -> tuple[str, Any]:
    """``name`` or ``{name: options}`` (or a spec) -> ``(name, options)``."""
    if isinstance(value, _PluginSpec):
        return value.name, dict(value.options)
    if isinstance(value, str):
        return value, {}
    if isinstance(value, dict) and len(value) == 1:
        ((name, opts),) = value.items()
        if isinstance(name, str) and (opts is None or isinstance(opts, dict)):
            return name, dict(opts or {})
    raise PydanticCustomError(
        "plugin_spec",
        "expected a {what} name or {form} with one key (got {got})",
        {"what": what, "form": "{name: {options}}", "got": repr(value)[:80]},
    )


class _PluginSpec(BaseModel):
    """A plugin by name with its validated options; written as ``name`` or ``{name: {options}}``."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)
    name: str
    options: dict[str, Any] = Field(default_factory=dict)

    _what: ClassVar[str] = "plugin"

    @classmethod
    def _registry(cls) -> Any:  # pragma: no cover - overridden
        raise NotImplementedError

    @model_validator(mode="before")
    @classmethod
    def _parse(cls, value: Any) -> Any:
        from .graphs.criterion import CriterionOptionsError, criterion_info, validate_options
        from .registry import PluginNotFoundError

        name, opts = _split_spec(value, cls._what)
        try:
            plugin = cls._registry().get(name)
        except PluginNotFoundError as err:
            raise PydanticCustomError("unknown_plugin", "{msg}", {"msg": str(err)}) from None
        try:
            info = criterion_info(plugin, name)
            checked = validate_options(info.Options, opts, label=name)
        except (CriterionOptionsError, ValueError) as err:
            raise PydanticCustomError("criterion_options", "{msg}", {"msg": str(err)}) from None
        full = checked.model_dump(mode="json") if isinstance(checked, BaseModel) else checked
        return {"name": name, "options": full}

    @model_serializer
    def _dump(self) -> Any:
        return {self.name: dict(self.options)} if self.options else self.name

    def plugin(self) -> Any:
        """The registered class (or object)."""
        return self._registry().get(self.name)

    def build(self) -> Any:
        """A new instance, built from the validated options."""
        from .graphs.criterion import build_criterion

        return build_criterion(self.plugin(), self.options, name=self.name)


class CriterionSpec(_PluginSpec):
    """One edge criterion of a stage: ``pixel_match`` or ``{chamfer_3d: {tau: 5.0e-5}}``.

    ``options`` holds every option (defaults filled in), validated against the
    criterion's ``Options`` model.

    Examples
    --------
    >>> spec = CriterionSpec.model_validate({"pixel_match": {"tau": 0.3}})
    >>> spec.name, spec.options["tau"], spec.options["percentile"]
    ('pixel_match', 0.3, 78.0)
    >>> spec.info().dimension
    '2d'
    """

    _what: ClassVar[str] = "criterion"

    @classmethod
    def _registry(cls) -> Any:
        from .graphs.registry import edge_adders

        return edge_adders

    def info(self) -> Any:
        """The criterion's declarations (:class:`graphseg.graphs.criterion.CriterionInfo`)."""
        from .graphs.criterion import criterion_info

        return criterion_info(self.plugin(), self.name)


class ContractorSpec(_PluginSpec):
    """The contractor: ``star`` or ``{name: {options}}`` (validated against its ``Options``).

    Examples
    --------
    >>> ContractorSpec.model_validate("union_find").model_dump()
    'union_find'
    """

    _what: ClassVar[str] = "contractor"

    @classmethod
    def _registry(cls) -> Any:
        from .graphs.registry import contractors

        return contractors


class OperationSpec(_PluginSpec):
    """One graph operation of the step list: ``split`` or ``{my_operation: {options}}``.

    Built-in operations (:mod:`graphseg.method.operations`) take no options
    here: they read their config section (``split``, ``objects``, ...).

    Examples
    --------
    >>> OperationSpec.model_validate("snap").model_dump()
    'snap'
    >>> OperationSpec.model_validate("snp")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    pydantic_core._pydantic_core.ValidationError: 1 validation error for OperationSpec
      unknown graph operation 'snp'; installed choices: support, split, merge, ...
    """

    _what: ClassVar[str] = "graph operation"

    @classmethod
    def _registry(cls) -> Any:
        from .graphs.registry import operations

        return operations

    @model_validator(mode="before")
    @classmethod
    def _section_options(cls, value: Any) -> Any:
        """A built-in operation given options in ``stages``: one line naming the section that holds them."""
        from .registry import PluginNotFoundError

        if isinstance(value, dict) and len(value) == 1:
            ((name, opts),) = value.items()
            try:
                section = getattr(cls._registry().get(name), "section", None) if isinstance(name, str) else None
            except PluginNotFoundError:
                return value  # the generic parser names the unknown operation
            if section and opts:
                raise PydanticCustomError(
                    "criterion_options", "{name}: takes its options from the {section} section, not from stages (got {keys})", {"name": name, "section": section, "keys": ", ".join(map(str, opts))}
                )
        return value

    @property
    def kind(self) -> str:
        """``"objects"`` (recorded in the objects graph) or ``"pixels"`` (a pixel refiner)."""
        return str(getattr(self.plugin(), "kind", "objects"))


#: Old top-level sections and the criterion whose stage entries receive them.
LEGACY_SECTIONS: dict[str, str] = {"pixel_match": "pixel_match", "chamfer_3d": "chamfer_3d", "dino": "dino"}


def migrate_config(data: dict[str, Any]) -> dict[str, Any]:
    """Move old-style option sections into the stage entries (returns a new dict).

    ``pixel_match: {...}``, ``chamfer_3d: {...}``, ``dino: {...}`` and
    ``adder_options: {name: {...}}`` become the options of every stage entry of
    that criterion, overriding options written in the entry (so
    ``Config.preset("rgbd", pixel_match={"tau": 0.5})`` overrides the preset). Sections of
    criteria that no stage uses are dropped (they had no effect before either).
    The old stage-name alias ``dino_similarity`` becomes ``dino``.

    Examples
    --------
    >>> migrate_config({"pixel_match": {"tau": 0.3}, "stages": [["pixel_match"], ["chamfer_3d"]]})
    {'stages': [[{'pixel_match': {'tau': 0.3}}], ['chamfer_3d']]}
    """
    sections: dict[str, dict[str, Any]] = {}
    out = dict(data)
    for key, crit in LEGACY_SECTIONS.items():
        if isinstance(out.get(key), dict):
            sections[crit] = dict(out.pop(key))
    legacy = out.pop("adder_options", None)
    if isinstance(legacy, dict):
        for name, opts in legacy.items():
            if isinstance(opts, dict):
                sections[name] = {**sections.get(name, {}), **opts}
    stages = out.get("stages", _DEFAULT_STAGES)
    if not isinstance(stages, list):
        return out
    flags = {k: out[k].get("enabled") for k in ("split", "refine", "grow", "trim") if isinstance(out.get(k), dict) and "enabled" in out[k]}
    if flags:
        for k in flags:
            out[k] = {f: v for f, v in out[k].items() if f != "enabled"}
        out["stages"] = stages = with_operations(stages, {k: bool(v) for k, v in flags.items()})
    changed = False
    new_stages: list[Any] = []
    for stage in stages:
        if not isinstance(stage, list):
            new_stages.append(stage)
            continue
        entries = []
        for entry in stage:
            name, opts = (entry, {}) if isinstance(entry, str) else (None, None)
            if isinstance(entry, dict) and len(entry) == 1:
                ((name, opts),) = entry.items()
            if name == "dino_similarity":
                name, changed = "dino", True
                entry = {name: opts} if opts else name
            if isinstance(name, str) and name in sections and isinstance(opts, dict | None):
                entry = {name: {**(opts or {}), **sections[name]}}
                changed = True
            entries.append(entry)
        new_stages.append(entries)
    if changed:
        out["stages"] = new_stages
    return out


_DEFAULT_STAGES: list[Any] = BASE_STAGES

_FAMILIES: dict[str, tuple[str, ...]] = {"split": SPLIT_FAMILY, "refine": ("refine",), "grow": ("grow",), "trim": ("trim",)}


def _entry_name(entry: Any) -> str | None:
    """The name of a graph operation entry (a string, ``{name: options}`` or a spec); None for an edge stage."""
    if isinstance(entry, OperationSpec):
        return entry.name
    if isinstance(entry, str):
        return entry
    if isinstance(entry, dict) and len(entry) == 1:
        return str(next(iter(entry)))
    return None


def with_operations(stages: list[Any], switches: dict[str, bool]) -> list[Any]:
    """``stages`` with the operations of each section switched on or off (the old ``enabled`` flags).

    ``switches`` maps a section (``split``, ``refine``, ``grow``, ``trim``) to
    whether its operations run; operations switched on are inserted in
    :data:`~graphseg.presets.CANONICAL_ORDER` among the ones present. A list
    of edge stages only gets the minimum support first.

    Examples
    --------
    >>> with_operations([["pixel_match"]], {"split": True, "trim": False})
    [['pixel_match'], 'support', 'split', 'merge', 'join_shared', 'mask_join', 'snap', 'support_final']
    >>> with_operations([["pixel_match"], "support", "split", "support_final"], {"split": False})
    [['pixel_match'], 'support', 'support_final']
    """
    out = list(stages)
    if not any(_entry_name(e) is not None for e in out):
        out += list(MINIMUM_SUPPORT)
    for section, on in switches.items():
        family = _FAMILIES[section]
        if not on:
            out = [e for e in out if _entry_name(e) not in family]
            continue
        for name in family:
            if not any(_entry_name(e) == name for e in out):
                out = _insert_operation(out, name)
    return out


def _insert_operation(steps: list[Any], name: str) -> list[Any]:
    """``steps`` with the built-in operation ``name`` inserted in :data:`~graphseg.presets.CANONICAL_ORDER`."""
    rank = CANONICAL_ORDER.index(name)
    after = [i for i, e in enumerate(steps) if _entry_name(e) in CANONICAL_ORDER and CANONICAL_ORDER.index(str(_entry_name(e))) < rank]
    at = after[-1] + 1 if after else next((i for i, e in enumerate(steps) if _entry_name(e) is not None), len(steps))
    return [*steps[:at], name, *steps[at:]]

def _parse_steps(steps: list[Any]) -> list[Any]:
    return [[e if isinstance(e, CriterionSpec) else CriterionSpec.model_validate(e) for e in s] if isinstance(s, list) else s if isinstance(s, OperationSpec) else OperationSpec.model_validate(s) for s in steps]


#: One entry of ``stages``: an edge stage (a list of criteria) or a graph operation (a name or ``{name: options}``).
Step = Annotated[
    Annotated[list[CriterionSpec], Tag("edges")] | Annotated[OperationSpec, Tag("operation")],
    Discriminator(lambda v: "edges" if isinstance(v, list) else "operation"),
]
_STEP_TAGS: dict[str, Any] = {"edges": list[CriterionSpec], "operation": OperationSpec}


def _step_label(step: Any) -> str:
    return "[" + ", ".join(c.name for c in step) + "]" if isinstance(step, list) else step.name


class Config(_Model):
    """Everything a GraphSeg run needs besides its inputs.

    ``stages`` lists, per stage, the edge criteria that run before that
    stage's contraction, each with its validated options (see the module
    docstring). ``contractor`` is the contractor of every stage.
    """

    background: BackgroundConfig = Field(default_factory=BackgroundConfig)
    masks: MaskConfig = Field(default_factory=MaskConfig)
    objects: ObjectConfig = Field(default_factory=ObjectConfig)
    split: SplitConfig = Field(default_factory=SplitConfig)
    refine: RefineConfig = Field(default_factory=RefineConfig)
    trim: TrimConfig = Field(default_factory=TrimConfig)
    grow: GrowConfig = Field(default_factory=GrowConfig)
    lifted: LiftedConfig = Field(default_factory=LiftedConfig)
    pairs: PairConfig = Field(default_factory=PairConfig)
    output: OutputConfig = Field(default_factory=OutputConfig)
    backends: BackendConfig = Field(default_factory=BackendConfig)
    stages: list[Step] = Field(default_factory=lambda: _parse_steps(_DEFAULT_STAGES))
    contractor: ContractorSpec = Field(default_factory=lambda: ContractorSpec.model_validate("star"))
    method: Literal["graphseg", "graphseg-minus", "maskclustering", "sam3d"] = Field("graphseg", description="graphseg-minus: no 3D stage; maskclustering / sam3d: the baselines of graphseg.method.baselines")
    seed: int | None = Field(0, ge=0, description="random seed (None: fresh entropy)")

    @model_validator(mode="before")
    @classmethod
    def _migrate(cls, data: Any) -> Any:
        if isinstance(data, dict) and (
            any(k in data for k in (*LEGACY_SECTIONS, "adder_options")) or any(isinstance(data.get(k), dict) and "enabled" in data[k] for k in _FAMILIES)
        ):
            return migrate_config(data)
        return data

    @field_validator("stages", mode="before")
    @classmethod
    def _steps(cls, v: Any) -> Any:
        if not isinstance(v, list):
            return v
        if not any(_entry_name(e) is not None for e in v):  # edge stages only: the minimum support follows
            v = [*v, *MINIMUM_SUPPORT]
        return v

    @field_validator("stages")
    @classmethod
    def _stages_not_empty(cls, v: list[Any]) -> list[Any]:
        edge = [s for s in v if isinstance(s, list)]
        if not edge or any(not s for s in edge):
            raise PydanticCustomError("steps", "stages must start with non-empty lists of criteria (the edge stages)")
        kinds = ["edges" if isinstance(s, list) else s.kind for s in v]
        if "edges" in kinds[kinds.index("edges") + 1 :] and any(k != "edges" for k in kinds[: len(kinds) - kinds[::-1].index("edges")]):
            raise PydanticCustomError("steps", "graph operations come after the last edge stage (got {got})", {"got": ", ".join(_step_label(s) for s in v)})
        if "pixels" in kinds and "objects" in kinds[kinds.index("pixels") :]:
            raise PydanticCustomError("steps", "pixel refiners come after every graph operation that decides objects (got {got})", {"got": ", ".join(_step_label(s) for s in v)})
        seen: dict[str, tuple[str, str]] = {}
        for stage in edge:
            for spec in stage:
                for col, how in spec.info().reduce.items():
                    if col in seen and seen[col][1] != how:
                        raise ValueError(
                            f"criteria {seen[col][0]!r} and {spec.name!r} merge edge column {col!r} differently ({seen[col][1]} vs {how})"
                        )
                    seen.setdefault(col, (spec.name, how))
        return v

    @property
    def edge_stages(self) -> list[list[CriterionSpec]]:
        """The edge stages of ``stages``, in order (each: criteria, then a contraction)."""
        return [s for s in self.stages if isinstance(s, list)]

    @property
    def operations(self) -> list[OperationSpec]:
        """The graph operations of ``stages``, in order (after the last edge stage)."""
        return [s for s in self.stages if isinstance(s, OperationSpec)]

    def step_names(self) -> list[Any]:
        """The whole method: criterion names per edge stage, then the operations' names.

        Examples
        --------
        >>> Config.preset("paper").step_names()
        [['pixel_match'], ['chamfer_3d'], 'support', 'support_final']
        """
        return [[c.name for c in s] if isinstance(s, list) else s.name for s in self.stages]

    @classmethod
    def preset(cls, name: str, **kwargs: Any) -> Config:
        """A named configuration (see :data:`PRESETS`), with overrides.

        ``"rgbd"`` is ``Config()``, chosen by measurement for metric RGB-D input
        (``docs/results.md``): the per-pair overlap fraction (``pair_hits``) >=
        0.3 for 2D edges, the official code's tau_3D = 5e-5 m^2, masks dropped
        only when at least half of them is background, then the minimum support
        and the 3D split with its joins. ``"paper"`` holds the paper's
        thresholds. Every preset is the keys it changes over ``Config()``;
        mapping overrides merge into the preset's sections.

        Examples
        --------
        >>> Config.preset("rgbd") == Config()
        True
        >>> Config.preset("paper").step_names()
        [['pixel_match'], ['chamfer_3d'], 'support', 'support_final']
        """
        if name not in PRESETS:
            raise ValueError(f"unknown preset {name!r}; choose one of {', '.join(PRESETS)}")
        merged: dict[str, Any] = {}
        for src in (PRESETS[name], kwargs):
            for key, val in src.items():
                if isinstance(val, dict) and isinstance(merged.get(key), dict):
                    merged[key] = {**merged[key], **val}
                else:
                    merged[key] = val
        return cls(**merged)

    @classmethod
    def minus(cls, **kwargs: Any) -> Config:
        """GraphSeg-minus, the paper's ablation: the 2D stage only (of ``Config(**kwargs)``)."""
        return cls(**kwargs).without_3d()

    @model_validator(mode="after")
    def _method_stages(self) -> Config:
        """``method`` becomes its stages and contractor here, when the config is built.

        ``graphseg`` keeps the stages as given; ``graphseg-minus`` drops the 3D
        criteria; ``maskclustering`` and ``sam3d`` replace the stages (and use
        components contraction). Idempotent, so a saved config reloads to the
        same run, and every entry point runs what ``method`` names.
        """
        if self.method == "graphseg":
            return self
        if self.method == "graphseg-minus":
            want, contractor = self.without_3d().stages, self.contractor
        else:
            name = "view_consensus" if self.method == "maskclustering" else "bidirectional_overlap"
            want = [*([CriterionSpec.model_validate(name)] for _ in range(3 if self.method == "maskclustering" else 1)), *self.operations]
            contractor = ContractorSpec.model_validate("star")
        if want != self.stages or contractor != self.contractor:
            self.__dict__.update(stages=want, contractor=contractor)  # the fields' own validators already ran on these
        return self

    def without_3d(self) -> Config:
        """A copy without criteria tagged ``dimension: "3d"`` (stages left empty are dropped)."""
        stages = [[c for c in s if c.info().dimension != "3d"] for s in self.edge_stages]
        kept = [s for s in stages if s] or [[CriterionSpec.model_validate("pixel_match")]]
        return self.model_copy(update={"stages": [*kept, *self.operations]})

    def for_lifter(self, lifter: str | None) -> Config:
        """The configuration a scene lifted by ``lifter`` runs with (see :class:`LiftedConfig`).

        Examples
        --------
        >>> cfg = Config.preset("rgbd")
        >>> cfg.for_lifter("sfm").criterion_options("chamfer_3d")["fragment_ratio"]
        0.5
        >>> Config.preset("rgbd", lifted={"objects": {"min_views": 3}}).for_lifter("sfm").objects.min_views
        3
        >>> cfg.for_lifter("sfm").backends.options["reprojection"]["max_color_distance"]
        30.0
        >>> cfg.for_lifter("rgbd") is cfg, cfg.split.merge_ncut, cfg.for_lifter("sfm").split.merge_ncut
        (True, 0.022, None)
        >>> cfg.for_lifter("sfm").step_names()[2:]      # estimated points: the border join, then rims grown and trimmed
        ['support', 'split', 'merge', 'join_shared', 'mask_join', 'snap', 'support_final', 'grow', 'trim']
        >>> "trim" in Config.preset("rgbd", lifted={"trim": {"enabled": False}}).for_lifter("sfm").step_names()
        False
        """
        lf = self.lifted
        if lifter is None or lifter not in lf.lifters or not (lf.criteria or lf.objects or lf.split or lf.preset or lf.backend_options or lf.trim or lf.grow):
            return self
        steps: list[Any] = list(self.stages)
        if lf.preset is not None and self.method == "graphseg":  # the preset's edge stages, this config's operations
            steps = [*Config.preset(lf.preset).edge_stages, *self.operations]
        over = lf.criteria
        steps = [[{c.name: {**c.options, **over[c.name]}} if c.name in over else c for c in s] if isinstance(s, list) else s for s in steps]
        objects_over = dict(lf.objects)
        if objects_over == _DEFAULT_LIFTED_OBJECTS:  # the built-in default yields to objects fields the user changed
            plain_objects = ObjectConfig()
            objects_over = {k: v for k, v in objects_over.items() if getattr(self.objects, k) == getattr(plain_objects, k)}
        objects = ObjectConfig.model_validate({**self.objects.model_dump(), **objects_over})
        split_over = {k: v for k, v in lf.split.items() if k != "enabled"}
        if split_over == _DEFAULT_LIFTED_SPLIT:  # the built-in default yields to split options the user changed
            plain = SplitConfig()
            split_over = {k: v for k, v in split_over.items() if getattr(self.split, k) == getattr(plain, k)}
        split = SplitConfig.model_validate({**self.split.model_dump(), **split_over})
        trim = TrimConfig.model_validate({**self.trim.model_dump(), **{k: v for k, v in lf.trim.items() if k != "enabled"}})  # lifted.trim wins
        grow = GrowConfig.model_validate({**self.grow.model_dump(), **{k: v for k, v in lf.grow.items() if k != "enabled"}})  # lifted.grow wins
        switches = {k: bool(d["enabled"]) for k, d in (("split", lf.split), ("trim", lf.trim), ("grow", lf.grow)) if "enabled" in d}
        steps = with_operations(steps, switches)
        if any(_entry_name(e) == "split" for e in steps):  # a join the lifted split turns on runs with the split
            wanted = {"merge": split.merge_ncut, "join_shared": split.join_shared, "mask_join": split.mask_join, "snap": split.snap_share}
            for name, value in wanted.items():
                if value is not None and not any(_entry_name(e) == name for e in steps):
                    steps = _insert_operation(steps, name)
        options = {**self.backends.options, **{k: {**v, **self.backends.options.get(k, {})} for k, v in lf.backend_options.items()}}
        return self.model_copy(
            update={
                "stages": _parse_steps(steps),
                "contractor": Config.preset(lf.preset).contractor if lf.preset is not None and self.method == "graphseg" else self.contractor,
                "objects": objects,
                "split": split,
                "trim": trim,
                "grow": grow,
                "backends": self.backends.model_copy(update={"options": options}),
            }
        )

    def stage_names(self) -> list[list[str]]:
        """The criterion names of every edge stage (:meth:`step_names` adds the graph operations)."""
        return [[c.name for c in s] for s in self.edge_stages]

    def criteria(self) -> list[CriterionSpec]:
        """Every criterion of every edge stage, in order."""
        return [c for s in self.edge_stages for c in s]

    def criterion_options(self, name: str) -> dict[str, Any]:
        """The options of the first stage entry named ``name`` (KeyError if none)."""
        for c in self.criteria():
            if c.name == name:
                return dict(c.options)
        raise KeyError(f"no stage uses criterion {name!r}; stages: {self.stage_names()}")

    def requires(self) -> frozenset[str]:
        """The evidence the configured criteria need (union of their ``requires``)."""
        out: set[str] = set()
        for c in self.criteria():
            out |= c.info().requires
        return frozenset(out)

    def edge_reduce(self) -> dict[str, str]:
        """Edge column -> reduction, from the configured criteria's ``reduce``."""
        out: dict[str, str] = {}
        for c in self.criteria():
            for col, how in c.info().reduce.items():
                out.setdefault(col, how)
        return out

    # ------------------------------------------------------------------ files
    def to_dict(self) -> dict[str, Any]:
        return self.model_dump(mode="json")

    def save(self, path: str | PathLike[str]) -> None:
        """Write YAML (``.yaml``/``.yml``) or JSON (anything else)."""
        p = Path(path)
        if p.suffix.lower() in (".yaml", ".yml"):
            import yaml

            p.write_text(yaml.safe_dump(self.to_dict(), sort_keys=False))
        else:
            p.write_text(json.dumps(self.to_dict(), indent=2))

    @classmethod
    def load(cls, path: str | PathLike[str], *, base: Config | None = None) -> Config:
        r"""Read YAML or JSON written by :meth:`save`.

        A partial file overrides ``base`` (default ``Config()``, the ``rgbd``
        method): nested sections are merged key by key, lists are replaced.
        YAML alias expansion is bounded (:func:`load_yaml_text`), and files
        over 1 MiB are refused.

        Raises
        ------
        ValueError or yaml.YAMLError
            For malformed files (``json.JSONDecodeError`` and ``UnicodeDecodeError``
            are ValueErrors; :func:`load_error_message` words any of them as one
            line with its position); pydantic's ValidationError for bad values
            (:func:`validation_message`).

        Examples
        --------
        >>> import tempfile
        >>> with tempfile.TemporaryDirectory() as d:
        ...     p = Path(d) / "c.yaml"
        ...     _ = p.write_text("seed: 3\n")
        ...     Config.load(p, base=Config.preset("rgbd")).criterion_options("chamfer_3d")["tau"]
        5e-05
        """
        p = Path(path)
        if p.stat().st_size > 2**20:
            raise ValueError("larger than 1 MiB; not a config file")
        text = p.read_text(encoding="utf-8")
        if p.suffix.lower() in (".yaml", ".yml"):
            data = load_yaml_text(text)
            data = {} if data is None else data
        else:
            data = json.loads(text)
        if not isinstance(data, dict):
            raise ValueError("expected a mapping at the top level")
        if base is not None:
            data = _deep_merge(base.to_dict(), data)
        return cls.model_validate(data)


def _deep_merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for k, v in over.items():
        out[k] = _deep_merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out




def load_yaml_text(text: str, *, max_nodes: int = 100_000) -> Any:
    r"""``yaml.safe_load`` with alias expansion bounded to ``max_nodes`` nodes.

    The document is composed first (linear in the text); its size with every
    alias expanded is counted (memoised, so a "billion laughs" file costs
    O(distinct nodes)) and refused above ``max_nodes`` before any object is built.

    Examples
    --------
    >>> load_yaml_text("a: &x [1, 2]\nb: *x")
    {'a': [1, 2], 'b': [1, 2]}
    >>> bomb = "a: &a [0,0,0,0,0,0,0,0,0]\n" + "".join(
    ...     f"{chr(98 + i)}: &{chr(98 + i)} [*{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}]\n"
    ...     for i in range(8))
    >>> load_yaml_text(bomb)
    Traceback (most recent call last):
    ...
    ValueError: YAML aliases expand to more than 100000 nodes
    """
    import yaml

    node = yaml.compose(text, Loader=yaml.SafeLoader)
    if node is None:
        return None
    sizes: dict[int, int] = {}

    def size(n: Any, depth: int = 0) -> int:
        if id(n) in sizes:
            return sizes[id(n)]
        if depth > 200:
            raise ValueError("YAML nesting deeper than 200 levels")
        sizes[id(n)] = 1  # guards against recursive aliases
        total = 1
        if isinstance(n, yaml.SequenceNode):
            total += sum(size(c, depth + 1) for c in n.value)
        elif isinstance(n, yaml.MappingNode):
            total += sum(size(k, depth + 1) + size(v, depth + 1) for k, v in n.value)
        if total > max_nodes:
            raise ValueError(f"YAML aliases expand to more than {max_nodes} nodes")
        sizes[id(n)] = total
        return total

    size(node)
    return yaml.SafeLoader(text).get_single_data()


# ----------------------------------------------------------------------------- messages
def _models(root: type[BaseModel]) -> dict[str, type[BaseModel]]:
    """``root`` and every model reachable through its fields, by class name."""
    out: dict[str, type[BaseModel]] = {}

    def visit(tp: Any) -> None:
        if isinstance(tp, type) and issubclass(tp, BaseModel):
            if tp.__name__ not in out:
                out[tp.__name__] = tp
                for f in tp.model_fields.values():
                    visit(f.annotation)
        for arg in typing.get_args(tp):
            visit(arg)

    visit(root)
    return out


def _is_union(tp: Any) -> bool:
    return typing.get_origin(tp) in (typing.Union, types.UnionType)


def _walk(root: type[BaseModel], loc: tuple[Any, ...]) -> tuple[list[str], type[BaseModel] | None]:
    """The printable path of ``loc`` below ``root`` and the model that holds its last key.

    Components that are not keys (pydantic's union member tags such as
    ``float`` or ``literal['auto']``) are left out.
    """
    path: list[str] = []
    cur: Any = root
    holder: type[BaseModel] | None = None
    for part in loc:
        while typing.get_origin(cur) is Annotated:
            cur = typing.get_args(cur)[0]
        if _is_union(cur) and isinstance(part, str) and part in _STEP_TAGS:  # a step's tag: which kind of step
            cur = _STEP_TAGS[part]
            continue
        while _is_union(cur):  # Optional[X] -> X; a real union ends the path (its tags follow)
            members = [a for a in typing.get_args(cur) if a is not type(None)]
            if len(members) != 1:
                return path, holder
            cur = members[0]
        if isinstance(cur, type) and issubclass(cur, BaseModel):
            holder = cur
            path.append(str(part))
            field = cur.model_fields.get(part) if isinstance(part, str) else None
            if field is None:
                return path, holder
            cur = field.annotation
        elif typing.get_origin(cur) in (list, tuple, dict, set, frozenset):
            path.append(str(part))
            args = typing.get_args(cur)
            cur = args[-1] if args else Any
        else:
            return path, holder
    return path, holder


def validation_message(err: ValidationError, model: type[BaseModel] | None = None) -> str:
    """The first error of a config validation error as one line, ``FIELD: what is wrong``.

    A misspelt key names the closest valid key (``difflib``) and lists the
    valid keys of its section; other errors name the value that was given.

    Parameters
    ----------
    err : pydantic.ValidationError
        Raised while building :class:`Config` or one of its sections.
    model : pydantic model class, optional
        The model that was validated (default: found from ``err.title`` among
        :class:`Config` and its sections, else :class:`Config`).

    Examples
    --------
    >>> try:
    ...     Config.model_validate({"seed": -1})
    ... except ValidationError as err:
    ...     print(validation_message(err))
    seed: Input should be greater than or equal to 0 (got -1)
    >>> try:
    ...     Config.model_validate({"stagse": []})
    ... except ValidationError as err:
    ...     print(validation_message(err))  # doctest: +ELLIPSIS
    stagse: unknown key 'stagse'; did you mean 'stages'? valid keys: background, masks, ...
    >>> try:
    ...     Config.model_validate({"background": {"max_distance": float("inf")}})
    ... except ValidationError as err:
    ...     print(validation_message(err))
    background.max_distance: Input should be a finite number (got inf)
    """
    from .graphs.criterion import did_you_mean

    known = _models(Config)
    root = model or known.get(err.title, Config)
    first = err.errors()[0]
    loc = tuple(first["loc"])
    path, holder = _walk(root, loc)
    where = ".".join(path) or "config"
    if first["type"] == "extra_forbidden" and holder is not None and loc:
        key = str(loc[-1])
        valid = list(holder.model_fields)
        candidates = valid + ([*LEGACY_SECTIONS, "adder_options"] if holder is Config else [])
        hint = did_you_mean(key, candidates)
        return f"{where}: unknown key {key!r}; " + (f"{hint} " if hint else "") + f"valid keys: {', '.join(valid)}"
    msg = (str(first["msg"]).splitlines() or [""])[0]
    value = first.get("input")
    shown = isinstance(value, (bool, int, float)) or (isinstance(value, str) and len(value) <= 60)
    if shown and repr(value) not in msg and first["type"] not in ("unknown_plugin", "criterion_options", "plugin_spec"):
        msg += f" (got {value!r})"
    return f"{where}: {msg}"


def load_error_message(err: BaseException) -> str:
    r"""A config file's syntax or encoding error as one line, with 1-based line and column.

    Examples
    --------
    >>> import yaml
    >>> try:
    ...     load_yaml_text("background:\n  plane: true\n - x\n")
    ... except yaml.YAMLError as err:
    ...     print(load_error_message(err))
    line 3, column 2: expected <block end>, but found '<block sequence start>' (while parsing a block mapping that starts at line 1, column 1)
    >>> try:
    ...     json.loads('{"seed": 1,}')
    ... except json.JSONDecodeError as err:
    ...     print(load_error_message(err))
    line 1, column 12: Expecting property name enclosed in double quotes
    """
    if isinstance(err, json.JSONDecodeError):
        return f"line {err.lineno}, column {err.colno}: {err.msg}"
    if isinstance(err, UnicodeDecodeError):
        return f"not UTF-8 text (byte 0x{err.object[err.start]:02x} at offset {err.start})"
    mark = getattr(err, "problem_mark", None)
    problem = getattr(err, "problem", None)
    if mark is not None and problem:
        text = f"line {mark.line + 1}, column {mark.column + 1}: {problem}"
        context, cmark = getattr(err, "context", None), getattr(err, "context_mark", None)
        if context and cmark is not None:
            text += f" ({context} that starts at line {cmark.line + 1}, column {cmark.column + 1})"
        elif context:
            text += f" ({context})"
        return text
    return (str(err) or type(err).__name__).splitlines()[0]
