"""Synthetic tabletop scenes rendered with pybullet (extra ``sim``).

Objects that ship inside pybullet (``pybullet_data``) are dropped onto the
table with physics so they rest naturally; any that fall off are removed. M
cameras circle above the table, looking at its centre with jitter, and
pybullet's CPU TinyRenderer (DIRECT mode, no GPU, no window) gives RGB, the
depth buffer and the segmentation buffer. Views carry metric z-depth (the
OpenGL depth buffer converted with the near/far planes), per-pixel instance
ids, ``K`` and ``cam_to_world`` in OpenCV axes. Deterministic by seed.

Examples
--------
>>> scene = synthesize(seed=0, objects=3, views=2, size=(160, 120))
>>> len(scene), scene.views[0].depth.shape, float(scene.views[0].K[0, 2])
(2, (120, 160), 80.0)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..registry import require
from ..scene import Scene, View
from .boxes import look_at

__all__ = ["synthesize", "render_view", "ASSETS", "Asset", "TABLE_TOP", "projection_K", "linearize_depth"]

TABLE_TOP = 0.626  # height of pybullet_data's table.urdf top surface (m)


@dataclass(frozen=True)
class Asset:
    """An object from ``pybullet_data``: file, uniform scale, whether to recolour it."""

    urdf: str
    scale: float = 1.0
    recolor: bool = True
    name: str = ""


ASSETS: tuple[Asset, ...] = (
    Asset("cube_small.urdf", 1.4, True, "cube"),
    Asset("sphere_small.urdf", 1.2, True, "sphere"),
    Asset("duck_vhacd.urdf", 1.0, False, "duck"),
    Asset("teddy_vhacd.urdf", 1.1, False, "teddy"),
    Asset("lego/lego.urdf", 2.5, True, "lego"),
    Asset("jenga/jenga.urdf", 0.8, True, "jenga"),
    Asset("soccerball.urdf", 0.09, False, "ball"),
    Asset("objects/mug.urdf", 1.0, True, "mug"),
) + tuple(Asset(f"random_urdfs/{k:03d}/{k:03d}.urdf", 0.9, True, f"random{k:03d}") for k in range(0, 60, 3))


def projection_K(width: int, height: int, fov_deg: float) -> np.ndarray:
    """Intrinsics of an image rendered by TinyRenderer with ``computeProjectionMatrixFOV``.

    Vertical field of view, square pixels. The principal point is
    ``(W / 2, H / 2 - 1)`` in graphseg's pixel coordinates (pixel centres at
    integers). This was measured, not assumed: ray casting through pixel
    centres (``rayTestBatch``) agrees with the rendered depth to about 1e-6 m
    only with this principal point; the textbook ``((W - 1) / 2, (H - 1) / 2)``
    leaves millimetre-to-centimetre depth errors on slanted surfaces (see
    ``tests/test_sim.py``).
    """
    f = 0.5 * height / np.tan(np.radians(fov_deg) / 2)
    return np.array([[f, 0, width / 2], [0, f, height / 2 - 1], [0, 0, 1.0]])


def linearize_depth(buffer: np.ndarray, near: float, far: float) -> np.ndarray:
    """OpenGL depth buffer in ``[0, 1]`` -> metric z-depth (0 where the buffer is 1, i.e. nothing)."""
    d = np.asarray(buffer, np.float64)
    z = far * near / (far - (far - near) * d)
    return np.where(d < 1.0 - 1e-7, z, 0.0).astype(np.float32)


def render_view(
    p: Any, cid: int, eye: np.ndarray, target: np.ndarray, size: tuple[int, int], fov_deg: float, near: float = 0.05, far: float = 6.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Render one camera with TinyRenderer: ``rgb [H, W, 3]``, metric ``depth [H, W]``, body ids ``[H, W]`` (-1 = none), ``K``, ``cam_to_world``."""
    w, h = size
    T = look_at(eye, target)
    view = p.computeViewMatrix(list(map(float, eye)), list(map(float, target)), [0, 0, 1], physicsClientId=cid)
    proj = p.computeProjectionMatrixFOV(fov_deg, w / h, near, far, physicsClientId=cid)
    _, _, rgba, dbuf, seg = p.getCameraImage(w, h, view, proj, renderer=p.ER_TINY_RENDERER, physicsClientId=cid)
    rgb = np.asarray(rgba, np.uint8).reshape(h, w, 4)[..., :3].copy()
    depth = linearize_depth(np.asarray(dbuf).reshape(h, w), near, far)
    seg = np.asarray(seg).reshape(h, w)
    body = np.where(seg >= 0, seg & ((1 << 24) - 1), -1)
    return rgb, depth, body, projection_K(w, h, fov_deg), T


#: The most objects :func:`synthesize` drops onto the table.
MAX_OBJECTS = 16


def _check_args(seed: int, objects: int, views: int, size: tuple[int, int]) -> None:
    if not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed: expected an integer >= 0 (got {seed!r})")
    if not 1 <= objects <= MAX_OBJECTS:
        raise ValueError(f"objects: expected 1..{MAX_OBJECTS} (got {objects})")
    if not 1 <= views <= 360:
        raise ValueError(f"views: expected 1..360 (got {views})")
    if len(size) != 2 or min(size) < 16 or max(size) > 8192:
        raise ValueError(f"size: expected WIDTHxHEIGHT with sides 16..8192 (got {size})")


