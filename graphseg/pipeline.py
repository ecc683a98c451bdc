"""The GraphSeg run end to end: scene -> (lift) -> masks, matches -> graph -> Result.

Backends come from the registries by name, class or instance; their names and
options default to ``config.backends``.

Examples
--------
>>> from graphseg.testing.scenes import box_scene, TWO_BOXES
>>> scene = box_scene(TWO_BOXES)
>>> result = run(scene)  # geometric segmenter, reprojection matcher
>>> result.num_objects
2
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from os import PathLike
from typing import Any

import numpy as np

from .backends.options import option_fields
from .backends.registry import features as feature_registry
from .backends.registry import lifters, matchers, segmenters
from .config import Config
from .geometry import scene_scale, select_pairs
from .method.segment import segment
from .parallel import backend_map
from .result import Result
from .scene import Matches, Scene, SceneError

__all__ = ["run", "plan_run", "backend_name", "execute", "RunPlan", "resolve_backends", "backends_for_lifter", "lift", "compute_masks", "compute_matches", "prepare", "resolve_backend", "backend_registry", "progress_bar", "no_objects_reason", "NO_OBJECT_STEPS"]

#: The backend kinds and their registries (entry-point groups ``graphseg.segmenters``, ...).
BACKEND_REGISTRIES: dict[str, Any] = {"segmenter": segmenters, "matcher": matchers, "lifter": lifters, "features": feature_registry}


def backend_registry(kind: str) -> Any:
    """The registry of a backend kind: ``segmenter``, ``matcher``, ``lifter`` or ``features``."""
    if kind not in BACKEND_REGISTRIES:
        raise ValueError(f"unknown backend kind {kind!r}; choose from {', '.join(BACKEND_REGISTRIES)}")
    return BACKEND_REGISTRIES[kind]


def _run_settings(kind: str, cfg: Config) -> dict[str, Any]:
    """Run-wide settings a backend of ``kind`` gets when its constructor takes them (and its options do not set them)."""
    if kind == "segmenter":
        return {"seed": cfg.seed}
    if kind == "matcher":
        return {"num_matches": cfg.backends.num_matches, "seed": cfg.seed}
    return {}


def resolve_backend(kind: str, spec: Any, config: Config | None = None) -> Any:
    """A backend instance from a registered name, a class or an instance (the one rule of the pipeline and :mod:`graphseg.job`).

    Parameters
    ----------
    kind : {"segmenter", "matcher", "lifter", "features"}
    spec : str, type or object
        A name is built with ``config.backends.options[name]``, plus the
        run-wide settings its ``Options`` declare as fields and the options
        leave unset (segmenters: ``seed``; matchers: ``num_matches`` and
        ``seed``; see :func:`graphseg.backends.options.option_fields`). A
        class is built with no options; an instance is returned as is.
    config : Config, optional
        Default ``Config()``.

    Raises
    ------
    PluginNotFoundError
        For an unknown name (the message lists the installed choices).
    SceneError
        When the backend rejects its options: one line naming the key
        (``backends.options.NAME.KEY``), the valid keys and the closest one.
    TypeError, ValueError
        When a backend without ``Options`` rejects its options.

    Examples
    --------
    >>> resolve_backend("matcher", "reprojection", Config(seed=3)).options.seed
    3
    >>> resolve_backend("matcher", "reprojection", Config(backends={"options": {"reprojection": {"strid": 2}}}))
    Traceback (most recent call last):
    ...
    graphseg.scene.SceneError: backends.options.reprojection.strid: unknown option 'strid'; valid keys: num_matches, seed, abs_tol, rel_tol, stride, max_color_distance, color_blur; did you mean 'stride'?
    """
    cfg = config or Config()
    return _resolve(backend_registry(kind), spec, cfg, _run_settings(kind, cfg))


def _resolve(registry: Any, spec: Any, cfg: Config, extra: dict[str, Any] | None = None) -> Any:
    if isinstance(spec, str):
        opts = dict(cfg.backends.options.get(spec, {}))
        if extra:
            fields = option_fields(registry.get(spec))  # declared in the backend's Options
            opts.update({k: v for k, v in extra.items() if k in fields and k not in opts})
        return registry.resolve(spec, **opts)
    return registry.resolve(spec)


def backend_name(spec: Any, default: str) -> str:
    """The registry name of a backend given as a name, class or instance (``default`` for None)."""
    if spec is None:
        return default
    return spec if isinstance(spec, str) else str(getattr(spec, "name", None) or default)


def _options_error(kind: str, name: str, err: Exception) -> SceneError:
    text = str(err).splitlines()[0] if str(err) else type(err).__name__
    return SceneError(f"{kind} {name!r} rejects its options ({text})", where="config", field=f"backends.options.{name}")


def resolve_backends(
    config: Config,
    *,
    segmenter: Any = None,
    matcher: Any = None,
    lifter: Any = None,
    need_lifter: bool = True,
) -> dict[str, Any]:
    """Instances of the segmenter, matcher and (if ``need_lifter``) lifter, before any work.

    Names default to ``config.backends``; options come from
    ``config.backends.options[name]``.

    Raises
    ------
    PluginNotFoundError
        For an unknown name (the message lists the installed choices).
    MissingDependencyError
        When a backend's package is not installed (the message names the extra).
    SceneError
        When a backend rejects its options: its ``Options`` name the key
        (field ``backends.options.NAME.KEY``, the valid keys and the closest
        one); a backend class without ``Options`` is reported with field
        ``backends.options.NAME``.
    """
    out: dict[str, Any] = {}
    plan: list[tuple[str, Any]] = [
        ("segmenter", segmenter or config.backends.segmenter),
        ("matcher", matcher or config.backends.matcher),
    ]
    if need_lifter or lifter is not None:
        plan.append(("lifter", lifter or config.backends.lifter))
    for kind, spec in plan:
        if isinstance(spec, str):
            backend_registry(kind).get(spec)  # PluginNotFoundError / MissingDependencyError first
        try:
            out[kind] = resolve_backend(kind, spec, config)
        except (TypeError, ValueError) as err:
            if isinstance(err, SceneError):
                raise
            raise _options_error(kind, spec if isinstance(spec, str) else type(spec).__name__, err) from err
    out.setdefault("lifter", None)
    return out


def backends_for_lifter(backends: dict[str, Any], config: Config, lifter: str | None, *, segmenter: Any = None, matcher: Any = None, effective: Config | None = None) -> dict[str, Any]:
    """``backends`` with the segmenter and matcher rebuilt for points ``lifter`` estimated.

    :attr:`LiftedConfig.backend_options <graphseg.config.LiftedConfig>` applies to
    backends chosen by name (``segmenter`` / ``matcher`` None or a string); an
    instance the caller built is kept as it is. Returns ``backends`` itself when
    nothing changes; a backend whose options do not change is not rebuilt.

    Examples
    --------
    >>> cfg = Config.preset("rgbd")
    >>> b = resolve_backends(cfg, need_lifter=False)
    >>> backends_for_lifter(b, cfg, "sfm")["matcher"].options.max_color_distance, b["matcher"].options.max_color_distance
    (30.0, None)
    >>> backends_for_lifter(b, cfg, "rgbd")["segmenter"] is b["segmenter"]
    True
    """
    cfg_l = effective if effective is not None else config.for_lifter(lifter)  # the run's effective config, when the caller built it
    out = dict(backends)
    for kind, given in (("segmenter", segmenter), ("matcher", matcher)):
        name = given or getattr(config.backends, kind)
        if isinstance(name, str) and cfg_l.backends.options.get(name) != config.backends.options.get(name):  # only what changes is rebuilt
            out[kind] = resolve_backend(kind, name, cfg_l)
    return out


def progress_bar(iterable: Any, desc: str, enabled: bool, total: int | None = None) -> Any:
    """``iterable`` wrapped in a tqdm progress bar named ``desc`` when ``enabled`` (else itself).

    The bar is left out when stderr is not a terminal, and removed when done.

    Parameters
    ----------
    iterable : iterable
    desc : str
        The bar's label (e.g. ``"segment"``).
    enabled : bool
        False returns ``iterable`` itself (tqdm is not imported).
    total : int, optional
        The number of items, for an iterable without ``len``.

    Returns
    -------
    iterable
        The same items in the same order.

    Examples
    --------
    >>> items = [1, 2]
    >>> progress_bar(items, "x", False) is items, list(progress_bar(items, "x", True))
    (True, [1, 2])
    """
    if not enabled:
        return iterable
    from tqdm.auto import tqdm

    return tqdm(iterable, desc=desc, total=total, leave=False, disable=None)  # None: no bar when stderr is not a terminal


def lift(scene: Scene, lifter: Any = None, config: Config | None = None) -> Scene:
    """World point maps for every view; a scene that has them is returned as is unless a lifter is named.

    The lifted scene records the lifter in ``scene.meta["lifter"]`` (``"given"`` when the
    scene came with point maps), so later steps can report it.
    """
    cfg = config or Config()
    if lifter is None and scene.has_points:
        if "lifter" not in scene.meta:
            scene = Scene(scene.views, scene.objects, scene.name, {**scene.meta, "lifter": "given"})
        return scene
    default = cfg.backends.lifter
    if lifter is None and default == "rgbd" and not scene.has_depth:
        default = "sfm"  # RGB-only: structure from motion + stereo (graphseg.backends.lifters.sfm)
    lifted = resolve_backend("lifter", lifter or default, cfg)(scene)
    lifted.meta["lifter"] = backend_name(lifter, default)
    return lifted


#: The steps :func:`no_objects_reason` names, in the order a run passes them.
NO_OBJECT_STEPS = ("registration", "lifting", "masks", "background", "support")

#: Below this share of the pixels with a 3D point, a run that lost every mask to the background
#: (or kept none) is said to have lost them at the lifting step (:func:`no_objects_reason`).
SPARSE_LIFT = 0.25

#: The warnings :func:`graphseg.method.segment.segment` gives for no object, replaced by :func:`no_objects_reason`'s line in :func:`run`.
_GENERIC_NO_OBJECT = ("no usable masks (", "0 objects found")


def _support_text(kept: int, support: dict[str, Any], cfg: Config) -> str:
    """:func:`no_objects_reason`'s words for objects lost to the minimum support (``support``: the run's record)."""
    unmeasured, final = int(support.get("unmeasured") or 0), int(support.get("dropped_final") or 0)
    return (
        f"the {kept} masks formed {int(support.get('dropped', 0)) + final} candidate objects, every one below the minimum support "
        f"(seen in objects.min_views {support.get('min_views', cfg.objects.min_views)} views, {support.get('min_points', '?')} points"
        + (f"; {unmeasured} mostly of filled-in points, objects.min_measured {cfg.objects.min_measured:g}" if unmeasured else "")
        + (f"; {final} final objects below their support, objects.min_object_fraction {cfg.objects.min_object_fraction:g}" if final else "")
        + ")"
    )


def _lift_context(out: dict[str, Any], scene: Scene, valid: int, text: str) -> str:
    """:func:`no_objects_reason`'s line with what the lifter did; moves ``out["step"]`` to ``lifting`` or ``registration`` when they lost the objects."""
    n = len(scene.views)
    pixels = sum(int(np.prod(v.shape)) for v in scene.views)
    coverage = valid / pixels if pixels else 0.0
    out["coverage"] = round(coverage, 4)
    sfm = scene.meta.get("sfm") or {}
    if 0 < coverage < SPARSE_LIFT and out["step"] in ("masks", "background"):  # the masks had too few points to stand on
        out["step"] = "lifting"
        how = ""
        if sfm.get("points") is not None:
            dense = sfm.get("dense_fraction") or []
            how = f" (structure from motion triangulated {int(sfm['points'])} points" + (f", dense stereo covered {100 * float(np.mean(dense)):.1f}% of the pixels" if dense else "") + ")"
        text = f"3D points cover only {100 * coverage:.0f}% of the pixels{how}, and then {text}; give depth, or take photos with more texture and overlap"
    dropped = list(scene.meta.get("dropped_views") or [])
    total = n + len(dropped)
    if dropped:
        registered = int(sfm.get("registered", n))
        how = f"structure from motion registered {registered} of {total} views" if registered < total else f"the lifter kept {n} of {total} views"
        text += f"; {how} and segmented {n}, so the points may be wrong"
        if 2 * n <= total:
            out["step"] = "registration"
    return text


