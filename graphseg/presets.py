"""The named configurations of :meth:`graphseg.Config.preset`, as plain data.

Written like a config file and kept apart from :mod:`graphseg.config` (which
validates them) so that the command line can list the preset names and its
default without importing pydantic. :mod:`graphseg.config` re-exports all three.

Examples
--------
>>> PRESET_NAMES[0] == DEFAULT_PRESET, sorted(PRESETS) == sorted(PRESET_NAMES)
(True, True)
"""

from __future__ import annotations

from typing import Any

from .published import TAU_3D_OFFICIAL

__all__ = ["PRESETS", "DEFAULT_PRESET", "PRESET_NAMES"]

#: Named configurations for :meth:`Config.preset`, written like a config file.
PRESETS: dict[str, dict[str, Any]] = {
    "paper": {},
    "rgbd": {
        "stages": [
            [{"pixel_match": {"normalization": "pair_hits", "tau": 0.3, "min_matches": 5}}],
            [{"chamfer_3d": {"tau": TAU_3D_OFFICIAL}}],
        ],
        "background": {"max_overlap": 0.5},
        "split": {"enabled": True, "mask_join": 0.5, "snap_share": 0.85},
    },
    # rgbd plus the robust contraction of issue 12 (measured in docs/results.md, "Robust contraction")
    "robust": {
        "stages": [
            [
                {"pixel_match": {"normalization": "pair_hits", "tau": 0.3, "min_matches": 5}},
                {"depth_repulsion": {"jump": 0.1, "concave": 0.2, "fraction": 0.5, "reach": 4}},
            ],
            [
                {"chamfer_3d": {"tau": TAU_3D_OFFICIAL, "outliers": "dbscan", "dbscan_min_samples": 15}},
                {"depth_repulsion": {"jump": 0.1, "concave": 0.2, "fraction": 0.5, "reach": 4}},
                {"smooth_adjacency": {"color": 20.0}},
            ],
        ],
        "contractor": "constrained",
        "background": {"max_overlap": 0.5},
        "split": {"enabled": True},
    },
    # robust with greedy additive edge contraction and smooth_adjacency without its colour test
    # (issue 21; chosen on the tune half of bench_ycb_views.py, measured in docs/results.md)
    "multicut": {
        "stages": [
            [
                {"pixel_match": {"normalization": "pair_hits", "tau": 0.3, "min_matches": 5}},
                {"depth_repulsion": {"jump": 0.1, "concave": 0.2, "fraction": 0.5, "reach": 4}},
            ],
            [
                {"chamfer_3d": {"tau": TAU_3D_OFFICIAL, "outliers": "dbscan", "dbscan_min_samples": 15}},
                {"depth_repulsion": {"jump": 0.1, "concave": 0.2, "fraction": 0.5, "reach": 4}},
                {"smooth_adjacency": {"color": None}},
            ],
        ],
        "contractor": "gaec",
        "background": {"max_overlap": 0.5},
        "split": {"enabled": True},
    },
}

#: The preset the command line (``run``, ``demo``, ``batch``, a new store) and
#: :func:`graphseg.batch.run_batch` start from: measured for metric RGB-D input.
#: ``Config()`` itself is the paper's (``"paper"``).
DEFAULT_PRESET: str = "rgbd"

#: The names of :data:`PRESETS`, :data:`DEFAULT_PRESET` first (the ``--preset`` choices).
PRESET_NAMES: tuple[str, ...] = (DEFAULT_PRESET, *(name for name in PRESETS if name != DEFAULT_PRESET))
