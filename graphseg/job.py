"""One library entry point for a whole job: scene -> lift -> run -> evaluate -> write.

The command line (``graphseg run`` / ``demo``), the Python API and batch
runners all call :func:`run_job`; it prints nothing and knows nothing of
argparse. The order is chosen so that every input problem surfaces before any
work is done:

1. backend names and options are resolved (unknown names, bad options and
   missing dependencies are reported before any image is read);
2. the output target is checked (:func:`graphseg.output.check_target`);
3. the scene is read (if given as a path) and validated;
4. the estimated peak memory is compared with the available memory;
5. the scene is lifted once, segmented, evaluated against its ground truth
   (when it has some), and the output folder is written atomically.

Examples
--------
>>> import tempfile, os
>>> from graphseg.testing.scenes import box_scene, TWO_BOXES
>>> scene = box_scene(TWO_BOXES, views=2, shape=(48, 64))
>>> with tempfile.TemporaryDirectory() as d:
...     job = run_job(scene, os.path.join(d, "out"))
...     sorted(job.metrics["mean"])[:2], job.result.num_objects, job.out.name
(['chamfer', 'f1'], 2, 'out')
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .config import Config
from .result import Result, jsonable
from .scene import Scene, SceneError

__all__ = [
    "JobResult",
    "run_job",
    "evaluate_output",
    "evaluate_scene",
    "estimate_peak_memory",
    "available_memory",
    "check_memory",
]

#: Bytes per pixel and view at the peak of a run (images, depth, points, labels,
#: matches, per-mask work). Measured: about 55-65 B (scene arrays ~23 B plus 30-42 B of
#: peak RSS growth, demo box scene, 4 and 8 views of 640x480, geometric segmenter);
#: 160 leaves room for heavier backends.
BYTES_PER_PIXEL = 160


@dataclass
class JobResult:
    """What :func:`run_job` produced.

    Attributes
    ----------
    result : Result
    scene : Scene
        The lifted scene (world point maps filled in).
    metrics : dict or None
        Metrics against the scene's ground truth, when it has some.
    out : Path or None
        The output folder written (None when ``out=None``).
    timings : dict of str to float
        Seconds per step: ``resolve``, ``read``, ``lift``, ``run``, ``evaluate``, ``write``, ``total``.
    warnings : list of str
        One-line warnings (degenerate input, objects that fell off, an
        existing output kept as ``OUT.graphseg-backup-N``, ...).
    """

    result: Result
    scene: Scene
    metrics: dict[str, Any] | None
    out: Path | None
    timings: dict[str, float] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)


def estimate_peak_memory(num_views: int, height: int, width: int) -> int:
    """Estimated peak bytes of a run on ``num_views`` views of ``height`` x ``width``.

    Examples
    --------
    >>> estimate_peak_memory(8, 480, 640) // 2**20
    375
    """
    return int(num_views) * int(height) * int(width) * BYTES_PER_PIXEL


def available_memory() -> int | None:
    """Bytes of memory available now (Linux ``MemAvailable``, else psutil), or None if unknown."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        import psutil
    except ImportError:
        return None
    return int(psutil.virtual_memory().available)


def check_memory(scene: Scene, where: str) -> None:
    """Raise SceneError when the estimated peak memory of a run exceeds the available memory.

    Set ``GRAPHSEG_SKIP_MEMORY_CHECK=1`` to skip the check.
    """
    if os.environ.get("GRAPHSEG_SKIP_MEMORY_CHECK") or not scene.views:
        return
    h, w = scene.views[0].shape
    need = estimate_peak_memory(len(scene.views), h, w)
    have = available_memory()
    if have is not None and need > have:
        raise SceneError(
            f"{len(scene.views)} views of {w}x{h} need about {need / 2**30:.1f} GiB but {have / 2**30:.1f} GiB are available; "
            "select fewer views (--num-views / --step) or set GRAPHSEG_SKIP_MEMORY_CHECK=1",
            where=where,
            field="memory",
        )


def evaluate_scene(result: Result, scene: Scene) -> dict[str, Any] | None:
    """Metrics of ``result`` against ``scene``'s ground truth (None without instances or points)."""
    from .metrics import evaluate

    if not scene.has_instances or not scene.has_points:
        return None
    return evaluate(result.labels, [np.asarray(v.instances) for v in scene.views], [np.asarray(v.points) for v in scene.views], names=scene.objects)


def _named(given: Mapping[str, Any] | None, keys: tuple[str, ...], what: str) -> list[Any]:
    """The values of ``keys`` in ``given`` (None where absent); an unknown key is a ValueError naming it."""
    given = dict(given or {})
    unknown = sorted(set(given) - set(keys))
    if unknown:
        raise ValueError(f"run_job {what}: unknown key {unknown[0]!r} (expected {', '.join(keys)})")
    return [given.get(k) for k in keys]