def no_objects_reason(result: Result, scene: Scene, config: Config | None = None) -> dict[str, Any] | None:
    """Which step of a run lost every object, in one line (None when the run found an object).

    The steps, in the order a run passes them (:data:`NO_OBJECT_STEPS`):
    ``lifting`` (no view has a valid 3D point), ``masks`` (the segmenter gave
    no mask, or every mask was below ``masks.min_area``), ``background``
    (every mask lay mostly in the background class: the table plane, below
    it, beyond the table or too far), ``support`` (objects were formed, and
    every one was below the minimum support, ``config.objects``). Masks lost
    (to the background, or below their minimum area) where 3D points cover
    less than :data:`SPARSE_LIFT` of the pixels count as lost at the
    ``lifting`` step (structure from motion found too few points). When the
    lifter left views out (structure from motion registered only some, or a
    view's pose looked wrong), the line says so, and the step is
    ``registration`` when it kept at most half of the views.

    Parameters
    ----------
    result : Result
        The run's result (its ``info`` holds ``masks``, ``background`` and ``support``).
    scene : Scene
        The lifted scene the result was segmented on.
    config : Config, optional
        The configuration of the run (for the thresholds the line names;
        default ``result.config``).

    Returns
    -------
    dict or None
        ``{"step": one of NO_OBJECT_STEPS, "line": str}``, plus the counts the
        line names; None when ``result`` has objects.

    Examples
    --------
    >>> from graphseg.testing.scenes import box_scene, TWO_BOXES
    >>> import numpy as np
    >>> scene = box_scene(TWO_BOXES, views=2, shape=(48, 64))
    >>> empty = run(scene, masks=[np.zeros((48, 64), np.int32)] * 2)
    >>> why = no_objects_reason(empty, scene)
    >>> why["step"], why["line"]
    ('masks', '0 objects: lost at the masks step: the segmenter gave no mask in any of the 2 views')
    >>> empty.info["warnings"] == [why["line"]]
    True
    """
    if result.num_objects:
        return None
    cfg = config or result.config
    n = len(scene.views)
    valid = sum(int(np.isfinite(np.asarray(v.points)).all(-1).sum()) for v in scene.views if v.points is not None)
    composed = result.info.get("masks") or []
    given = sum(int(m.get("num_input", 0)) for m in composed)
    on_bg = sum(len(m.get("dropped_background", ())) for m in composed)
    small = sum(len(m.get("dropped_small", ())) for m in composed)
    kept = sum(len(m.get("kept", ())) for m in composed)
    support = result.info.get("support") or {}
    out: dict[str, Any] = {"views": n, "valid_points": valid, "masks": given, "masks_background": on_bg, "masks_small": small, "masks_kept": kept}
    if valid == 0:
        out["step"] = "lifting"
        text = f"the lifter ({scene.meta.get('lifter', 'given')}) gave no valid 3D point in any of the {n} views"
    elif given == 0:
        out["step"] = "masks"
        text = f"the segmenter gave no mask in any of the {n} views"
    elif kept == 0 and on_bg >= small:
        out["step"] = "background"
        fractions = (result.info.get("background") or {}).get("fraction") or []
        share = f"; the background class covered {100 * float(np.mean(fractions)):.0f}% of the pixels" if fractions else ""
        text = (
            f"all {given} masks were dropped: {on_bg} lay at least {100 * cfg.background.max_overlap:.0f}% in the background class "
            f"(the table plane, below it, beyond the table or too far; config background){share}"
            + (f", {small} were below masks.min_area {cfg.masks.min_area}" if small else "")
        )
    elif kept == 0:
        out["step"] = "masks"
        text = f"all {given} masks were dropped: {small} were below masks.min_area {cfg.masks.min_area} pixels" + (f", {on_bg} lay in the background class" if on_bg else "")
    else:
        out["step"] = "support"
        text = _support_text(kept, support, cfg)
    text = _lift_context(out, scene, valid, text)
    out["line"] = f"0 objects: lost at the {out['step']} step: {text}"
    return out


