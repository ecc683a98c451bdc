"""Baselines on the same inputs as GraphSeg: MaskClustering- and SAM3D-style merging.

Each baseline is ``fn(scene, masks, matches, config) -> Result`` and runs
through :func:`~graphseg.method.segment.segment` with its own stages, so
background, mask composition, outputs and metrics are identical to GraphSeg's:

* :func:`maskclustering`: MaskClustering's view-consensus criterion
  (:mod:`graphseg.graphs.consensus`), applied three times; each round
  contracts and recomputes the consensus of the merged nodes (the original
  iterates with decreasing thresholds over 3D-projected masks; here the
  containers come from the same pixel matches GraphSeg gets).
* :func:`sam3d`: SAM3D's bidirectional-overlap merging
  (:mod:`graphseg.graphs.overlap`), all view pairs at once (the original
  merges adjacent frames bottom-up).

:func:`run_method` dispatches on ``config.method``.

Examples
--------
>>> from graphseg.testing.scenes import two_boxes_scene
>>> scene, masks, matches = two_boxes_scene()
>>> r = sam3d(scene, masks, matches)
>>> r.config.stages, r.labels[0].shape == scene.views[0].shape
([['bidirectional_overlap']], True)
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..config import Config
from ..result import Result
from ..scene import Matches, Scene
from .segment import MasksLike, segment

__all__ = ["maskclustering", "sam3d", "run_method", "METHODS"]


def maskclustering(scene: Scene, masks: MasksLike, matches: Mapping[tuple[int, int], Matches], config: Config | None = None) -> Result:
    """MaskClustering-style view-consensus clustering (3 rounds, components contraction)."""
    cfg = (config or Config()).model_copy(update={"stages": [["view_consensus"]] * 3, "contractor": "star"})
    return segment(scene, masks, matches, cfg)


def sam3d(scene: Scene, masks: MasksLike, matches: Mapping[tuple[int, int], Matches], config: Config | None = None) -> Result:
    """SAM3D-style bidirectional-overlap merging (one stage, components contraction)."""
    cfg = (config or Config()).model_copy(update={"stages": [["bidirectional_overlap"]], "contractor": "star"})
    return segment(scene, masks, matches, cfg)


def _graphseg(scene: Scene, masks: MasksLike, matches: Mapping[tuple[int, int], Matches], config: Config | None = None, **kw: Any) -> Result:
    return segment(scene, masks, matches, config, **kw)


def _graphseg_minus(scene: Scene, masks: MasksLike, matches: Mapping[tuple[int, int], Matches], config: Config | None = None, **kw: Any) -> Result:
    return segment(scene, masks, matches, (config or Config()).without_3d(), **kw)


#: ``config.method`` -> function.
METHODS = {"graphseg": _graphseg, "graphseg-minus": _graphseg_minus, "maskclustering": maskclustering, "sam3d": sam3d}


def run_method(scene: Scene, masks: MasksLike, matches: Mapping[tuple[int, int], Matches], config: Config | None = None, **kw: Any) -> Result:
    """Run ``config.method`` (default ``"graphseg"``); ``kw`` (e.g. ``features``) goes to GraphSeg only.

    Examples
    --------
    >>> from graphseg.testing.scenes import two_boxes_scene
    >>> run_method(*two_boxes_scene(), Config(method="maskclustering")).config.stages[0]
    ['view_consensus']
    """
    cfg = config or Config()
    fn = METHODS[cfg.method]
    return fn(scene, masks, matches, cfg, **kw) if cfg.method.startswith("graphseg") else fn(scene, masks, matches, cfg)