def run_job(
    scene_or_path: Scene | str | os.PathLike[str],
    out: str | os.PathLike[str] | None,
    config: Config | None = None,
    *,
    backends: Mapping[str, Any] | None = None,
    read: Mapping[str, Any] | None = None,
    overwrite: bool = False,
    progress: bool = False,
    inputs: Sequence[str | os.PathLike[str]] = (),
    run_info: dict[str, Any] | None = None,
    kind: str = "run",
) -> JobResult:
    """Run one GraphSeg job end to end and (unless ``out`` is None) write its output folder.

    Parameters
    ----------
    scene_or_path : Scene or path-like
        An in-memory scene or a scene folder in any supported layout.
    out : path-like or None
        Output folder: new, or an earlier graphseg output of ``kind`` (or
        ``overwrite``). None: nothing is written. An existing ``out`` that is
        not exactly an earlier graphseg output of ``kind`` (a file added,
        changed or removed; or another folder, with ``overwrite``) is kept as
        ``OUT.graphseg-backup-N``, never deleted, and
        :attr:`JobResult.warnings` says so.
    config : Config, optional
        Default ``Config()``.
    backends : dict, optional
        ``segmenter``, ``matcher``, ``lifter``: a name, class or instance each
        (None or absent: ``config.backends``'s). The lifter runs only when the
        scene has no point maps or a lifter is named.
    read : dict, optional
        How to read the scene: ``views``, ``step``, ``num_views`` (the view
        selection, :func:`graphseg.io.select_indices`; ``views`` entries that
        are strings match view names; an in-memory scene is selected the same
        way) and ``format`` (a path's layout; default: detected).
    overwrite : bool
        Replace an existing target that is no graphseg output of ``kind``
        (it is kept as ``OUT.graphseg-backup-N``).
    progress : bool
        Progress bars (on stderr).
    inputs : sequence of path-like
        Further inputs (masks folder, config file) that the output may not be,
        contain or lie in; the scene folder is always one.
    run_info : dict, optional
        Extra entries for ``run.json``.
    kind : str
        Marker kind of the output folder.

    Returns
    -------
    JobResult

    Raises
    ------
    SceneError
        For every bad input, including a refused output target and too little memory.
    PluginNotFoundError, MissingDependencyError
        For unknown backends or missing extras, before any image is read.
    """
    from .io import detect_format, load_scene
    from .output import backup_message, check_target, write_output
    from .pipeline import backend_name, execute, plan_run, resolve_backends

    cfg = config or Config()
    segmenter, matcher, lifter = _named(backends, ("segmenter", "matcher", "lifter"), "backends")
    views, step, num_views, format = _named(read, ("views", "step", "num_views", "format"), "read")
    t0 = time.perf_counter()
    timings: dict[str, float] = {}
    is_path = not isinstance(scene_or_path, Scene)
    need_lifter = is_path or lifter is not None or not scene_or_path.has_points  # type: ignore[union-attr]
    backends = resolve_backends(cfg, segmenter=segmenter, matcher=matcher, lifter=lifter, need_lifter=need_lifter)
    timings["resolve"] = time.perf_counter() - t0
    all_inputs: list[str | os.PathLike[str]] = [*inputs]
    if not isinstance(scene_or_path, Scene):
        all_inputs.insert(0, scene_or_path)
    if out is not None:
        check_target(out, kind, inputs=all_inputs, overwrite=overwrite)
    t = time.perf_counter()
    info = dict(run_info or {})
    if is_path:
        path = Path(scene_or_path)  # type: ignore[arg-type]
        fmt = format or detect_format(path)
        scene = load_scene(path, format=fmt, views=views, step=step, num_views=num_views)
        info.setdefault("scene", str(path.resolve()))
        info.setdefault("format", fmt)
    else:
        scene = scene_or_path  # type: ignore[assignment]
        if views is not None or step is not None or num_views is not None:
            from .io import select_indices

            scene = scene.select(select_indices(len(scene), views=views, step=step, num_views=num_views, names=[v.name for v in scene.views], where=scene.name))
        info.setdefault("scene", scene.meta.get("source", scene.name))
        info.setdefault("format", scene.meta.get("format", "memory"))
    info.setdefault("views", [v.name for v in scene.views])
    timings["read"] = time.perf_counter() - t
    t = time.perf_counter()
    # validated, lifted and configured once (the backends were resolved above, before any image was read)
    where = str(info.get("scene"))
    plan = plan_run(scene, cfg, segmenter=segmenter, matcher=matcher, lifter=lifter, backends=backends, check=lambda sc: check_memory(sc, where))
    scene = plan.scene  # the metrics need its points
    info.update({"sfm": json.loads(json.dumps(scene.meta["sfm"], default=jsonable))} if scene.meta.get("sfm") else {})  # registered views, variants and draws tried
    if scene.meta.get("dropped_views"):  # the lifter left views out (not registered, or wrongly posed): run.json says which
        info["views"] = [v.name for v in scene.views]
        info["dropped_views"] = list(scene.meta["dropped_views"])
    timings["lift"] = time.perf_counter() - t
    t = time.perf_counter()
    names = {"segmenter": backend_name(segmenter, cfg.backends.segmenter), "matcher": backend_name(matcher, cfg.backends.matcher)}
    result = execute(plan, progress=progress, names=names)
    timings["run"] = time.perf_counter() - t
    info["steps"] = result.config.step_names()  # the method that ran: edge stages, then graph operations
    info["refiners"] = dict(result.info.get("refiners") or {})  # pixels the pixel refiners moved (the objects graph explains the rest)
    why = result.info.get("no_objects")
    if why:  # run.json says which step lost every object (the same line is among the warnings)
        info["no_objects"] = {"step": why["step"], "reason": why["line"]}
    t = time.perf_counter()
    metrics = evaluate_scene(result, scene)
    if metrics is not None:  # ground truth: audit the edges too (shown in report.html and metrics.json)
        from .audit import audit as edge_audit

        metrics["audit"] = edge_audit(result, scene)
    timings["evaluate"] = time.perf_counter() - t
    warnings = list(result.info.get("warnings", []))
    from .scene import fell_off_warning

    fell = fell_off_warning(scene)
    if fell:
        warnings.append(fell)
    result.info["warnings"] = warnings
    path_out = None
    info["timings"] = dict(timings)  # read, lift, run, evaluate (run.json); the write is timed below
    t = time.perf_counter()
    if out is not None:
        moved: list[tuple[Path, Path]] = []
        path_out = write_output(out, result, scene, metrics=metrics, run_info=info, inputs=all_inputs, overwrite=overwrite, kind=kind, moved=moved)
        # a new list: result.info["warnings"] (written to run.json) is about the result, not about this write
        warnings = [*warnings, *(backup_message(old, kept, shown=out, kind=kind) for old, kept in moved)]
    timings["write"] = time.perf_counter() - t
    timings["total"] = time.perf_counter() - t0
    return JobResult(result, scene, metrics, path_out, timings, warnings)