def compute_masks(scene: Scene, segmenter: Any = None, config: Config | None = None, *, progress: bool = False) -> list[Any]:
    """One mask set per view from the segmenter."""
    cfg = config or Config()
    seg = resolve_backend("segmenter", segmenter or cfg.backends.segmenter, cfg)
    views = list(scene.views)  # a classical segmenter: on several processes (graphseg.parallel)
    return backend_map(seg, seg, views, wrap=lambda it: progress_bar(it, "segment", progress, total=len(views)))


def compute_matches(
    scene: Scene,
    matcher: Any = None,
    config: Config | None = None,
    *,
    pairs: list[tuple[int, int]] | None = None,
    progress: bool = False,
) -> dict[tuple[int, int], Matches]:
    """Matches for the selected view pairs (``config.pairs``)."""
    cfg = config or Config()
    m = resolve_backend("matcher", matcher or cfg.backends.matcher, cfg)
    if pairs is None:
        poses = [v.cam_to_world for v in scene.views]
        scale = scene_scale([v.points for v in scene.views], poses) if all(p is not None for p in poses) else None
        pairs = select_pairs(
            poses,
            mode=cfg.pairs.mode,
            max_rotation=cfg.pairs.max_rotation,
            max_translation=cfg.pairs.max_translation,
            translation_scale=cfg.pairs.translation_scale,
            scale=scale,
            auto_max_views=cfg.pairs.auto_max_views,
        )
    pairs = list(pairs)
    got = backend_map(m, lambda ij: m(scene[ij[0]], scene[ij[1]]), pairs, wrap=lambda it: progress_bar(it, "match", progress, total=len(pairs)))
    return dict(zip(pairs, got))


