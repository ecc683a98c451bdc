"""The named configurations of :meth:`graphseg.Config.preset`, as plain data.

Written like a config file and kept apart from :mod:`graphseg.config` (which
validates them) so that the command line can list the preset names and its
default without importing pydantic. ``Config()`` is the ``rgbd`` method
(:data:`BASE_STAGES` and the sections' defaults); every other preset is the
keys it changes over it. :mod:`graphseg.config` re-exports the names.

Examples
--------
>>> PRESET_NAMES[0] == DEFAULT_PRESET, sorted(PRESETS) == sorted(PRESET_NAMES)
(True, True)
"""

from __future__ import annotations

from typing import Any

from .published import TAU_3D_OFFICIAL

__all__ = ["PRESETS", "DEFAULT_PRESET", "PRESET_NAMES", "BASE_STAGES", "SPLIT_FAMILY", "CANONICAL_ORDER", "MINIMUM_SUPPORT"]

#: The graph operations an old section's ``enabled: true`` turned on (config files written before the step list).
SPLIT_FAMILY: tuple[str, ...] = ("split", "merge", "join_shared", "mask_join", "snap")
#: The built-in graph operations in the order a migration or a lifter inserts them.
CANONICAL_ORDER: tuple[str, ...] = ("support", *SPLIT_FAMILY, "support_final", "refine", "grow", "trim")
#: What a ``stages`` list without any graph operation gets after its edge stages: the minimum support.
MINIMUM_SUPPORT: tuple[str, ...] = ("support", "support_final")

_PIXEL_MATCH = {"pixel_match": {"normalization": "pair_hits", "tau": 0.3, "min_matches": 5}}
_REPULSION = {"depth_repulsion": {"jump": 0.1, "concave": 0.2, "fraction": 0.5, "reach": 4}}
_OBJECT_OPERATIONS = ["support", *SPLIT_FAMILY, "support_final"]

#: The default method, ``Config()``: measured for metric RGB-D input (``docs/results.md``). 2D edges
#: where the per-pair overlap fraction (``pair_hits``) is >= 0.3, the official code's tau_3D
#: = 5e-5 m^2, then the minimum support, the 3D split and its joins. The other presets are
#: differences over it. The sections' own defaults (``background.max_overlap`` 0.5,
#: ``split.mask_join`` 0.5, ``split.snap_share`` 0.85) belong to this method too.
BASE_STAGES: list[Any] = [[_PIXEL_MATCH], [{"chamfer_3d": {"tau": TAU_3D_OFFICIAL}}], *_OBJECT_OPERATIONS]

#: Named configurations for :meth:`Config.preset`: each the keys it changes over ``Config()``.
PRESETS: dict[str, dict[str, Any]] = {
    "rgbd": {},
    # the paper's thresholds: its criteria's defaults, the paper code's 9% background share, no split
    "paper": {
        "stages": [["pixel_match"], ["chamfer_3d"], *MINIMUM_SUPPORT],
        "background": {"max_overlap": 0.09},
        "split": {"mask_join": None, "snap_share": None},
    },
    # rgbd plus the robust contraction of issue 12 (measured in docs/results.md, "Robust contraction")
    "robust": {
        "stages": [
            [_PIXEL_MATCH, _REPULSION],
            [{"chamfer_3d": {"tau": TAU_3D_OFFICIAL, "outliers": "dbscan", "dbscan_min_samples": 15}}, _REPULSION, {"smooth_adjacency": {"color": 20.0}}],
            *_OBJECT_OPERATIONS,
        ],
        "contractor": "constrained",
        "split": {"mask_join": None, "snap_share": None},
    },
    # robust with greedy additive edge contraction and smooth_adjacency without its colour test
    # (issue 21; chosen on the tune half of bench_ycb_views.py, measured in docs/results.md)
    "multicut": {
        "stages": [
            [_PIXEL_MATCH, _REPULSION],
            [{"chamfer_3d": {"tau": TAU_3D_OFFICIAL, "outliers": "dbscan", "dbscan_min_samples": 15}}, _REPULSION, {"smooth_adjacency": {"color": None}}],
            *_OBJECT_OPERATIONS,
        ],
        "contractor": "gaec",
        "split": {"mask_join": None, "snap_share": None},
    },
}

#: The preset the command line's ``--preset`` names by default: ``Config()`` itself.
DEFAULT_PRESET: str = "rgbd"

#: The names of :data:`PRESETS`, :data:`DEFAULT_PRESET` first (the ``--preset`` choices).
PRESET_NAMES: tuple[str, ...] = (DEFAULT_PRESET, *(name for name in PRESETS if name != DEFAULT_PRESET))
