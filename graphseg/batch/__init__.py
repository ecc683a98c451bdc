"""Batch runs: many scenes x configurations x view counts, resumable, on local processes or Ray.

::

    OUT/
      .graphseg-output                   marker: a graphseg output of kind "batch"
      batch.json                         state of the last run (tasks, failures)
      aggregate.{md,csv,json}            the paper's Table I layout per split / method / views
      sparse_views.png                   mean IoU against the number of views
      runs/SCENE/METHOD/views-N/         one complete graphseg output folder per task

A task's output folder records its key (scene digest + configuration digest +
views) in ``run.json``; a re-run skips every task whose output folder holds
the same key, so re-running a finished batch does no work. Failed tasks are
recorded with their one-line error and tried again on the next run.

Examples
--------
>>> import tempfile, os
>>> from graphseg.io import write_scene_folder
>>> from graphseg.testing.scenes import box_scene, TWO_BOXES
>>> d = tempfile.mkdtemp()
>>> _ = write_scene_folder(box_scene(TWO_BOXES, views=3, shape=(48, 64)), os.path.join(d, "scenes", "a"))
>>> s = run_batch([os.path.join(d, "scenes", "a")], os.path.join(d, "out"), num_views=[2, 3])
>>> s.ok, s.failed, s.skipped, s.exit_code
(2, 0, 0, 0)
>>> run_batch([os.path.join(d, "scenes", "a")], os.path.join(d, "out"), num_views=[2, 3]).skipped
2
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..io.files import read_json
from ..scene import SceneError
from .aggregate import aggregate, plot_sparse_views, to_markdown, write_aggregate
from .executors import LocalExecutor, RayExecutor
from .tasks import Task, configurations, expand_scenes, make_tasks
from .worker import run_task, stage_timings

__all__ = [
    "run_batch",
    "rebuild_report",
    "BatchSummary",
    "LocalExecutor",
    "RayExecutor",
    "run_task",
    "aggregate",
    "write_aggregate",
    "to_markdown",
    "plot_sparse_views",
    "expand_scenes",
    "configurations",
    "make_tasks",
    "STATE",
]

#: The file that holds the state of a batch folder (marked as kind ``batch`` by ``.graphseg-output``).
STATE = "batch.json"


@dataclass
class BatchSummary:
    """What a batch did: counts, the records of every task and the aggregate files."""

    tasks: int
    ok: int
    failed: int
    skipped: int
    records: list[dict[str, Any]] = field(default_factory=list)
    files: dict[str, Path] = field(default_factory=dict)
    seconds: float = 0.0

    @property
    def exit_code(self) -> int:
        """0 when every task succeeded, 3 when the batch finished and some failed."""
        return 3 if self.failed else 0


def _check_out(out: Path, inputs: Sequence[str]) -> None:
    """A batch writes into a new folder or an earlier batch output, never into or around its inputs."""
    from ..output import check_target, read_marker

    check_target(out, "batch", inputs=inputs, overwrite=True)  # symlinks, inputs, root/home
    if out.exists():
        if not out.is_dir():
            raise SceneError("exists and is not a folder", where=str(out), field="output")
        marker = read_marker(out)
        if any(out.iterdir()) and (marker is None or marker.get("kind") != "batch"):
            raise SceneError("exists, is not empty and is not a graphseg batch output; choose a new folder", where=str(out), field="output")


def _read_json(path: Path) -> dict[str, Any] | None:
    try:
        data = read_json(path, field=path.name)
    except (OSError, SceneError):
        return None
    return data if isinstance(data, dict) else None


def record_from_output(folder: str | os.PathLike[str]) -> dict[str, Any] | None:
    """The record of a finished task, rebuilt from its output folder (None if it is not one)."""
    root = Path(folder)
    info = _read_json(root / "run.json")
    if not info or not isinstance(info.get("batch"), dict) or not (root / "result.npz").is_file():
        return None
    b = info["batch"]
    metrics = _read_json(root / "metrics.json")
    rec = {k: b.get(k) for k in ("key", "scene_label", "split", "method", "label", "num_views")}
    rec.update(
        scene=info.get("scene"),
        out=str(root),
        status="ok",
        error=None,
        num_objects=info.get("num_objects"),
        metrics=(metrics or {}).get("mean"),
        timings=stage_timings(info, info.get("timings")),
    )
    return rec


def _finished(task: Task) -> dict[str, Any] | None:
    rec = record_from_output(task.out)
    return rec if rec is not None and rec.get("key") == task.key else None


def _write_state(out: Path, records: Sequence[dict[str, Any]], extra: dict[str, Any]) -> None:
    state = {
        "format": "graphseg-batch",
        "version": 1,
        **extra,
        "failed": [{k: r.get(k) for k in ("key", "scene", "label", "split", "method", "num_views", "error")} for r in records if r.get("status") != "ok"],
    }
    tmp = out / f".{STATE}.tmp-{os.getpid()}"
    tmp.write_text(json.dumps(state, indent=2, default=str), encoding="utf-8")
    os.replace(tmp, out / STATE)


def run_batch(
    scenes: Sequence[str],
    out: str | os.PathLike[str],
    *,
    methods: Sequence[str] | None = None,
    config_files: Sequence[str] | None = None,
    preset: str | None = None,
    num_views: Sequence[int | None] = (None,),
    dataset: dict[str, Any] | None = None,
    backends: dict[str, str | None] | None = None,
    executor: Any = None,
    progress: bool = False,
) -> BatchSummary:
    """Run every (scene, configuration, views) task that is not finished yet, then aggregate.

    Parameters
    ----------
    scenes : list of str
        Scene folders, glob patterns, or dataset roots (with ``dataset``).
    out : path-like
        The batch folder: new, or an earlier batch output (resumed).
    methods, config_files, preset
        The configurations swept (see :func:`graphseg.batch.tasks.configurations`;
        ``preset`` None: ``Config()``).
    num_views : list of int or None
        View counts (evenly spaced views; None = all views).
    dataset : dict, optional
        For dataset roots: ``{"split": ..., "videos": [...]}`` (see
        :func:`graphseg.batch.tasks.expand_scenes`).
    backends : dict, optional
        ``{"segmenter": ..., "matcher": ..., "lifter": ...}`` names.
    executor : LocalExecutor or RayExecutor, optional
        Default: one local worker process.
    progress : bool
        One overall bar: done, failed and remaining, with an ETA.

    Returns
    -------
    BatchSummary
        ``exit_code`` is 0 when everything succeeded, 3 when some task failed.

    Raises
    ------
    SceneError
        Bad arguments (unknown scenes, methods, configs or an output folder that is
        not a batch output); nothing is run then.
    KeyboardInterrupt
        After stopping the workers; finished outputs and ``batch.json`` stay.
    """
    t0 = time.perf_counter()
    root = Path(out)
    dataset = dict(dataset or {})
    unknown = sorted(set(dataset) - {"split", "videos"})
    if unknown:
        raise SceneError(f"unknown dataset option {unknown[0]!r} (expected split, videos)", where=str(out), field="dataset")
    specs = expand_scenes(scenes, split=dataset.get("split"), videos=dataset.get("videos"))
    configs = configurations(methods, config_files, preset=preset, backends=backends)
    _check_out(root, [s.path for s in specs] + list(config_files or []))
    if any(n is not None and n < 1 for n in num_views):
        raise SceneError(f"view counts must be >= 1 (got {list(num_views)})", where="--num-views", field="num_views")
    tasks = make_tasks(specs, configs, list(num_views), root)
    done: list[dict[str, Any]] = []
    todo: list[Task] = []
    for t in tasks:
        rec = _finished(t)
        (done.append(rec) if rec is not None else todo.append(t))
    from ..output import read_marker, write_marker

    root.mkdir(parents=True, exist_ok=True)
    if read_marker(root) is None:
        write_marker(root, "batch")
    records = list(done)
    new: list[dict[str, Any]] = []
    bar = None
    if progress and todo:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(todo), desc="batch", unit="task", disable=None)  # no bar when stderr is not a terminal

    failed = 0

    def on_record(rec: dict[str, Any]) -> None:
        nonlocal failed
        new.append(rec)
        records.append(rec)
        failed += rec["status"] != "ok"
        if bar is not None:
            bar.set_postfix(done=len(new) - failed, failed=failed, left=len(todo) - len(new), refresh=False)
            bar.update(1)

    extra = {"scenes": [s.path for s in specs], "configurations": [c.label for c in configs], "num_views": list(num_views), "tasks": len(tasks)}
    try:
        (executor or LocalExecutor(1)).execute([t.to_dict() for t in todo], on_record)
    except BaseException:
        _write_state(root, records, {**extra, "interrupted": True})
        raise
    finally:
        if bar is not None:
            bar.close()
    _write_state(root, records, {**extra, "interrupted": False})
    files = write_aggregate(root, records)
    failed = sum(r["status"] != "ok" for r in records)
    return BatchSummary(len(tasks), len(records) - failed, failed, len(done), records, files, time.perf_counter() - t0)


def rebuild_report(out: str | os.PathLike[str]) -> BatchSummary:
    """Rebuild the aggregate of a batch folder from its output folders (and recorded failures)."""
    root = Path(out)
    state = _read_json(root / STATE)
    if state is None or state.get("format") != "graphseg-batch":
        raise SceneError(f"not a graphseg batch output (no valid {STATE})", where=str(root), field="output")
    from ..output import BACKUP

    runs = [p for p in sorted(root.glob("runs/*/*/views-*")) if BACKUP not in p.name]  # not an earlier output kept aside
    records = [r for p in runs if (r := record_from_output(p)) is not None]
    ok_keys = {r["key"] for r in records}
    for f in state.get("failed") or []:
        if f.get("key") not in ok_keys:
            records.append({**f, "status": "failed"})
    files = write_aggregate(root, records)
    failed = sum(r["status"] != "ok" for r in records)
    return BatchSummary(len(records), len(records) - failed, failed, len(records) - failed, records, files)