def _given_masks(scene: Scene, masks: Any) -> list[Any]:
    if isinstance(masks, (str, PathLike)):
        from .backends.segmenters.precomputed import PrecomputedSegmenter

        seg = PrecomputedSegmenter(folder=masks)
        return [seg(v) for v in scene.views]
    if len(masks) != scene.num_views:
        raise ValueError(f"expected one mask set per view ({scene.num_views}) (got {len(masks)})")
    return list(masks)


def _given_matches(scene: Scene, matches: Any) -> dict[tuple[int, int], Matches]:
    if isinstance(matches, (str, PathLike)):
        from .io.precomputed import read_matches_folder

        return read_matches_folder(matches, scene)
    return dict(matches)


@dataclass
class RunPlan:
    """A run's inputs after the one pass that checks and prepares them (:func:`plan_run`).

    ``scene`` is validated and lifted (``scene.meta["lifter"]`` names the
    lifter), ``config`` is the effective configuration
    (:meth:`Config.for_lifter` applied) and ``backends`` the segmenter and
    matcher instances built with its options.
    """

    scene: Scene
    config: Config
    backends: dict[str, Any]
    timings: dict[str, float] = field(default_factory=dict)


def plan_run(
    scene: Scene,
    config: Config | None = None,
    *,
    segmenter: Any = None,
    matcher: Any = None,
    lifter: Any = None,
    points: Any = None,
    backends: dict[str, Any] | None = None,
    check: Any = None,
) -> RunPlan:
    """Validate the scene, resolve the backends, lift, and build the effective config: once each, in that order.

    ``backends`` (from :func:`resolve_backends`) are used as given: a caller
    that resolved them before reading the scene does not resolve them twice.
    ``points`` (a point-map folder) replaces the lifter. An RGB-only scene
    without a named lifter is lifted by structure from motion (:func:`lift`).
    ``check(scene)`` runs on the validated scene before it is lifted (the
    job's memory check).
    """
    cfg = config or Config()
    scene.validate()
    if check is not None:
        check(scene)
    if backends is None:
        backends = resolve_backends(cfg, segmenter=segmenter, matcher=matcher, lifter=lifter, need_lifter=lifter is not None or not scene.has_points)
    t = time.perf_counter()
    if points is not None:
        from .backends.lifters.precomputed import PrecomputedLifter

        scene = lift(scene, PrecomputedLifter(folder=points), cfg)
        scene.meta["lifter"] = "precomputed"
    else:
        use = backends.get("lifter") if (lifter is not None or not scene.has_points) else None
        if lifter is None and not scene.has_points and not scene.has_depth and cfg.backends.lifter == "rgbd":
            use = None  # RGB-only and no lifter chosen: lift() picks structure from motion ("sfm")
        scene = lift(scene, use, cfg)
    timings = {"lift": time.perf_counter() - t}
    effective = cfg.for_lifter(scene.meta.get("lifter"))  # options for estimated (not measured) points
    backends = backends_for_lifter(backends, cfg, scene.meta.get("lifter"), segmenter=segmenter, matcher=matcher, effective=effective)
    return RunPlan(scene, effective, backends, timings)