def _run_points(sc: Scene, out: Path, where: str) -> Scene:
    """The scene with the point maps the run used: its stored estimates, or the scene's measured depth; never a new estimate."""
    from .pipeline import lift

    if (out / "points").is_dir():
        from .io.precomputed import apply_point_maps

        return apply_point_maps(sc, out / "points")
    if sc.has_points:
        return sc
    if sc.has_depth:
        return lift(sc, "rgbd")  # measured depth: the same points by geometry alone
    raise SceneError(
        "the scene has no depth and the output stores no estimated points (written by an older graphseg): run it again to evaluate it",
        where=where,
        field="points",
    )


def evaluate_output(out: str | os.PathLike[str], scene: Scene | str | os.PathLike[str] | None = None, *, audit: bool = False) -> dict[str, Any]:
    """Metrics of an output folder against ground truth.

    Parameters
    ----------
    out : path-like
        A folder written by :func:`run_job` / ``graphseg run``.
    scene : Scene or path-like, optional
        The scene with ground truth; default: the one recorded in ``run.json``.
    audit : bool
        Also audit the edges against the ground truth (:func:`graphseg.audit.audit`),
        under the key ``"audit"``.

    Raises
    ------
    SceneError
        When the scene cannot be found, has no ground truth, or its view names
        (or image sizes) differ from the result's.
    """
    from .io import load_scene
    from .output import read_output

    result, info = read_output(out)
    if scene is None:
        scene = info.get("scene")
        if not scene:
            raise SceneError("run.json names no scene; pass a scene", where=str(out), field="scene")
        where = str(scene)
        fmt = info.get("format")
        sc = load_scene(scene, format=fmt if fmt in ("native", "ycbv", "bop", "graspnet") else None, views=result.view_names)
    elif isinstance(scene, Scene):
        where = scene.name
        names = [v.name for v in scene.views]
        missing = [n for n in result.view_names if n not in names]
        if missing:
            raise SceneError(f"the scene has no view {missing[0]!r} of the result", where=where, field="views")
        sc = scene.select([names.index(n) for n in result.view_names])
    else:
        where = str(scene)
        from .io import detect_format

        fmt = detect_format(scene)
        try:
            sc = load_scene(scene, format=fmt, views=result.view_names)
        except SceneError as err:
            if "unknown view" in str(err):
                raise SceneError(f"the scene's view names differ from the result's ({err})", where=where, field="views") from err
            raise
    if [v.name for v in sc.views] != result.view_names:
        raise SceneError("the scene's view names differ from the result's", where=where, field="views")
    for v, lab in zip(sc.views, result.labels):
        if v.shape != lab.shape:
            raise SceneError(f"view {v.name!r} is {list(v.shape)} but the result's labels are {list(lab.shape)}", where=where, field="views")
    if not sc.has_instances:
        raise SceneError("the scene has no ground truth", where=where, field="instances")
    sc = _run_points(sc, Path(out), where)
    metrics = evaluate_scene(result, sc)
    assert metrics is not None
    if audit:
        from .audit import audit as edge_audit

        metrics["audit"] = edge_audit(result, sc)
    return metrics
