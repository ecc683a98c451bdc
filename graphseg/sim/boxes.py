"""An exact, dependency-free ray caster for boxes on a table plane.

It renders metric depth, per-pixel instance ids, RGB (flat colours with
Lambertian shading and a checkered table) and exact world points for cameras
in OpenCV axes. It is the fast ground truth behind graphseg's hand-built test
scenes; :mod:`graphseg.sim.pybullet_scenes` renders richer scenes with pybullet.

Examples
--------
>>> import numpy as np
>>> K = intrinsics(64, 48, fov_deg=60)
>>> T = look_at([0.0, -0.6, 0.5], [0, 0, 0])
>>> r = render_boxes([Box((0, 0, 0.05), (0.1, 0.1, 0.1))], T, K, (48, 64))
>>> r.depth.shape, int(r.instances.max())
((48, 64), 1)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["Box", "Rendering", "look_at", "intrinsics", "render_boxes"]


@dataclass(frozen=True)
class Box:
    """A box resting on or above the table: centre (m), size (m), yaw (rad), colour (RGB 0-255)."""

    center: tuple[float, float, float]
    size: tuple[float, float, float]
    yaw: float = 0.0
    color: tuple[int, int, int] = (200, 60, 60)


@dataclass
class Rendering:
    """One rendered view: depth ``[H, W]`` (m, 0 = nothing), instances ``[H, W]`` (0 = table/none), rgb, points."""

    depth: np.ndarray
    instances: np.ndarray
    rgb: np.ndarray
    points: np.ndarray


def look_at(eye: Sequence[float] | np.ndarray, target: Sequence[float] | np.ndarray, up: Sequence[float] = (0, 0, 1)) -> np.ndarray:
    """``cam_to_world`` ``[4, 4]`` of a camera at ``eye`` looking at ``target`` (OpenCV axes).

    Examples
    --------
    >>> T = look_at([1.0, 0, 0], [0, 0, 0])
    >>> np.round(T[:3, 2], 6).tolist()   # the camera's z axis points at the target
    [-1.0, 0.0, 0.0]
    """
    eye = np.asarray(eye, np.float64)
    z = np.asarray(target, np.float64) - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, np.asarray(up, np.float64))
    if np.linalg.norm(x) < 1e-9:
        x = np.cross(z, [0.0, 1.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = x, y, z, eye
    return T


def intrinsics(width: int, height: int, fov_deg: float = 60.0) -> np.ndarray:
    """Pinhole ``K`` with the given horizontal field of view and the principal point at the image centre."""
    f = 0.5 * width / np.tan(np.radians(fov_deg) / 2)
    return np.array([[f, 0, (width - 1) / 2], [0, f, (height - 1) / 2], [0, 0, 1.0]])


def render_boxes(
    boxes: Sequence[Box],
    cam_to_world: np.ndarray,
    K: np.ndarray,
    shape: tuple[int, int],
    *,
    table_half_extent: float = 0.5,
    table_color: tuple[int, int, int] = (150, 140, 120),
) -> Rendering:
    """Ray-cast boxes on the table plane ``z = 0`` (a square of half-size ``table_half_extent``).

    Notes
    -----
    O(H W x number of boxes), vectorized over pixels.
    """
    h, w = shape
    T = np.asarray(cam_to_world, np.float64)
    Kinv = np.linalg.inv(np.asarray(K, np.float64))
    ys, xs = np.mgrid[0:h, 0:w]
    pix = np.stack([xs, ys, np.ones_like(xs)], -1).reshape(-1, 3).astype(np.float64)
    d_cam = pix @ Kinv.T  # z = 1 in camera coordinates, so ray parameter t = z-depth
    d = d_cam @ T[:3, :3].T
    o = T[:3, 3]
    n = d.shape[0]
    best = np.full(n, np.inf)
    inst = np.zeros(n, np.int32)
    normal = np.zeros((n, 3))
    hit_table = np.zeros(n, bool)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_plane = -o[2] / d[:, 2]
    p_plane = o + t_plane[:, None] * d
    on_table = (t_plane > 0) & (np.abs(p_plane[:, 0]) <= table_half_extent) & (np.abs(p_plane[:, 1]) <= table_half_extent)
    best[on_table] = t_plane[on_table]
    hit_table[on_table] = True
    normal[on_table] = [0, 0, 1]
    for k, box in enumerate(boxes, start=1):
        c, s = np.cos(box.yaw), np.sin(box.yaw)
        R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        ol = R.T @ (o - np.asarray(box.center))
        dl = d @ R  # = (R.T @ d.T).T
        half = np.asarray(box.size) / 2
        with np.errstate(divide="ignore", invalid="ignore"):
            t1 = (-half - ol) / dl
            t2 = (half - ol) / dl
        tmin = np.minimum(t1, t2)
        tmax = np.maximum(t1, t2)
        tmin = np.where(np.isnan(tmin), -np.inf, tmin)
        tmax = np.where(np.isnan(tmax), np.inf, tmax)
        t_near = tmin.max(1)
        t_far = tmax.min(1)
        hit = (t_near <= t_far) & (t_near > 1e-6) & (t_near < best)
        axis = tmin.argmax(1)
        best[hit] = t_near[hit]
        inst[hit] = k
        hit_table[hit] = False
        nl = np.zeros((hit.sum(), 3))
        ax = axis[hit]
        nl[np.arange(len(ax)), ax] = -np.sign(dl[hit, ax])
        normal[hit] = nl @ R.T
    valid = np.isfinite(best)
    depth = np.where(valid, best, 0.0).reshape(h, w).astype(np.float32)
    points = (o + best[:, None] * d).reshape(h, w, 3).astype(np.float32)
    points[~valid.reshape(h, w)] = np.nan
    # colours: flat albedo, Lambertian shading from a light above-front, checkered table
    light = np.array([0.3, -0.4, 0.87])
    light /= np.linalg.norm(light)
    shade = 0.45 + 0.55 * np.clip(normal @ light, 0, 1)
    albedo = np.zeros((n, 3))
    albedo[:] = (40, 40, 45)
    tp = p_plane[hit_table]
    checker = ((np.floor(tp[:, 0] / 0.05) + np.floor(tp[:, 1] / 0.05)) % 2)[:, None]
    albedo[hit_table] = np.asarray(table_color) * (0.85 + 0.15 * checker)
    for k, box in enumerate(boxes, start=1):
        albedo[inst == k] = box.color
    rgb = np.clip(albedo * np.where(valid, shade, 1.0)[:, None], 0, 255).astype(np.uint8).reshape(h, w, 3)
    return Rendering(depth, inst.reshape(h, w), rgb, points)