def _inputs(plan: RunPlan, masks: Any, matches: Any, progress: bool) -> tuple[list[Any], dict[tuple[int, int], Matches], dict[str, float]]:
    times: dict[str, float] = {}
    scene, cfg = plan.scene, plan.config
    t = time.perf_counter()
    masks = _given_masks(scene, masks) if masks is not None else compute_masks(scene, plan.backends["segmenter"], cfg, progress=progress)
    times["segment"] = time.perf_counter() - t
    if matches is not None:
        matches = _given_matches(scene, matches)
    elif "matches" in cfg.requires():  # evidence on demand: matches only when a criterion reads them
        t = time.perf_counter()
        matches = compute_matches(scene, plan.backends["matcher"], cfg, progress=progress)
        times["match"] = time.perf_counter() - t
    else:
        matches = {}
    return masks, matches, times


def prepare(
    scene: Scene,
    config: Config | None = None,
    *,
    segmenter: Any = None,
    matcher: Any = None,
    lifter: Any = None,
    masks: Any = None,
    matches: Any = None,
    points: Any = None,
    progress: bool = False,
) -> tuple[Scene, list[Any], dict[tuple[int, int], Matches], dict[str, float]]:
    """The inputs of :func:`~graphseg.method.segment.segment`: ``(lifted scene, masks, matches, timings)``.

    ``masks`` (a list per view or a masks folder), ``matches`` (a dict or a
    matches folder) and ``points`` (a point-map folder, see
    :mod:`graphseg.io.precomputed`) replace the segmenter, matcher and lifter.
    :func:`graphseg.io.precomputed.save_inputs` saves the three so that a later
    run from them reproduces this one exactly.
    """
    plan = plan_run(scene, config, segmenter=segmenter, matcher=matcher, lifter=lifter, points=points)
    masks, matches, times = _inputs(plan, masks, matches, progress)
    return plan.scene, masks, matches, {**plan.timings, **times}


