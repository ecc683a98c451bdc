"""Synthetic tabletop scenes rendered with pybullet (extra ``sim``).

Objects that ship inside pybullet (``pybullet_data``) are dropped onto the
table with physics so they rest naturally; an object that does not stay on the
table is dropped again at a free spot (up to four rounds; every requested object
ends on the table for all seeds tried). M cameras circle above the table, looking
at its centre with jitter, and pybullet's CPU TinyRenderer (DIRECT mode, no GPU,
no window) gives RGB, the depth buffer and the segmentation buffer. Views carry
metric z-depth (the OpenGL depth buffer converted with the near/far planes),
per-pixel instance ids, ``K`` and ``cam_to_world`` in OpenCV axes. Deterministic
by seed.

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

__all__ = ["synthesize", "render_view", "fell_off_warning", "ASSETS", "Asset", "TABLE_TOP", "projection_K", "linearize_depth"]

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


#: Drop points lie in ``[-_HALF, _HALF]`` around the table's centre (well inside its
#: 1.5 m x 1.0 m top, and inside every camera's view).
_HALF = np.array([0.22, 0.16])
#: Rounds of dropping again the objects that did not stay on the table.
_REDROPS = 4
#: Gap between a dropped object's bounding box and what it is dropped onto (m).
_CLEARANCE = 0.01
#: Least rolling and spinning friction of a dropped object: without it the small sphere
#: (0.001 in its URDF) rolls off the table in most scenes with 16 objects.
_ROLLING = 0.01


def _xy(p: Any, cid: int, body: int) -> np.ndarray:
    return np.array(p.getBasePositionAndOrientation(body, physicsClientId=cid)[0][:2])


def _lowest(p: Any, cid: int, body: int, plane: int) -> float:
    """Height of the body's lowest collision point: its distance to the floor plane at z = 0.

    pybullet's closest-point query is only approximate for a body far above the floor, but
    for one resting on the table it gives the top (0.625 m) to the millimetre, where
    ``getAABB`` (loose for compound V-HACD shapes) reaches up to 4 cm lower.
    """
    return min(c[5][2] for c in p.getClosestPoints(body, plane, 10.0, physicsClientId=cid))


def _free_spot(rng: np.random.Generator, placed: list[np.ndarray], gap: float) -> np.ndarray:
    """A drop point at least ``gap`` from every point in ``placed`` (the last of 30 tries otherwise)."""
    for _ in range(30):
        xy = rng.uniform(-_HALF, _HALF)
        if all(np.linalg.norm(xy - q) > gap for q in placed):
            break
    return xy


def _drop(p: Any, cid: int, others: list[int], asset: Asset, xy: np.ndarray, top: float, rng: np.random.Generator) -> int:
    """Load ``asset`` at ``xy`` with a random orientation, just above the table or the objects under it.

    The body's bounding box (which contains it) starts ``_CLEARANCE`` above the highest
    bounding box it overlaps in x, y (the table's top included), so no body starts
    inside another and none falls from high enough to bounce far.
    """
    orn = p.getQuaternionFromEuler(list(rng.uniform(0, 2 * np.pi, 3)))
    z0 = top + 0.5
    b = p.loadURDF(asset.urdf, [float(xy[0]), float(xy[1]), z0], orn, globalScaling=asset.scale, physicsClientId=cid)
    lo, hi = p.getAABB(b, physicsClientId=cid)
    floor = top
    for o in others:
        olo, ohi = p.getAABB(o, physicsClientId=cid)
        if olo[0] < hi[0] and lo[0] < ohi[0] and olo[1] < hi[1] and lo[1] < ohi[1]:
            floor = max(floor, ohi[2])
    dyn = p.getDynamicsInfo(b, -1, physicsClientId=cid)
    p.changeDynamics(b, -1, rollingFriction=max(dyn[6], _ROLLING), spinningFriction=max(dyn[7], _ROLLING), physicsClientId=cid)
    pos, q = p.getBasePositionAndOrientation(b, physicsClientId=cid)  # the inertial frame, not the URDF's link frame
    p.resetBasePositionAndOrientation(b, [pos[0], pos[1], pos[2] + floor + _CLEARANCE - lo[2]], q, physicsClientId=cid)
    if asset.recolor:
        col = np.r_[rng.uniform(0.15, 0.95, 3), 1.0]
        for link in range(-1, p.getNumJoints(b, physicsClientId=cid)):
            p.changeVisualShape(b, link, rgbaColor=col.tolist(), physicsClientId=cid)
    return b


def _on_table(p: Any, cid: int, body: int, plane: int, table_lo: Any, table_hi: Any) -> bool:
    """Over the table top (its ``getAABB``: x +-0.751 m, y +-0.501 m) and resting on it, not on the floor.

    A body that fell lies on the floor, more than half a metre below the top; 5 cm of
    tolerance covers contact margins and the closest-point query's error.
    """
    x, y = _xy(p, cid, body)
    inside = table_lo[0] < x < table_hi[0] and table_lo[1] < y < table_hi[1]
    return bool(inside and _lowest(p, cid, body, plane) > table_hi[2] - 0.05)


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
    layout: str = "spread",
) -> Scene:
    """Render a scene with ``objects`` objects and ``views`` cameras (``size`` = (width, height)).

    ``layout`` (stress set): ``"spread"`` drops objects at least 9 cm apart;
    ``"touching"`` drops them 4-7 cm apart around the centre, so they settle
    against each other; ``"stacked"`` drops them in piles of two or three on
    the same spot, so they land on top of each other.

    Returns
    -------
    Scene
        Views named ``000``..; ``meta`` records the seed, the assets used,
        ``redropped``: the names of objects that had to be dropped again (once per
        drop), and ``fell_off``: the names of objects finally not on the table, left
        out of the scene (normally empty; :func:`fell_off_warning` words it).

    Raises
    ------
    ValueError
        For ``seed < 0``, ``objects`` outside ``[1, MAX_OBJECTS]``, ``views``
        outside ``[1, 360]`` or a size below 16 pixels.
    """
    _check_args(seed, objects, views, size)
    if layout not in ("spread", "touching", "stacked"):
        raise ValueError(f"unknown layout {layout!r}; choose 'spread', 'touching' or 'stacked'")
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
        table_lo, table_hi = p.getAABB(table, physicsClientId=cid)  # the top: x +-0.751, y +-0.501, z 0.574..0.626
        top = float(table_hi[2])
        picks = rng.choice(len(ASSETS), size=objects, replace=objects > len(ASSETS))
        slots: list[tuple[int, Asset]] = []  # (body, asset) in drop order: the instance ids
        placed: list[np.ndarray] = []
        for k, a in enumerate(picks):
            asset = ASSETS[int(a)]
            if layout == "stacked" and k % 3 and placed:  # on top of the pile's first object
                xy = placed[-1] + rng.normal(0, 0.01, 2)
            elif layout == "touching" and placed:
                ang = rng.uniform(0, 2 * np.pi)
                xy = placed[int(rng.integers(len(placed)))] + rng.uniform(0.04, 0.07) * np.array([np.cos(ang), np.sin(ang)])
                xy = np.clip(xy, -_HALF, _HALF)
            else:
                xy = _free_spot(rng, placed, 0.09)
            placed.append(xy)
            slots.append((_drop(p, cid, [b for b, _ in slots], asset, xy, top, rng), asset))
        redropped: list[str] = []
        for attempt in range(_REDROPS + 1):
            for _ in range(settle_steps):
                p.stepSimulation(physicsClientId=cid)
            off = [i for i, (b, _) in enumerate(slots) if not _on_table(p, cid, b, plane, table_lo, table_hi)]
            if not off or attempt == _REDROPS:
                break
            for i in off:  # drop them again, each at a free spot: same asset, same instance id
                p.removeBody(slots[i][0], physicsClientId=cid)
            for i in off:
                others = [b for j, (b, _) in enumerate(slots) if j not in off or j < i]
                spot = _free_spot(rng, [_xy(p, cid, b) for b in others], 0.09)
                slots[i] = (_drop(p, cid, others, slots[i][1], spot, top, rng), slots[i][1])
                redropped.append(slots[i][1].name or slots[i][1].urdf)
        kept = [(b, asset) for i, (b, asset) in enumerate(slots) if i not in off]
        for i in off:  # still not on the table after every round (none for the seeds tested)
            p.removeBody(slots[i][0], physicsClientId=cid)
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
        fell_off = [slots[i][1].name or slots[i][1].urdf for i in off]
    finally:
        p.disconnect(physicsClientId=cid)
    meta: dict[str, Any] = {"seed": seed, "generator": "graphseg.sim.pybullet_scenes", "fov_deg": fov_deg, "layout": layout, "objects_requested": objects, "fell_off": fell_off, "redropped": redropped}
    return Scene(out, objects_named, name=f"synth-{seed}", meta=meta)


def fell_off_warning(scene: Scene) -> str | None:
    """The one-line warning for a synthetic scene that lacks objects that fell off the table, or None.

    >>> fell_off_warning(synthesize(seed=0, objects=2, views=1, size=(32, 24))) is None
    True
    """
    fell = list(scene.meta.get("fell_off") or [])
    if not fell:
        return None
    total = int(scene.meta.get("objects_requested") or len(fell) + len(scene.objects))
    return f"{len(fell)} of {total} objects did not stay on the table and are not in the scene: {', '.join(map(str, fell))}"
