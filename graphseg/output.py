"""The output folder of a run, written to a temporary sibling and renamed (never half an output).

::

    OUT/
      labels/VIEW.png        uint16 object ids, consistent across views (0 = background)
      overlays/VIEW.png      RGB with coloured objects and their ids
      objects/OBJ.ply        per-object points and colours (OBJ = 001, 002, ...)
      graph_2d.graphml       the mask graph with its 2D edges
      graph_3d.graphml       the super graph with its 3D edges (when the 3D stage ran)
      result.npz             the native result file (Result.load)
      config.yaml            the configuration used
      run.json               scene path, views, backends, timings
      metrics.json           when the scene has ground truth
      report.html            overlays + interactive 3D view, works offline
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from .graphs import write_graphml
from .io.images import write_png
from .io.ply import write_ply
from .report import overlay, palette, render_report
from .result import Result
from .scene import Scene

__all__ = ["write_output", "read_output", "write_object_clouds", "RESULT_FILE"]

RESULT_FILE = "result.npz"


def _safe(name: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in name) or "view"


def write_object_clouds(result: Result, folder: str | os.PathLike[str]) -> int:
    """Write one PLY per object (``001.ply``, ...) into ``folder``; returns how many."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    for k in range(1, result.num_objects + 1):
        pts, cols = result.object_cloud(k)
        write_ply(folder / f"{k:03d}.ply", pts, cols)
    return result.num_objects


def write_output(
    out: str | os.PathLike[str],
    result: Result,
    scene: Scene,
    *,
    metrics: dict[str, Any] | None = None,
    run_info: dict[str, Any] | None = None,
) -> Path:
    """Write every output file for ``result`` into ``out`` (replacing an existing folder).

    Raises
    ------
    PermissionError, OSError
        When the parent folder cannot be written; nothing is left behind.
    """
    dest = Path(out).resolve()
    dest.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{dest.name}.tmp-", dir=dest.parent))
    try:
        colors = palette(result.num_objects)
        (tmp / "labels").mkdir()
        (tmp / "overlays").mkdir()
        overlays = []
        for v, (view, lab) in enumerate(zip(scene.views, result.labels)):
            name = _safe(result.view_names[v])
            write_png(tmp / "labels" / f"{name}.png", lab.astype(np.uint16))
            ov = overlay(view.rgb, lab, colors)
            write_png(tmp / "overlays" / f"{name}.png", ov)
            overlays.append(ov)
        write_object_clouds(result, tmp / "objects")
        write_graphml(result.graph_2d, tmp / "graph_2d.graphml")
        if result.graph_3d is not None:
            write_graphml(result.graph_3d, tmp / "graph_3d.graphml")
        result.save(tmp / RESULT_FILE)
        result.config.save(tmp / "config.yaml")
        info = dict(run_info or {})
        info.setdefault("views", result.view_names)
        info.setdefault("num_objects", result.num_objects)
        info.setdefault("pipeline", result.info.get("pipeline"))
        (tmp / "run.json").write_text(json.dumps(info, indent=2, default=str))
        if metrics is not None:
            (tmp / "metrics.json").write_text(json.dumps(metrics, indent=2))
        summary = {
            "scene": info.get("scene", scene.name),
            "views": len(result.view_names),
            "objects": result.num_objects,
            "stages": " -> ".join("+".join(s) for s in result.config.stage_names()),
        }
        if result.info.get("pipeline"):
            p = result.info["pipeline"]
            summary["backends"] = f"segmenter={p.get('segmenter')}, matcher={p.get('matcher')}, lifter={p.get('lifter')}"
        page = render_report(
            title=f"graphseg: {scene.name}",
            view_names=result.view_names,
            overlays=overlays,
            points=result.object_points.points,
            point_colors=colors[result.object_points.node_of_point() + 1],
            metrics=metrics,
            summary=summary,
        )
        (tmp / "report.html").write_text(page)
        if dest.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{dest.name}.old-", dir=dest.parent))
            os.replace(dest, old / "x")
            os.replace(tmp, dest)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, dest)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return dest


def read_output(out: str | os.PathLike[str]) -> tuple[Result, dict[str, Any]]:
    """The :class:`Result` and ``run.json`` of an output folder."""
    from .scene import SceneError

    root = Path(out)
    if not (root / RESULT_FILE).is_file():
        raise SceneError(f"not a graphseg output folder (no {RESULT_FILE})", where=str(root), field="path")
    info = json.loads((root / "run.json").read_text()) if (root / "run.json").exists() else {}
    return Result.load(root / RESULT_FILE), info
