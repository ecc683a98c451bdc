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

__all__ = ["run_task", "record_path"]


def record_path(out: str) -> str:
    """Where a task's record lives: next to (not inside) its output folder."""
    return os.path.join(os.path.dirname(out), f".{os.path.basename(out)}.record.json")


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
        "num_objects", "seconds", "pid", ...}`` plus the task's identifying fields.
    """
    from ..config import Config
    from ..io import load_scene
    from ..metrics import evaluate
    from ..output import write_output
    from ..pipeline import lift, run
    from ..registry import MissingDependencyError, PluginNotFoundError
    from ..scene import SceneError

    t0 = time.perf_counter()
    rec: dict[str, Any] = {k: task[k] for k in ("key", "scene", "scene_label", "split", "method", "label", "num_views", "out")}
    rec["pid"] = os.getpid()
    try:
        cfg = Config.model_validate(task["config"])
        scene = load_scene(task["scene"], num_views=task["num_views"])
        be = task.get("backends") or {}
        t_lift = time.perf_counter()
        scene = lift(scene, be.get("lifter"), cfg)
        t_lift = time.perf_counter() - t_lift
        result = run(scene, cfg, segmenter=be.get("segmenter"), matcher=be.get("matcher"))
        metrics = None
        if scene.has_instances:
            metrics = evaluate(result.labels, [v.instances for v in scene.views], [v.points for v in scene.views], names=scene.objects)
        batch = {k: task[k] for k in ("key", "scene_label", "split", "method", "label", "num_views")}
        info = {"scene": task["scene"], "views": [v.name for v in scene.views], "batch": {**batch, "lift": t_lift}}
        os.makedirs(os.path.dirname(task["out"]), exist_ok=True)
        write_output(task["out"], result, scene, metrics=metrics, run_info=info)
        rec.update(
            status="ok",
            error=None,
            views=len(scene.views),
            num_objects=result.num_objects,
            metrics=(metrics or {}).get("mean"),
            timings={**{k: float(v) for k, v in (result.info.get("pipeline") or {}).get("timings", {}).items()}, "lift": t_lift},
        )
    except (SceneError, PluginNotFoundError, MissingDependencyError, FileNotFoundError, ValueError) as err:
        rec.update(status="failed", error=_one_line(err))
    except Exception as err:  # an internal error must not stop the batch either
        rec.update(status="failed", error=f"internal error: {type(err).__name__}: {_one_line(err)}", traceback=traceback.format_exc(limit=8))
    rec["seconds"] = time.perf_counter() - t0
    return rec