def synthesize(
    seed: int = 0,
    objects: int = 6,
    views: int = 8,
    size: tuple[int, int] = (640, 480),
    *,
    radius: float = 0.5,
    height: float = 0.42,
    fov_deg: float = 50.0,
    jitter: float = 0.03,
    arc_deg: float = 360.0,
    settle_steps: int = 480,
) -> Scene:
    """Render a scene with ``objects`` objects and ``views`` cameras (``size`` = (width, height)).

    Returns
    -------
    Scene
        Views named ``000``..; ``meta`` records the seed, the assets used, and
        ``fell_off``: the names of dropped objects that did not stay on the table.

    Raises
    ------
    ValueError
        For ``seed < 0``, ``objects`` outside ``[1, MAX_OBJECTS]``, ``views``
        outside ``[1, 360]`` or a size below 16 pixels.
    """
    _check_args(seed, objects, views, size)
    from ..quiet import native_silence

    with native_silence():  # pybullet prints its build banner on fd 1
        p = require("pybullet", "sim")
        pybullet_data = require("pybullet_data", "sim")
    rng = np.random.default_rng(seed)
    w, h = size
    near, far = 0.05, 6.0
    with native_silence():
        cid = p.connect(p.DIRECT)
    try:
        p.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=cid)
        p.setGravity(0, 0, -9.81, physicsClientId=cid)
        plane = p.loadURDF("plane.urdf", [0, 0, 0], physicsClientId=cid)
        table = p.loadURDF("table/table.urdf", [0, 0, 0], useFixedBase=True, physicsClientId=cid)
        p.changeVisualShape(plane, -1, rgbaColor=[0.35, 0.33, 0.3, 1], physicsClientId=cid)
        bodies: list[tuple[int, Asset]] = []
        picks = rng.choice(len(ASSETS), size=objects, replace=objects > len(ASSETS))
        placed: list[np.ndarray] = []
        for k, a in enumerate(picks):
            asset = ASSETS[int(a)]
            for _ in range(30):  # spread the drop points
                xy = rng.uniform([-0.22, -0.16], [0.22, 0.16])
                if all(np.linalg.norm(xy - q) > 0.09 for q in placed):
                    break
            placed.append(xy)
            pos = [float(xy[0]), float(xy[1]), TABLE_TOP + 0.06 + 0.05 * k]
            orn = p.getQuaternionFromEuler(list(rng.uniform(0, 2 * np.pi, 3)))
            b = p.loadURDF(asset.urdf, pos, orn, globalScaling=asset.scale, physicsClientId=cid)
            if asset.recolor:
                col = np.r_[rng.uniform(0.15, 0.95, 3), 1.0]
                for link in range(-1, p.getNumJoints(b, physicsClientId=cid)):
                    p.changeVisualShape(b, link, rgbaColor=col.tolist(), physicsClientId=cid)
            bodies.append((b, asset))
        for _ in range(settle_steps):
            p.stepSimulation(physicsClientId=cid)
        kept: list[tuple[int, Asset]] = []
        for b, asset in bodies:
            pos, _ = p.getBasePositionAndOrientation(b, physicsClientId=cid)
            lo, _hi = p.getAABB(b, physicsClientId=cid)
            on = abs(pos[0]) < 0.7 and abs(pos[1]) < 0.45 and lo[2] > TABLE_TOP - 0.02
            if on:
                kept.append((b, asset))
            else:
                p.removeBody(b, physicsClientId=cid)
        ids = {b: i + 1 for i, (b, _) in enumerate(kept)}
        centre = np.array([0.0, 0.0, TABLE_TOP])
        start = rng.uniform(0, 2 * np.pi)
        span = np.radians(arc_deg)
        out = []
        for i in range(views):
            az = start + (span * i / views if arc_deg >= 360 else span * (i / max(views - 1, 1) - 0.5))
            r = radius * (1 + rng.uniform(-0.08, 0.08))
            eye = centre + np.array([r * np.cos(az), r * np.sin(az), height * (1 + rng.uniform(-0.1, 0.1))])
            target = centre + np.r_[rng.normal(0, jitter, 2), 0.0]
            rgb, depth, body, K, T = render_view(p, cid, eye, target, (w, h), fov_deg, near, far)
            inst = np.zeros((h, w), np.int32)
            for b, k in ids.items():
                inst[body == b] = k
            out.append(View(f"{i:03d}", rgb, depth=depth, K=K, cam_to_world=T, instances=inst))
        objects_named = {ids[b]: a.name or a.urdf for b, a in kept}
        fell_off = [a.name or a.urdf for b, a in bodies if b not in ids]
        _ = table
    finally:
        p.disconnect(physicsClientId=cid)
    meta: dict[str, Any] = {"seed": seed, "generator": "graphseg.sim.pybullet_scenes", "fov_deg": fov_deg, "objects_requested": objects, "fell_off": fell_off}
    return Scene(out, objects_named, name=f"synth-{seed}", meta=meta)
