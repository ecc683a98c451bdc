import numpy as np
import pytest

from graphseg.geometry import pose_distance, scene_scale, select_pairs
from graphseg.sim.boxes import look_at


def test_translation_term_counts():
    """Two cameras with identical orientation but 2 m apart are not a pair; 0.1 m apart they are.

    The official code compared a pose with itself, so its translation term was always 0 and
    the far pair would have been kept.
    """
    a = np.eye(4)
    near = np.eye(4)
    near[:3, 3] = [0.1, 0, 0]
    far = np.eye(4)
    far[:3, 3] = [2.0, 0, 0]
    pairs = select_pairs([a, near, far], mode="pose", max_translation=0.5)
    assert pairs == [(0, 1)]
    assert select_pairs([a, near, far], mode="all") == [(0, 1), (0, 2), (1, 2)]


def test_rotation_term_counts():
    a = look_at([0, -1, 0.5], [0, 0, 0])
    b = look_at([1, 0, 0.5], [0, 0, 0])  # 90 degrees around
    c = look_at([0.2, -1, 0.5], [0, 0, 0])
    rot, _ = pose_distance(a, b)
    assert rot > 1.2
    assert select_pairs([a, b, c], mode="pose", max_translation=10.0) == [(0, 2)]


def test_default_translation_is_relative_to_scene_scale():
    a = np.eye(4)
    b = np.eye(4)
    b[:3, 3] = [0.8, 0, 0]
    assert select_pairs([a, b], mode="pose", scale=1.0) == [(0, 1)]
    assert select_pairs([a, b], mode="pose", scale=0.5) == []
    pts = np.zeros((2, 2, 3), np.float32)
    pts[..., 2] = 2.0
    assert scene_scale([pts], [np.eye(4)]) == pytest.approx(2.0)


def test_missing_poses_and_bad_mode():
    assert select_pairs([None, None, None]) == [(0, 1), (0, 2), (1, 2)]
    far = [np.eye(4), np.eye(4)]
    far[1] = far[1].copy()
    far[1][0, 3] = 100.0
    assert select_pairs(far, mode="auto", scale=1.0) == [(0, 1)]  # N <= 8: all pairs
    assert select_pairs(far, mode="auto", scale=1.0, auto_max_views=1) == []
    with pytest.raises(ValueError, match="unknown pair mode"):
        select_pairs([np.eye(4), np.eye(4)], mode="nearest")
    assert select_pairs([np.eye(4)], mode="auto") == []
    assert select_pairs([np.eye(4)]) == []
