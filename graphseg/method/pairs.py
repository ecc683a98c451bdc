"""Pair selection: which views are matched against each other.

Mode ``pose`` keeps pairs whose camera poses are close: the rotation angle
between them is ``<= max_rotation`` (radians; default 1.2) and the distance
between the camera centres is ``<= max_translation`` (default: the scene scale,
i.e. the median camera-to-scene distance, times ``translation_scale``). The
official code compared a pose with itself, so its translation term was always
0; here both terms count. Mode ``all`` keeps every pair (meant for N <= 8);
mode ``auto`` (the default) is ``all`` for N <= ``auto_max_views`` (8) views
and ``pose`` above.

Examples
--------
>>> import numpy as np
>>> a = np.eye(4); b = np.eye(4); b[0, 3] = 0.5
>>> pose_distance(a, b)
(0.0, 0.5)
>>> select_pairs([a, b], max_translation=0.4), select_pairs([a, b], max_translation=0.6)
([], [(0, 1)])
"""

from __future__ import annotations

# defined in graphseg.geometry, so the backends (dust3r's pose mode) can use them without the method
from ..geometry import pose_distance, scene_scale, select_pairs

__all__ = ["pose_distance", "select_pairs", "scene_scale"]
