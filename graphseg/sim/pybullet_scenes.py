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

Options (keyword-only, each off by default, so that the same seed and arguments
render exactly what they rendered before the options existed):

* ``object_set``: ``"bundled"`` (the ``pybullet_data`` objects of :data:`ASSETS`),
  ``"procedural"`` (boxes, cylinders and spheres of 3-12 cm built with
  ``createCollisionShape`` / ``createVisualShape``, each with a procedural texture:
  plain colour, stripes, noise or "photo-like" (smooth colour blobs, hard-edged
  shapes and text-like marks); :data:`OBJECT_TEXTURES`) or ``"mixed"`` (each object
  either, with equal chance).
* ``table_texture``: ``None`` (the table's own wood image) or one of
  :data:`TABLE_TEXTURES` (procedural images mapped on the table).
* ``lighting``: ``None`` (TinyRenderer's default light), ``"vary"`` (a light
  direction, colour, ambient / diffuse / specular coefficients and shadows drawn
  from the seed) or a dict of ``getCameraImage`` light arguments.

Table texture and lighting are drawn from their own random stream, so they never move
the objects: the same seed with another table or light gives the same layout.
Procedural textures are band-limited (a Gaussian blur of 1-1.5 texels, no one-texel
speckles or grain): TinyRenderer samples textures nearest-neighbour without mipmaps,
so detail at the scale of a texel would alias, showing in one view and not the next,
which a camera never does. TinyRenderer maps textures on ``createVisualShape`` boxes,
cylinders and spheres (a cylinder's mapping wraps the image like a sphere's).

Examples
--------
>>> scene = synthesize(seed=0, objects=3, views=2, size=(160, 120))
>>> len(scene), scene.views[0].depth.shape, float(scene.views[0].K[0, 2])
(2, (120, 160), 80.0)
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..registry import require
from ..scene import Scene, View
from .boxes import look_at

__all__ = [
    "synthesize",
    "CameraRig",
    "render_view",
    "ASSETS",
    "Asset",
    "Shape",
    "TABLE_TOP",
    "projection_K",
    "linearize_depth",
    "OBJECT_SETS",
    "OBJECT_TEXTURES",
    "TABLE_TEXTURES",
    "LIGHT_KEYS",
    "object_texture",
    "table_texture_image",
    "draw_shape",
    "draw_lighting",
]

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


#: What :func:`synthesize` drops: ``pybullet_data`` objects, procedural shapes, or both.
OBJECT_SETS = ("bundled", "procedural", "mixed")
#: Textures of procedural shapes (:func:`object_texture`).
OBJECT_TEXTURES = ("plain", "stripes", "noise", "photo")
#: Procedural table-top textures (:func:`table_texture_image`); ``None`` keeps the table's own image.
TABLE_TEXTURES = ("wood", "plain", "checker", "noise", "cloth", "photo")
#: ``getCameraImage`` light arguments a ``lighting`` dict may hold.
LIGHT_KEYS = ("lightDirection", "lightColor", "lightDistance", "shadow", "lightAmbientCoeff", "lightDiffuseCoeff", "lightSpecularCoeff")
#: Side of an object texture image (pixels).
_TEX = 256
#: Size of a table texture image (pixels, width x height: the top's 1.5 m x 1.0 m, about 0.7 px per mm).
_TABLE_TEX = (1024, 683)
#: Gaussian blur (texels) that band-limits every procedural texture, objects' and table's.
#: TinyRenderer samples textures nearest-neighbour, without mipmaps; detail at the scale
#: of one texel would alias: appear in one view and vanish in the next, which a camera
#: (integrating light over each pixel) never shows.
_BAND_LIMIT = {"object": 1.5, "table": 1.0}


def _band_limit(img: np.ndarray, sigma: float) -> np.ndarray:
    import cv2

    return np.ascontiguousarray(cv2.GaussianBlur(img, (0, 0), sigma))


@dataclass
class Shape:
    """A procedural object: a box, cylinder or sphere with its texture.

    ``size`` is in metres: a box's full extents ``(x, y, z)``, a cylinder's
    ``(radius, height)``, a sphere's ``(radius,)``. ``image`` is the texture
    (``uint8 [H, W, 3]``; None for ``"plain"``, which uses ``rgba`` alone).
    """

    kind: str
    size: tuple[float, ...]
    texture: str
    rgba: tuple[float, float, float, float]
    image: np.ndarray | None = field(default=None, repr=False, compare=False)
    name: str = ""


def _noise(rng: np.random.Generator, shape: tuple[int, int], cells: tuple[int, ...] = (3, 6, 12, 24, 48)) -> np.ndarray:
    """Smooth multi-octave value noise in ``[0, 1]`` (``float32 [H, W]``)."""
    import cv2

    h, w = shape
    out = np.zeros((h, w), np.float32)
    for k, c in enumerate(cells):
        low = rng.random((c, max(int(round(c * w / h)), 1))).astype(np.float32)
        out += cv2.resize(low, (w, h), interpolation=cv2.INTER_CUBIC) * 0.55**k
    out -= out.min()
    return out / max(float(out.max()), 1e-6)


def _colour(rng: np.random.Generator, lo: float = 0.1, hi: float = 0.95) -> np.ndarray:
    return rng.uniform(lo, hi, 3)


def _ramp(t: np.ndarray, colours: list[np.ndarray]) -> np.ndarray:
    """Colours (floats in ``[0, 1]``) interpolated along ``t`` in ``[0, 1]`` -> ``uint8 [H, W, 3]``."""
    c = np.asarray(colours, np.float32)
    x = np.clip(t, 0, 1) * (len(c) - 1)
    i = np.minimum(x.astype(np.int64), len(c) - 2)
    f = (x - i)[..., None]
    return np.clip((c[i] * (1 - f) + c[i + 1] * f) * 255 + 0.5, 0, 255).astype(np.uint8)


def _stripes(rng: np.random.Generator, shape: tuple[int, int], period: float) -> np.ndarray:
    h, w = shape
    ang = rng.choice([0.0, 0.5 * np.pi, 0.25 * np.pi, rng.uniform(0, np.pi)])
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    t = ((xx * np.cos(ang) + yy * np.sin(ang)) / period) % 1.0
    band = t < rng.uniform(0.35, 0.65)
    a, b = _colour(rng), _colour(rng)
    while np.abs(a - b).sum() < 0.6:  # two clearly different colours
        b = _colour(rng)
    return np.where(band[..., None], (a * 255).astype(np.uint8), (b * 255).astype(np.uint8)).astype(np.uint8)


def _photo(rng: np.random.Generator, shape: tuple[int, int]) -> np.ndarray:
    """A photo-like image: smooth colour blobs, hard-edged shapes, lines and text-like marks."""
    import cv2

    h, w = shape
    low = rng.uniform(0.1, 0.95, (4, 4, 3)).astype(np.float32)
    img = cv2.resize(low, (w, h), interpolation=cv2.INTER_CUBIC)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    for _ in range(int(rng.integers(3, 8))):  # soft blobs
        cy, cx, sig = rng.uniform(0, h), rng.uniform(0, w), rng.uniform(0.05, 0.25) * min(h, w)
        a = np.exp(-((yy - cy) ** 2 + (xx - cx) ** 2) / (2 * sig**2))[..., None]
        img = img * (1 - a) + _colour(rng).astype(np.float32) * a
    img = np.clip(img * 255, 0, 255).astype(np.uint8)
    s = min(h, w)
    for _ in range(int(rng.integers(3, 9))):  # hard edges
        col = tuple(int(c) for c in rng.integers(0, 256, 3))
        kind = int(rng.integers(3))
        if kind == 0:
            p0 = rng.integers(0, [w, h])
            p1 = p0 + rng.integers(s // 12, s // 3, 2)
            cv2.rectangle(img, (int(p0[0]), int(p0[1])), (int(p1[0]), int(p1[1])), col, -1)
        elif kind == 1:
            cv2.circle(img, (int(rng.integers(w)), int(rng.integers(h))), int(rng.integers(s // 20, s // 6)), col, -1, cv2.LINE_AA)
        else:
            pts = (rng.uniform(0, 1, (int(rng.integers(3, 6)), 2)) * [w, h]).astype(np.int32)
            cv2.fillPoly(img, [pts], col, cv2.LINE_AA)
    for _ in range(int(rng.integers(2, 6))):  # lines
        col = tuple(int(c) for c in rng.integers(0, 256, 3))
        a, b = rng.integers(0, [w, h]), rng.integers(0, [w, h])
        cv2.line(img, (int(a[0]), int(a[1])), (int(b[0]), int(b[1])), col, int(rng.integers(1, 4)), cv2.LINE_AA)
    fonts = (cv2.FONT_HERSHEY_SIMPLEX, cv2.FONT_HERSHEY_DUPLEX, cv2.FONT_HERSHEY_COMPLEX, cv2.FONT_HERSHEY_TRIPLEX)
    letters = np.array(list("ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789abcdefghkmnrstuwxyz"))
    for _ in range(int(rng.integers(3, 8))):  # text-like marks
        text = "".join(rng.choice(letters, int(rng.integers(2, 8))))
        dark = rng.random() < 0.6
        col = tuple(int(c) for c in (rng.integers(0, 70, 3) if dark else rng.integers(190, 256, 3)))
        scale = float(rng.uniform(0.3, 1.2)) * s / 256
        org = (int(rng.integers(0, w - s // 8)), int(rng.integers(s // 10, h)))
        cv2.putText(img, text, org, fonts[int(rng.integers(len(fonts)))], scale, col, int(rng.integers(1, 3)), cv2.LINE_AA)
    return img


def object_texture(kind: str, rng: np.random.Generator, size: int = _TEX) -> np.ndarray | None:
    """The texture image of a procedural shape (``uint8 [size, size, 3]``; None for ``"plain"``).

    >>> object_texture("stripes", np.random.default_rng(0), 32).shape
    (32, 32, 3)
    """
    shape = (size, size)
    sigma = _BAND_LIMIT["object"] * size / _TEX
    if kind == "plain":
        return None
    if kind == "stripes":
        return _band_limit(_stripes(rng, shape, rng.uniform(0.06, 0.16) * size), sigma)
    if kind == "noise":
        t = _noise(rng, shape, (4, 8, 16, 32, 64))
        return _band_limit(_ramp(t, [_colour(rng), _colour(rng), _colour(rng)]), sigma)
    if kind == "photo":
        return _band_limit(_photo(rng, shape), sigma)
    raise ValueError(f"unknown object texture {kind!r}; choose one of {', '.join(OBJECT_TEXTURES)}")


def table_texture_image(kind: str, rng: np.random.Generator, size: tuple[int, int] = _TABLE_TEX) -> np.ndarray:
    """A procedural table-top image (``uint8 [H, W, 3]``, ``size`` = (W, H); the top spans it once).

    ``"wood"``: warped grain in a random brown; ``"plain"``: one uniform colour;
    ``"checker"``: 3-8 cm squares of two colours; ``"noise"``: granite-like noise with
    speckles; ``"cloth"``: a coarse woven pattern (1-2 cm); ``"photo"``: a photo-like
    print. Band-limited (:data:`_BAND_LIMIT`): nothing finer than a few texels.

    >>> table_texture_image("checker", np.random.default_rng(0), (60, 40)).shape
    (40, 60, 3)
    """
    img = _table_texture_raw(kind, rng, size)
    return img if kind == "plain" else _band_limit(img, _BAND_LIMIT["table"] * size[0] / _TABLE_TEX[0])


def _table_texture_raw(kind: str, rng: np.random.Generator, size: tuple[int, int]) -> np.ndarray:
    w, h = size
    px_per_m = w / 1.5
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    if kind == "wood":
        import cv2

        warp = _noise(rng, (h, w), (2, 3, 6))
        freq = rng.uniform(6, 14) / h  # growth rings across the boards
        rings = 0.5 + 0.5 * np.sin(2 * np.pi * (yy * freq + 3.0 * warp))
        streaks = cv2.resize(rng.random((max(h // 6, 2), 12)).astype(np.float32), (w, h), interpolation=cv2.INTER_CUBIC)  # fibres along x
        t = 0.6 * rings**2 + 0.3 * streaks + 0.1 * _noise(rng, (h, w), (32, 128))
        base = np.array([rng.uniform(0.6, 0.9), rng.uniform(0.4, 0.65), rng.uniform(0.2, 0.4)])
        return _ramp(t, [base, base * 0.7])
    if kind == "plain":
        col = np.clip(_colour(rng, 0.3, 0.9) * 255 + 0.5, 0, 255).astype(np.uint8)
        return np.broadcast_to(col, (h, w, 3)).copy()
    if kind == "checker":
        side = rng.uniform(0.03, 0.08) * px_per_m
        even = ((xx // side + yy // side) % 2 == 0)[..., None]
        a, b = _colour(rng), _colour(rng)
        while np.abs(a - b).sum() < 0.8:
            b = _colour(rng)
        return np.where(even, (a * 255).astype(np.uint8), (b * 255).astype(np.uint8)).astype(np.uint8)
    if kind == "noise":
        import cv2

        t = _noise(rng, (h, w), (4, 16, 64, 256))
        img = _ramp(t, [_colour(rng, 0.2, 0.9), _colour(rng, 0.2, 0.9)])
        for _ in range(int(w * h * 0.002)):  # speckles of 1.5-3 texels radius
            grey = int(rng.integers(0, 256))
            cv2.circle(img, (int(rng.integers(w)), int(rng.integers(h))), int(rng.integers(2, 4)), (grey, grey, grey), -1, cv2.LINE_AA)
        return img
    if kind == "cloth":
        period = rng.uniform(8.0, 14.0)
        t = 0.5 + 0.25 * np.sin(2 * np.pi * xx / period) * np.sign(np.sin(np.pi * yy / period)) + 0.25 * _noise(rng, (h, w), (16, 128))
        base = _colour(rng, 0.2, 0.9)
        return _ramp(t, [base * 0.55, base, np.minimum(base * 1.3, 1.0)])
    if kind == "photo":  # a print of 4 x 3 photo-like tiles (each about 37 cm x 33 cm)
        tw, th = -(-w // 4), -(-h // 3)
        rows = [np.concatenate([_photo(rng, (th, tw)) for _ in range(4)], 1) for _ in range(3)]
        return np.ascontiguousarray(np.concatenate(rows, 0)[:h, :w])
    raise ValueError(f"unknown table texture {kind!r}; choose None or one of {', '.join(TABLE_TEXTURES)}")


def draw_shape(rng: np.random.Generator) -> Shape:
    """A random procedural object: kind, size (3-12 cm), texture and colour.

    >>> s = draw_shape(np.random.default_rng(1))
    >>> s.kind in ("box", "cylinder", "sphere") and s.texture in OBJECT_TEXTURES
    True
    """
    kind = str(rng.choice(["box", "box", "cylinder", "cylinder", "sphere"]))
    texture = str(rng.choice(OBJECT_TEXTURES))
    if kind == "box":
        size: tuple[float, ...] = tuple(float(x) for x in rng.uniform(0.03, 0.12, 3))
    elif kind == "cylinder":
        size = (float(rng.uniform(0.015, 0.05)), float(rng.uniform(0.03, 0.12)))
    else:
        size = (float(rng.uniform(0.015, 0.045)),)
    rgba = (*(float(c) for c in _colour(rng, 0.15, 0.95)), 1.0)
    image = object_texture(texture, np.random.default_rng(int(rng.integers(2**31))))
    rgba_used = rgba if image is None else (1.0, 1.0, 1.0, 1.0)  # a texture is shown as is (rgba multiplies it)
    return Shape(kind, size, texture, rgba_used, image, f"{texture} {kind}")  # type: ignore[arg-type]


def draw_lighting(rng: np.random.Generator) -> dict[str, Any]:
    """Random ``getCameraImage`` light arguments: direction above the table, tint, coefficients, shadows.

    The light comes from 40-85 degrees above the horizon at any azimuth; its colour
    is white tinted by up to 25 % per channel; ambient 0.35-0.75, diffuse 0.25-0.6,
    specular 0-0.3; shadows in half the draws.

    >>> sorted(draw_lighting(np.random.default_rng(0))) == sorted(LIGHT_KEYS[:2] + LIGHT_KEYS[3:])
    True
    """
    az, el = rng.uniform(0, 2 * np.pi), np.radians(rng.uniform(40, 85))
    direction = [float(np.cos(el) * np.cos(az)), float(np.cos(el) * np.sin(az)), float(np.sin(el))]
    tint = 1 - rng.uniform(0, 0.25, 3)
    return {
        "lightDirection": direction,
        "lightColor": [float(c) for c in tint / tint.max()],
        "lightAmbientCoeff": float(rng.uniform(0.35, 0.75)),
        "lightDiffuseCoeff": float(rng.uniform(0.25, 0.6)),
        "lightSpecularCoeff": float(rng.uniform(0.0, 0.3)),
        "shadow": int(rng.random() < 0.5),
    }


def _light_args(lighting: Any, rng: np.random.Generator) -> dict[str, Any]:
    """``getCameraImage`` keyword arguments for the ``lighting`` option ({} = TinyRenderer's default)."""
    if lighting is None:
        return {}
    if isinstance(lighting, str):
        if lighting != "vary":
            raise ValueError(f"lighting: expected None, 'vary' or a dict (got {lighting!r})")
        return draw_lighting(rng)
    if not isinstance(lighting, dict):
        raise ValueError(f"lighting: expected None, 'vary' or a dict (got {type(lighting).__name__})")
    bad = sorted(set(lighting) - set(LIGHT_KEYS))
    if bad:
        raise ValueError(f"lighting: unknown keys {', '.join(bad)}; choose from {', '.join(LIGHT_KEYS)}")
    out: dict[str, Any] = {}
    for k, v in lighting.items():
        if k in ("lightDirection", "lightColor"):
            vec = [float(x) for x in v]
            if len(vec) != 3 or not np.isfinite(vec).all():
                raise ValueError(f"lighting: {k}: expected 3 finite numbers (got {v!r})")
            out[k] = vec
        elif k == "shadow":
            out[k] = int(bool(v))
        else:
            out[k] = float(v)
    return out


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
    p: Any,
    cid: int,
    eye: np.ndarray,
    target: np.ndarray,
    size: tuple[int, int],
    fov_deg: float,
    near: float = 0.05,
    far: float = 6.0,
    light: dict[str, Any] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Render one camera with TinyRenderer: ``rgb [H, W, 3]``, metric ``depth [H, W]``, body ids ``[H, W]`` (-1 = none), ``K``, ``cam_to_world``.

    ``light``: extra ``getCameraImage`` arguments (:data:`LIGHT_KEYS`); None or {} = the default light.
    """
    w, h = size
    T = look_at(eye, target)
    view = p.computeViewMatrix(list(map(float, eye)), list(map(float, target)), [0, 0, 1], physicsClientId=cid)
    proj = p.computeProjectionMatrixFOV(fov_deg, w / h, near, far, physicsClientId=cid)
    _, _, rgba, dbuf, seg = p.getCameraImage(w, h, view, proj, renderer=p.ER_TINY_RENDERER, physicsClientId=cid, **(light or {}))
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


def _create_shape(p: Any, cid: int, shape: Shape, pos: list[float], orn: Any, texture_id: int | None) -> int:
    """A dynamic body for a procedural ``shape`` (mass from a density of 400 kg/m^3), textured when ``texture_id`` is given."""
    if shape.kind == "box":
        half = [0.5 * x for x in shape.size]
        col = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=cid)
        vis = p.createVisualShape(p.GEOM_BOX, halfExtents=half, rgbaColor=list(shape.rgba), physicsClientId=cid)
        volume = float(np.prod(shape.size))
    elif shape.kind == "cylinder":
        r, ht = shape.size
        col = p.createCollisionShape(p.GEOM_CYLINDER, radius=r, height=ht, physicsClientId=cid)
        vis = p.createVisualShape(p.GEOM_CYLINDER, radius=r, length=ht, rgbaColor=list(shape.rgba), physicsClientId=cid)
        volume = float(np.pi * r * r * ht)
    elif shape.kind == "sphere":
        (r,) = shape.size
        col = p.createCollisionShape(p.GEOM_SPHERE, radius=r, physicsClientId=cid)
        vis = p.createVisualShape(p.GEOM_SPHERE, radius=r, rgbaColor=list(shape.rgba), physicsClientId=cid)
        volume = float(4 / 3 * np.pi * r**3)
    else:
        raise ValueError(f"unknown shape kind {shape.kind!r}")
    b = p.createMultiBody(max(400.0 * volume, 0.01), col, vis, pos, orn, physicsClientId=cid)
    if texture_id is not None:
        p.changeVisualShape(b, -1, textureUniqueId=texture_id, rgbaColor=list(shape.rgba), physicsClientId=cid)
    return b


def _drop(
    p: Any, cid: int, others: list[int], asset: Asset | Shape, xy: np.ndarray, top: float, rng: np.random.Generator, texture_id: int | None = None
) -> int:
    """Load ``asset`` (or create the procedural shape) at ``xy`` with a random orientation, just above the table or the objects under it.

    The body's bounding box (which contains it) starts ``_CLEARANCE`` above the highest
    bounding box it overlaps in x, y (the table's top included), so no body starts
    inside another and none falls from high enough to bounce far.
    """
    orn = p.getQuaternionFromEuler(list(rng.uniform(0, 2 * np.pi, 3)))
    z0 = top + 0.5
    if isinstance(asset, Shape):
        b = _create_shape(p, cid, asset, [float(xy[0]), float(xy[1]), z0], orn, texture_id)
    else:
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
    if isinstance(asset, Asset) and asset.recolor:
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


def _label(item: Asset | Shape) -> str:
    return item.name or item.urdf if isinstance(item, Asset) else item.name or item.kind


def _load_texture(p: Any, cid: int, image: np.ndarray, folder: str, name: str) -> int:
    """Write ``image`` (RGB) as a PNG in ``folder`` and load it as a pybullet texture."""
    import cv2

    path = os.path.join(folder, f"{name}.png")
    if not cv2.imwrite(path, np.ascontiguousarray(image[..., ::-1])):
        raise OSError(f"could not write the texture {path}")
    tid = int(p.loadTexture(path, physicsClientId=cid))
    if tid < 0:
        raise RuntimeError(f"pybullet could not load the texture {path}")
    return tid


@dataclass(frozen=True)
class CameraRig:
    """Where :func:`synthesize` puts its cameras.

    ``arc_deg >= 360`` spaces the views evenly on a full ring; a smaller arc
    spans ``arc_deg`` degrees from the first view to the last. Each camera is
    ``radius`` (+-8 %) from the table's centre horizontally and ``height``
    (+-10 %) above its top, looking at the centre with ``jitter`` (m) of noise;
    ``fov_deg`` is its vertical field of view.
    """

    arc_deg: float = 360.0
    radius: float = 0.5
    height: float = 0.42
    fov_deg: float = 50.0
    jitter: float = 0.03


def synthesize(
    seed: int = 0,
    objects: int = 6,
    views: int = 8,
    size: tuple[int, int] = (640, 480),
    *,
    cameras: CameraRig | None = None,
    settle_steps: int = 480,
    layout: str = "spread",
    object_set: str = "bundled",
    table_texture: str | None = None,
    lighting: str | dict[str, Any] | None = None,
) -> Scene:
    """Render a scene with ``objects`` objects and ``views`` cameras (``size`` = (width, height)).

    ``layout`` (stress set): ``"spread"`` drops objects at least 9 cm apart;
    ``"touching"`` drops them 4-7 cm apart around the centre, so they settle
    against each other; ``"stacked"`` drops them in piles of two or three on
    the same spot, so they land on top of each other.

    ``cameras``: where the views are (:class:`CameraRig`; None: its defaults).

    ``object_set``: ``"bundled"`` (default: :data:`ASSETS`), ``"procedural"``
    (:func:`draw_shape`: textured boxes, cylinders and spheres of 3-12 cm) or
    ``"mixed"`` (each object either, with equal chance). ``table_texture``:
    None (default: the table's own wood image) or one of :data:`TABLE_TEXTURES`.
    ``lighting``: None (default light), ``"vary"`` (:func:`draw_lighting`) or a
    dict of ``getCameraImage`` light arguments (:data:`LIGHT_KEYS`). Table texture
    and lighting come from random streams of their own (``[seed, 1]`` and
    ``[seed, 2]``), so they do not move the objects.

    Returns
    -------
    Scene
        Views named ``000``..; ``meta`` records the seed, the assets used,
        ``redropped``: the names of objects that had to be dropped again (once per
        drop), and ``fell_off``: the names of objects finally not on the table, left
        out of the scene (normally empty; :func:`graphseg.scene.fell_off_warning` words it).
        With a non-default option, also ``object_set``, ``table_texture`` and
        ``lighting`` (the light arguments used).

    Raises
    ------
    ValueError
        For ``seed < 0``, ``objects`` outside ``[1, MAX_OBJECTS]``, ``views``
        outside ``[1, 360]``, a size below 16 pixels, or an unknown layout,
        object set, table texture or lighting.
    """
    _check_args(seed, objects, views, size)
    rig = cameras if cameras is not None else CameraRig()
    radius, height, fov_deg, jitter, arc_deg = rig.radius, rig.height, rig.fov_deg, rig.jitter, rig.arc_deg
    if layout not in ("spread", "touching", "stacked"):
        raise ValueError(f"unknown layout {layout!r}; choose 'spread', 'touching' or 'stacked'")
    if object_set not in OBJECT_SETS:
        raise ValueError(f"unknown object set {object_set!r}; choose one of {', '.join(OBJECT_SETS)}")
    if table_texture is not None and table_texture not in TABLE_TEXTURES:
        raise ValueError(f"unknown table texture {table_texture!r}; choose None or one of {', '.join(TABLE_TEXTURES)}")
    light = _light_args(lighting, np.random.default_rng([int(seed), 2]))
    from ..quiet import native_silence

    with native_silence():  # pybullet prints its build banner on fd 1
        p = require("pybullet", "sim")
        pybullet_data = require("pybullet_data", "sim")
    rng = np.random.default_rng(seed)
    w, h = size
    near, far = 0.05, 6.0
    textures = tempfile.mkdtemp(prefix="graphseg-textures-") if object_set != "bundled" or table_texture is not None else None
    with native_silence():
        cid = p.connect(p.DIRECT)
    try:
        p.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=cid)
        p.setGravity(0, 0, -9.81, physicsClientId=cid)
        plane = p.loadURDF("plane.urdf", [0, 0, 0], physicsClientId=cid)
        table = p.loadURDF("table/table.urdf", [0, 0, 0], useFixedBase=True, physicsClientId=cid)
        p.changeVisualShape(plane, -1, rgbaColor=[0.35, 0.33, 0.3, 1], physicsClientId=cid)
        if table_texture is not None and textures is not None:
            img = table_texture_image(table_texture, np.random.default_rng([int(seed), 1]))
            tid = _load_texture(p, cid, img, textures, "table")
            p.changeVisualShape(table, -1, textureUniqueId=tid, rgbaColor=[1, 1, 1, 1], physicsClientId=cid)
        table_lo, table_hi = p.getAABB(table, physicsClientId=cid)  # the top: x +-0.751, y +-0.501, z 0.574..0.626
        top = float(table_hi[2])
        picks = rng.choice(len(ASSETS), size=objects, replace=objects > len(ASSETS))
        items: list[Asset | Shape] = []
        for k in range(objects):
            if object_set == "bundled" or (object_set == "mixed" and rng.random() < 0.5):
                items.append(ASSETS[int(picks[k])])
            else:
                items.append(draw_shape(rng))
        tex_ids: dict[int, int] = {}  # slot -> texture of a textured procedural shape
        for k, item in enumerate(items):
            if isinstance(item, Shape) and item.image is not None and textures is not None:
                tex_ids[k] = _load_texture(p, cid, item.image, textures, f"object{k:02d}")
        slots: list[tuple[int, Asset | Shape]] = []  # (body, asset) in drop order: the instance ids
        placed: list[np.ndarray] = []
        for k, asset in enumerate(items):
            if layout == "stacked" and k % 3 and placed:  # on top of the pile's first object
                xy = placed[-1] + rng.normal(0, 0.01, 2)
            elif layout == "touching" and placed:
                ang = rng.uniform(0, 2 * np.pi)
                xy = placed[int(rng.integers(len(placed)))] + rng.uniform(0.04, 0.07) * np.array([np.cos(ang), np.sin(ang)])
                xy = np.clip(xy, -_HALF, _HALF)
            else:
                xy = _free_spot(rng, placed, 0.09)
            placed.append(xy)
            slots.append((_drop(p, cid, [b for b, _ in slots], asset, xy, top, rng, tex_ids.get(k)), asset))
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
                slots[i] = (_drop(p, cid, others, slots[i][1], spot, top, rng, tex_ids.get(i)), slots[i][1])
                redropped.append(_label(slots[i][1]))
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
            rgb, depth, body, K, T = render_view(p, cid, eye, target, (w, h), fov_deg, near, far, light)
            inst = np.zeros((h, w), np.int32)
            for b, k in ids.items():
                inst[body == b] = k
            out.append(View(f"{i:03d}", rgb, depth=depth, K=K, cam_to_world=T, instances=inst))
        objects_named = {ids[b]: _label(a) for b, a in kept}
        fell_off = [_label(slots[i][1]) for i in off]
    finally:
        p.disconnect(physicsClientId=cid)
        if textures is not None:
            import shutil

            shutil.rmtree(textures, ignore_errors=True)
    meta: dict[str, Any] = {"seed": seed, "generator": "graphseg.sim.pybullet_scenes", "fov_deg": fov_deg, "layout": layout, "objects_requested": objects, "fell_off": fell_off, "redropped": redropped}
    if object_set != "bundled":
        meta["object_set"] = object_set
    if table_texture is not None:
        meta["table_texture"] = table_texture
    if light:
        meta["lighting"] = light
    return Scene(out, objects_named, name=f"synth-{seed}", meta=meta)
