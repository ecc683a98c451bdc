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

:func:`run_method` dispatches on ``config.method`` (the config's validator gives it the method's stages).

Examples
--------
>>> from graphseg.testing.scenes import two_boxes_scene
>>> scene, masks, matches = two_boxes_scene()
>>> r = sam3d(scene, masks, matches)
>>> r.config.stage_names(), r.labels[0].shape == scene.views[0].shape
([['bidirectional_overlap']], True)
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..config import Config
from ..result import Result
from ..scene import Matches, Scene
from .segment import MasksLike, segment

__all__ = ["maskclustering", "sam3d", "run_method"]


def _with(config: Config | None, **update: Any) -> Config:
    """A validated copy of ``config`` with some top-level keys replaced (stages are re-validated)."""
    return Config.model_validate({**(config or Config()).to_dict(), **update})


def maskclustering(scene: Scene, masks: MasksLike, matches: Mapping[tuple[int, int], Matches], config: Config | None = None) -> Result:
    """MaskClustering-style view-consensus clustering (3 rounds, components contraction)."""
    return segment(scene, masks, matches, _with(config, method="maskclustering"))  # segment() runs the method's stages


def sam3d(scene: Scene, masks: MasksLike, matches: Mapping[tuple[int, int], Matches], config: Config | None = None) -> Result:
    """SAM3D-style bidirectional-overlap merging (one stage, components contraction)."""
    return segment(scene, masks, matches, _with(config, method="sam3d"))


def run_method(scene: Scene, masks: MasksLike, matches: Mapping[tuple[int, int], Matches], config: Config | None = None, **kw: Any) -> Result:
    """Run ``config.method`` (default ``"graphseg"``) on the same inputs; ``kw`` (e.g. ``features``) goes to :func:`segment`.

    Examples
    --------
    >>> from graphseg.testing.scenes import two_boxes_scene
    >>> run_method(*two_boxes_scene(), Config(method="maskclustering")).config.stage_names()[0]
    ['view_consensus']
    """
    return segment(scene, masks, matches, config, **kw)