def run(
    scene: Scene,
    config: Config | None = None,
    *,
    segmenter: Any = None,
    matcher: Any = None,
    lifter: Any = None,
    features: Any = None,
    progress: bool = False,
    masks: Any = None,
    matches: Any = None,
    points: Any = None,
) -> Result:
    """Run GraphSeg on ``scene`` with backends: :func:`plan_run`, then :func:`execute`.

    Parameters
    ----------
    scene : Scene
    config : Config, optional
    segmenter, matcher, lifter : name, class or instance, optional
        Default to ``config.backends``.
    features : name, class or instance, optional
        Feature extractor (default ``config.backends.features``), run only when
        a configured criterion requires ``features``. Matches, too, are
        computed only when a criterion requires ``matches``.
    progress : bool
        Show progress bars.
    masks, matches, points : optional
        Precomputed inputs instead of the backends (see :func:`prepare`).

    Returns
    -------
    Result
        ``info["pipeline"]`` names the backends and holds per-step timings.
    """
    t0 = time.perf_counter()
    plan = plan_run(scene, config, segmenter=segmenter, matcher=matcher, lifter=lifter, points=points)
    names = {"segmenter": backend_name(segmenter, plan.config.backends.segmenter), "matcher": backend_name(matcher, plan.config.backends.matcher)}
    return execute(plan, masks=masks, matches=matches, features=features, progress=progress, names=names, start=t0)


