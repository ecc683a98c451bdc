"""Hand-built scenes with known answers, rendered exactly by :mod:`graphseg.sim.boxes`.

Examples
--------
>>> scene, masks, matches = two_boxes_scene()
>>> scene.num_views, len(masks[0]) >= 4, sorted(matches)
(3, True, [(0, 1), (0, 2), (1, 2)])
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..backends.matchers.reprojection import ReprojectionMatcher
from ..backends.segmenters.oracle_parts import split_mask
from ..scene import Matches, Scene, View
from ..sim.boxes import Box, intrinsics, look_at, render_boxes

__all__ = ["box_scene", "two_boxes_scene", "oracle_part_masks", "gt_cut_masks", "exact_matches", "random_boxes", "demo_box_scene", "rim_scene"]

TWO_BOXES = (
    Box((-0.08, 0.0, 0.05), (0.08, 0.08, 0.10), yaw=0.3, color=(200, 60, 60)),
    Box((0.09, 0.02, 0.04), (0.10, 0.06, 0.08), yaw=-0.2, color=(60, 90, 200)),
)


def box_scene(
    boxes: Sequence[Box],
    *,
    views: int = 3,
    shape: tuple[int, int] = (96, 128),
    radius: float = 0.55,
    height: float = 0.45,
    arc_deg: float = 60.0,
    fov_deg: float = 55.0,
    jitter: float = 0.0,
    rng: Any = None,
    name: str = "boxes",
) -> Scene:
    """Render ``views`` cameras on an arc around the table centre, looking at it."""
    gen = np.random.default_rng(rng)
    h, w = shape
    K = intrinsics(w, h, fov_deg)
    out = []
    az = np.radians(np.linspace(-arc_deg / 2, arc_deg / 2, views)) - np.pi / 2
    for i, a in enumerate(az):
        eye = np.array([radius * np.cos(a), radius * np.sin(a), height]) + gen.normal(0, jitter, 3)
        target = gen.normal(0, jitter, 3) * np.array([1, 1, 0])
        T = look_at(eye, target)
        r = render_boxes(boxes, T, K, shape)
        out.append(View(f"{i:03d}", r.rgb, depth=r.depth, points=r.points, K=K, cam_to_world=T, instances=r.instances))
    return Scene(out, {k: f"box{k}" for k in range(1, len(boxes) + 1)}, name=name)


def oracle_part_masks(scene: Scene, parts: int = 2, *, rng: Any = None, table_mask: bool = True) -> list[list[np.ndarray]]:
    """Per view, each ground-truth object split into ``parts`` masks (plus the table, which the background removes)."""
    gen = np.random.default_rng(rng)
    out = []
    for v in scene.views:
        assert v.instances is not None
        masks: list[np.ndarray] = []
        for k in np.unique(v.instances):
            if k == 0:
                continue
            masks += split_mask(v.instances == k, parts, rng=gen)
        if table_mask:
            masks.append((v.instances == 0) & np.isfinite(np.asarray(v.points, np.float32)).all(-1))
        out.append(masks)
    return out


def gt_cut_masks(masks: Sequence[np.ndarray], scene: Scene) -> list[np.ndarray]:
    """Every mask label image ``[H, W]`` cut along the ground-truth instances: pure masks, ids 1.. per view (0 stays 0).

    Examples
    --------
    >>> from graphseg.scene import View
    >>> view = View("a", np.zeros((1, 4, 3), np.float32), instances=np.array([[0, 1, 1, 2]]))
    >>> gt_cut_masks([np.array([[1, 1, 1, 1]])], Scene([view]))[0].tolist()
    [[1, 2, 2, 3]]
    """
    out = []
    for lab, view in zip(masks, scene.views):
        lab = np.asarray(lab).astype(np.int64)
        gt = np.asarray(view.instances).astype(np.int64)
        key = np.where(lab > 0, lab * (int(gt.max()) + 2) + gt + 1, 0)
        keys, inv = np.unique(key, return_inverse=True)
        ids = inv if keys.size and keys[0] == 0 else inv + 1  # 0 stays 0; with no unlabelled pixel the first piece is 1
        out.append(ids.reshape(lab.shape).astype(np.int32))
    return out


def exact_matches(scene: Scene, pairs: Sequence[tuple[int, int]] | None = None, num_matches: int | None = None, *, rng: Any = None) -> dict[tuple[int, int], Matches]:
    """Exact dense matches by reprojection for the given pairs (all pairs by default)."""
    n = scene.num_views
    pairs = pairs if pairs is not None else [(i, j) for i in range(n) for j in range(i + 1, n)]
    matcher = ReprojectionMatcher(num_matches=num_matches, seed=rng)
    return {(i, j): matcher(scene[i], scene[j]) for i, j in pairs}


def two_boxes_scene(parts: int = 2, views: int = 3, shape: tuple[int, int] = (96, 128), seed: int = 0):
    """Three views of two boxes on a plane; each object's mask split into ``parts``; exact dense matches.

    Returns ``(scene, masks, matches)``: the answer is exactly two objects.
    """
    scene = box_scene(TWO_BOXES, views=views, shape=shape, name="two_boxes")
    masks = oracle_part_masks(scene, parts, rng=seed)
    return scene, masks, exact_matches(scene)


def random_boxes(rng: Any, n: int, *, spread: float = 0.2) -> list[Box]:
    """Up to ``n`` non-overlapping random boxes (4-12 cm) on the table around the origin."""
    gen = np.random.default_rng(rng)
    boxes: list[Box] = []
    for _ in range(500):
        if len(boxes) >= n:
            break
        c = gen.uniform(-spread, spread, 2)
        s = gen.uniform(0.04, 0.12, 3)
        if any(np.linalg.norm(c - np.asarray(b.center[:2])) < 0.5 * (max(s[:2]) + max(b.size[:2])) * 1.42 + 0.02 for b in boxes):
            continue
        color = tuple(int(x) for x in gen.integers(30, 230, 3))
        boxes.append(Box((float(c[0]), float(c[1]), float(s[2] / 2)), (float(s[0]), float(s[1]), float(s[2])), float(gen.uniform(0, np.pi)), color))  # type: ignore[arg-type]
    return boxes


def demo_box_scene(seed: int = 0, views: int = 8, objects: int = 6, shape: tuple[int, int] = (480, 640)) -> Scene:
    """The demo's fallback scene when pybullet is missing: random boxes, cameras all around."""
    gen = np.random.default_rng(seed)
    return box_scene(random_boxes(gen, objects), views=views, shape=shape, arc_deg=360.0 * (views - 1) / views, radius=0.55, height=0.45, jitter=0.01, rng=gen, name=f"boxes-{seed}")


def rim_scene(offset: int, h: int = 20, w: int = 24) -> tuple[np.ndarray, np.ndarray]:
    """One view whose object label misses its colour edge by ``offset`` columns: label ids ``[H, W]`` and RGB ``[H, W, 3]``.

    A bright object fills columns 12 and up of a dark table; it is labelled 3
    from column ``12 + offset`` on (``offset`` > 0: the label stops short of
    the edge; < 0: it runs over the table). The test scene of the rim steps
    (:func:`graphseg.method.grow.grow_rims`, :func:`graphseg.method.trim.trim_rims`).

    Examples
    --------
    >>> lab, rgb = rim_scene(-2)
    >>> lab[0, 9:13].tolist(), rgb[0, 11:13, 0].tolist()
    ([0, 3, 3, 3], [30, 200])
    """
    rgb = np.full((h, w, 3), 30, np.uint8)
    rgb[:, 12:] = (200, 180, 40)
    lab = np.zeros((h, w), np.int32)
    lab[:, 12 + offset :] = 3
    return lab, rgb
