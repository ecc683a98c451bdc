"""graphseg: consistent, object-level 3D segments from a few RGB(-D) views.

Implements GraphSeg (Tang et al., 2025): masks become nodes of a correspondence
graph, 2D pixel matches and 3D Chamfer proximity add edges, and contraction
turns connected masks into objects consistent across views.
"""

from __future__ import annotations

from typing import Any

from ._version import __version__

__all__ = ["__version__", "segment", "Scene", "View", "Matches", "Config", "Result", "run_job", "evaluate_output", "SceneGraph"]


def __getattr__(name: str) -> Any:  # lazy top-level API (PEP 562)
    if name in ("Scene", "View", "Matches"):
        from . import scene

        return getattr(scene, name)
    if name == "segment":
        from .method.segment import segment

        return segment
    if name == "Config":
        from .config import Config

        return Config
    if name in ("run_job", "evaluate_output"):
        from . import job

        return getattr(job, name)
    if name == "Result":
        from .result import Result

        return Result
    if name == "SceneGraph":
        from .store import SceneGraph

        return SceneGraph
    raise AttributeError(f"module 'graphseg' has no attribute {name!r}")