def execute(
    plan: RunPlan,
    *,
    masks: Any = None,
    matches: Any = None,
    features: Any = None,
    progress: bool = False,
    names: dict[str, str] | None = None,
    start: float | None = None,
) -> Result:
    """The masks, matches and features of a planned run, then :func:`~graphseg.method.segment.segment` on them.

    ``names`` (``segmenter``, ``matcher``) are recorded in ``info["pipeline"]``
    (default: the config's backends).
    """
    t0 = time.perf_counter() if start is None else start
    scene, cfg = plan.scene, plan.config
    masks_given, matches_given = masks is not None, matches is not None
    masks, matches, times = _inputs(plan, masks, matches, progress)
    times = {**plan.timings, **times}
    feats = None
    if "features" in cfg.requires():
        t = time.perf_counter()
        fx = resolve_backend("features", features or cfg.backends.features, cfg)
        feats = [fx(v) for v in progress_bar(scene.views, "features", progress)]
        times["features"] = time.perf_counter() - t
    t = time.perf_counter()
    result = segment(scene, masks, matches, cfg, features=feats, checked=True)
    times["graph"] = time.perf_counter() - t
    times["total"] = time.perf_counter() - t0
    _lift_notes(result, scene, cfg)
    names = names or {"segmenter": cfg.backends.segmenter, "matcher": cfg.backends.matcher}
    result.info["pipeline"] = {
        "segmenter": "given" if masks_given else names["segmenter"],
        "matcher": "given" if matches_given else (names["matcher"] if "matches" in cfg.requires() else None),
        "lifter": scene.meta["lifter"],
        "timings": times,
    }
    return result


def _lift_notes(result: Result, scene: Scene, cfg: Config) -> None:
    """The lifter's warnings and dropped views, and the one line naming the step that lost every object."""
    lift_warnings = list(scene.meta.get("warnings") or [])  # e.g. views structure from motion did not register
    if lift_warnings:
        result.info["warnings"] = [*lift_warnings, *result.info.get("warnings", [])]
    if scene.meta.get("dropped_views"):
        result.info["dropped_views"] = list(scene.meta["dropped_views"])
    why = no_objects_reason(result, scene, cfg)
    if why is not None:  # one line that names the step that lost every object, instead of segment's generic ones
        result.info["no_objects"] = why
        kept = [w for w in result.info.get("warnings", []) if not w.startswith(_GENERIC_NO_OBJECT)]
        result.info["warnings"] = [*kept, why["line"]]
