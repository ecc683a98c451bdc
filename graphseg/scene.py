"""Input data types: :class:`Scene`, :class:`View` and :class:`Matches`.

Cameras use OpenCV axes (x right, y down, z forward). ``cam_to_world`` maps
camera coordinates to world coordinates, in metres. Pixel coordinates are
``(x, y)`` = (column, row).

Examples
--------
>>> import numpy as np
>>> v = View("000", rgb=np.zeros((4, 5, 3), np.uint8))
>>> v.shape
(4, 5)
>>> Scene([v]).num_views
1
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

__all__ = ["View", "Scene", "Matches", "SceneError", "backproject", "is_rigid", "fell_off_warning"]


class SceneError(ValueError):
    """Bad input data; ``where`` names the file or view and ``field`` the field."""

    def __init__(self, message: str, *, where: str | None = None, field: str | None = None) -> None:
        self.where = where
        self.field = field
        prefix = ""
        if where:
            prefix += f"{where}: "
        if field:
            prefix += f"{field}: "
        super().__init__(prefix + message)


def is_rigid(T: np.ndarray, tol: float = 1e-3) -> bool:
    """Whether a 4x4 matrix is a rigid transform (orthonormal rotation, det +1, last row 0 0 0 1).

    Examples
    --------
    >>> is_rigid(np.eye(4)), is_rigid(np.diag([2.0, 1, 1, 1]))
    (True, False)
    """
    T = np.asarray(T, dtype=np.float64)
    if T.shape != (4, 4) or not np.isfinite(T).all():
        return False
    R = T[:3, :3]
    with np.errstate(over="ignore", invalid="ignore"):  # huge finite entries: not rigid, without a warning
        return bool(
            np.allclose(R @ R.T, np.eye(3), atol=tol)
            and abs(np.linalg.det(R) - 1) < tol
            and np.allclose(T[3], [0, 0, 0, 1], atol=tol)
        )


def backproject(depth: np.ndarray, K: np.ndarray, cam_to_world: np.ndarray | None = None) -> np.ndarray:
    """World (or camera) points ``[H, W, 3]`` float32 from metric depth; NaN where depth <= 0.

    Parameters
    ----------
    depth : float array ``[H, W]``
        Metres along the optical axis (z), 0 or NaN = invalid.
    K : ``[3, 3]``
        Intrinsics.
    cam_to_world : ``[4, 4]``, optional
        When given, points are returned in the world frame.

    Examples
    --------
    >>> K = np.array([[2.0, 0, 1], [0, 2, 1], [0, 0, 1]])
    >>> backproject(np.full((2, 2), 4.0), K)[1, 1].tolist()
    [0.0, 0.0, 4.0]
    """
    d = np.asarray(depth, dtype=np.float32)
    h, w = d.shape
    K = np.asarray(K, dtype=np.float64)
    xs = (np.arange(w, dtype=np.float32) - K[0, 2]) / K[0, 0]
    ys = (np.arange(h, dtype=np.float32) - K[1, 2]) / K[1, 1]
    pts = np.empty((h, w, 3), np.float32)
    pts[..., 0] = xs[None, :] * d
    pts[..., 1] = ys[:, None] * d
    pts[..., 2] = d
    if cam_to_world is not None:
        T = np.asarray(cam_to_world, dtype=np.float32)
        pts = pts @ T[:3, :3].T + T[:3, 3]
    bad = ~(d > 0)
    pts[bad] = np.nan
    return pts


@dataclass
class View:
    """One image of a scene.

    Attributes
    ----------
    name : str
    rgb : uint8 ``[H, W, 3]``
    depth : float32 ``[H, W]`` metres, optional (0 or NaN = invalid)
    points : float32 ``[H, W, 3]`` world-frame point map, NaN where invalid, optional
        until a lifter fills it.
    confidence : float ``[H, W]``, optional
    K : float64 ``[3, 3]``, optional
    cam_to_world : float64 ``[4, 4]``, optional
    instances : int ``[H, W]`` ground truth, 0 = background, optional
    """

    name: str
    rgb: np.ndarray
    depth: np.ndarray | None = None
    points: np.ndarray | None = None
    confidence: np.ndarray | None = None
    K: np.ndarray | None = None
    cam_to_world: np.ndarray | None = None
    instances: np.ndarray | None = None
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def shape(self) -> tuple[int, int]:
        """``(H, W)``."""
        return (int(self.rgb.shape[0]), int(self.rgb.shape[1]))

    @property
    def camera_center(self) -> np.ndarray:
        """World position of the camera ``[3]``."""
        if self.cam_to_world is None:
            raise SceneError("view has no pose", where=self.name, field="cam_to_world")
        return np.asarray(self.cam_to_world, np.float64)[:3, 3]

    def camera_points(self) -> np.ndarray:
        """Camera-frame points ``[H, W, 3]`` float32 (NaN = invalid).

        From ``points`` and ``cam_to_world`` when both exist, else from ``depth``
        and ``K``; a point map without a pose is taken as camera-frame already.
        """
        if self.points is not None and self.cam_to_world is not None:
            T = np.asarray(self.cam_to_world, np.float64)
            return ((np.asarray(self.points, np.float64) - T[:3, 3]) @ T[:3, :3]).astype(np.float32)
        if self.depth is not None and self.K is not None:
            return backproject(self.depth, self.K)
        if self.points is not None:
            return np.asarray(self.points, np.float32)
        raise SceneError("needs depth + K or a point map", where=self.name, field="depth")

    def z_depth(self) -> np.ndarray:
        """Depth along the optical axis ``[H, W]`` float32, NaN where invalid."""
        if self.depth is not None:
            d = np.asarray(self.depth, np.float32)
            return np.where(d > 0, d, np.float32(np.nan))
        return self.camera_points()[..., 2]

    def replace(self, **changes: Any) -> View:
        """A shallow copy with some fields replaced."""
        return replace(self, **changes)

    def validate(self) -> None:
        """Check shapes and dtypes; raise :class:`SceneError` naming the field."""
        rgb = np.asarray(self.rgb)
        if rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.dtype != np.uint8:
            raise SceneError(f"expected uint8 [H, W, 3] (got {rgb.dtype} {list(rgb.shape)})", where=self.name, field="rgb")
        h, w = self.shape
        if self.depth is not None:
            d = np.asarray(self.depth)
            if d.shape != (h, w):
                raise SceneError(f"expected [{h}, {w}] like rgb (got {list(d.shape)})", where=self.name, field="depth")
            if d.dtype.kind != "f":
                raise SceneError(f"expected float metres (got {d.dtype})", where=self.name, field="depth")
        if self.points is not None:
            p = np.asarray(self.points)
            if p.shape != (h, w, 3):
                raise SceneError(f"expected [{h}, {w}, 3] (got {list(p.shape)})", where=self.name, field="points")
        if self.confidence is not None and np.asarray(self.confidence).shape != (h, w):
            raise SceneError(f"expected [{h}, {w}] (got {list(np.shape(self.confidence))})", where=self.name, field="confidence")
        if self.instances is not None:
            inst = np.asarray(self.instances)
            if inst.shape != (h, w) or inst.dtype.kind not in "iu":
                raise SceneError(f"expected int [{h}, {w}] (got {inst.dtype} {list(inst.shape)})", where=self.name, field="instances")
        if self.K is not None:
            K = np.asarray(self.K)
            if K.shape != (3, 3) or not np.isfinite(K).all():
                raise SceneError(f"expected a finite 3x3 matrix (got shape {list(K.shape)})", where=self.name, field="K")
        if self.cam_to_world is not None:
            T = np.asarray(self.cam_to_world, dtype=np.float64)
            if T.shape != (4, 4):
                raise SceneError(f"expected 4x4 (got {list(T.shape)})", where=self.name, field="cam_to_world")
            if not np.isfinite(T).all():
                raise SceneError("contains NaN or inf", where=self.name, field="cam_to_world")
            if not is_rigid(T):
                raise SceneError("not a rigid transform (rotation must be orthonormal with det +1)", where=self.name, field="cam_to_world")


@dataclass
class Scene:
    """A list of views plus optional object names (ground-truth id -> name)."""

    views: list[View]
    objects: dict[int, str] = field(default_factory=dict)
    name: str = "scene"
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def num_views(self) -> int:
        return len(self.views)

    def __len__(self) -> int:
        return len(self.views)

    def __iter__(self) -> Iterator[View]:
        return iter(self.views)

    def __getitem__(self, i: int) -> View:
        return self.views[i]

    @property
    def has_depth(self) -> bool:
        return bool(self.views) and all(v.depth is not None for v in self.views)

    @property
    def has_points(self) -> bool:
        return bool(self.views) and all(v.points is not None for v in self.views)

    @property
    def has_poses(self) -> bool:
        return bool(self.views) and all(v.cam_to_world is not None and v.K is not None for v in self.views)

    @property
    def has_instances(self) -> bool:
        return bool(self.views) and all(v.instances is not None for v in self.views)

    def select(self, indices: Sequence[int]) -> Scene:
        """A scene with only the given views, in the given order."""
        return Scene([self.views[i] for i in indices], dict(self.objects), self.name, dict(self.meta))

    def validate(self) -> None:
        """Validate every view; names must be unique."""
        if not self.views:
            raise SceneError("scene has no views", where=self.name, field="views")
        names = [v.name for v in self.views]
        if len(set(names)) != len(names):
            raise SceneError("view names must be unique", where=self.name, field="views")
        for v in self.views:
            v.validate()


@dataclass
class Matches:
    """Pixel matches between view ``i`` and view ``j``.

    Attributes
    ----------
    xy_i, xy_j : float32 ``[M, 2]``
        Pixel coordinates ``(x, y)`` in each image.
    certainty : float32 ``[M]``
        Higher is better, in ``[0, 1]`` by convention.
    """

    xy_i: np.ndarray
    xy_j: np.ndarray
    certainty: np.ndarray

    def __post_init__(self) -> None:
        self.xy_i = np.asarray(self.xy_i, dtype=np.float32).reshape(-1, 2)
        self.xy_j = np.asarray(self.xy_j, dtype=np.float32).reshape(-1, 2)
        self.certainty = np.asarray(self.certainty, dtype=np.float32).reshape(-1)
        m = self.xy_i.shape[0]
        if self.xy_j.shape[0] != m or self.certainty.shape[0] != m:
            raise ValueError(
                f"expected xy_i [M, 2], xy_j [M, 2] and certainty [M] with one M "
                f"(got {self.xy_i.shape[0]}, {self.xy_j.shape[0]}, {self.certainty.shape[0]})"
            )

    def __len__(self) -> int:
        return int(self.xy_i.shape[0])

    def top(self, n: int | None) -> Matches:
        """The ``n`` most certain matches (all when ``n`` is None or >= M).

        Examples
        --------
        >>> m = Matches(np.zeros((3, 2)), np.ones((3, 2)), [0.1, 0.9, 0.5])
        >>> m.top(2).certainty.tolist()
        [0.8999999761581421, 0.5]
        """
        if n is None or n >= len(self):
            return self
        idx = np.argpartition(-self.certainty, n - 1)[:n]
        idx = idx[np.argsort(-self.certainty[idx], kind="stable")]
        return Matches(self.xy_i[idx], self.xy_j[idx], self.certainty[idx])


def fell_off_warning(scene: Scene) -> str | None:
    """The one-line warning for a synthetic scene that lacks objects that fell off the table, or None.

    >>> fell_off_warning(Scene([], meta={"fell_off": ["sphere"], "objects_requested": 3}))
    '1 of 3 objects did not stay on the table and are not in the scene: sphere'
    >>> fell_off_warning(Scene([])) is None
    True
    """
    fell = list(scene.meta.get("fell_off") or [])
    if not fell:
        return None
    total = int(scene.meta.get("objects_requested") or len(fell) + len(scene.objects))
    return f"{len(fell)} of {total} objects did not stay on the table and are not in the scene: {', '.join(map(str, fell))}"
