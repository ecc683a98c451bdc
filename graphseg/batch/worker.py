"""The one function every executor runs: :func:`run_task` (a task dict in, a record dict out).

It never raises: a bad scene or an internal error becomes a ``failed`` record
with a one-line message, so one scene cannot stop a batch. The output folder
is written atomically by :func:`graphseg.output.write_output`, so an
interrupted task leaves no half output.
"""

from __future__ import annotations

import os
import time
import traceback
from typing import Any

__all__ = ["run_task", "stage_timings"]


def stage_timings(result_info: dict[str, Any], job_timings: dict[str, float] | None = None) -> dict[str, float]:
    """Seconds per stage of one task: read, lift, segment, match, (features), graph, evaluate.

    Examples
    --------
    >>> stage_timings({"pipeline": {"timings": {"lift": 0.0, "segment": 2.0, "total": 9.0}}}, {"lift": 1.5, "read": 0.5})
    {'segment': 2.0, 'lift': 1.5, 'read': 0.5}
    """
    out = {k: float(v) for k, v in ((result_info.get("pipeline") or {}).get("timings") or {}).items() if k not in ("total", "lift")}
    for k in ("lift", "read", "evaluate"):
        if job_timings and k in job_timings:
            out[k] = float(job_timings[k])
    return out


def _one_line(err: BaseException) -> str:
    text = str(err).strip().splitlines()
    return f"{text[0] if text else type(err).__name__}"


def run_task(task: dict[str, Any]) -> dict[str, Any]:
    """Run one (scene, configuration, views) task and write its output folder.

    Parameters
    ----------
    task : dict
        :meth:`graphseg.batch.tasks.Task.to_dict`.

    Returns
    -------
    dict
        ``{"key", "status": "ok" | "failed", "error", "metrics" (means), "timings",
        "num_objects", "warnings", "seconds", "pid", ...}`` plus the task's identifying fields.
    """
    from ..config import Config
    from ..job import run_job
    from ..parallel import jobs
    from ..registry import MissingDependencyError, PluginNotFoundError
    from ..scene import SceneError

    t0 = time.perf_counter()
    rec: dict[str, Any] = {k: task[k] for k in ("key", "scene", "scene_label", "split", "method", "label", "num_views", "out")}
    rec["pid"] = os.getpid()
    try:
        cfg = Config.model_validate(task["config"])
        be = task.get("backends") or {}
        batch = {k: task[k] for k in ("key", "scene_label", "split", "method", "label", "num_views")}
        os.makedirs(os.path.dirname(task["out"]), exist_ok=True)
        with jobs(1):  # the batch runs its tasks in parallel already: one process per task
            job = run_job(
                task["scene"],
                task["out"],
                cfg,
                backends={k: be.get(k) for k in ("segmenter", "matcher", "lifter")},
                read={"num_views": task["num_views"]},
                run_info={"batch": batch},
            )
        rec.update(
            status="ok",
            error=None,
            views=len(job.scene.views),
            num_objects=job.result.num_objects,
            metrics=(job.metrics or {}).get("mean"),
            timings=stage_timings(job.result.info, job.timings),
            warnings=list(job.warnings),  # e.g. an earlier output of the task kept as OUT.graphseg-backup-N
        )
    except (SceneError, PluginNotFoundError, MissingDependencyError, FileNotFoundError, ValueError) as err:
        rec.update(status="failed", error=_one_line(err))
    except Exception as err:  # an internal error must not stop the batch either
        rec.update(status="failed", error=f"internal error: {type(err).__name__}: {_one_line(err)}", traceback=traceback.format_exc(limit=8))
    rec["seconds"] = time.perf_counter() - t0
    return rec
