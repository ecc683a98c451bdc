"""Objects for a robot: per object a fused mesh and its boxes, in the scene's frame.

For every object of a :class:`~graphseg.result.Result`, :func:`object_geometry`
reads its points from the lifted scene (every pixel of the object with a valid
world point, over all views) and gives the number of views and points, the
centroid, the axis-aligned box and an oriented box. The oriented box is
*upright* when the table plane is known (``result.info["background"]["plane"]``):
its third axis is the table normal and its footprint the smallest-area rectangle
around the points seen from above (rotating calipers on their convex hull), the
box a gripper plans with; without a plane it is the principal-axes box.

:func:`fuse_mesh` fuses one object's views into a triangle mesh with open3d
(extra ``open3d``, imported only there): the object's masked depth of every
view it appears in (the camera-frame depth of its world points, so estimated
point maps work too) is integrated into a TSDF volume
(``open3d.pipelines.integration.ScalableTSDFVolume``, colours included) with the
view's ``K`` and pose, and the surface is extracted by marching cubes; or, with
``method="poisson"``, a screened Poisson surface of the object's points (normals
facing the camera that saw each point), trimmed to the points' box and to the
well-supported vertices. The mesh is in the scene's (world) frame, in metres.

:func:`write_objects` writes ``objects.json`` and ``objects/NNN_mesh.ply``
(binary PLY, readable by open3d, trimesh and any PLY reader) into an output
folder. Without open3d, or without poses and intrinsics, ``objects.json`` is still
written, every ``mesh`` is ``null`` and ``mesh_note`` says why.

``objects.json``::

    {"kind": "graphseg-objects", "version": 1, "frame": "world", "units": "m",
     "method": "tsdf", "voxel_size": ..., "open3d": "0.19.0", "mesh_note": null,
     "objects": [{"id": 1, "name": null, "views": 3, "view_names": [...],
                  "num_points": 5120, "centroid": [x, y, z],
                  "aabb": {"min": [...], "max": [...]}, "extent": [dx, dy, dz],
                  "obb": {"center": [...], "rotation": [[...], [...], [...]], "extent": [...], "upright": true},
                  "mesh": "objects/001_mesh.ply", "mesh_vertices": 812, "mesh_triangles": 1540}, ...]}

``rotation``'s columns are the box axes in the world frame (det +1);
``extent`` is the full side lengths along them.

Examples
--------
>>> from graphseg.method.segment import segment
>>> from graphseg.testing.scenes import two_boxes_scene
>>> scene, masks, matches = two_boxes_scene()
>>> objs = object_geometry(scene, segment(scene, masks, matches))
>>> [o["id"] for o in objs], objs[0]["views"], objs[0]["obb"]["upright"]
([1, 2], 3, True)
"""

from __future__ import annotations

import json
import os
import sys
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .registry import MissingDependencyError
from .result import Result
from .scene import Scene

__all__ = [
    "object_points",
    "upright_box",
    "principal_box",
    "object_geometry",
    "fuse_mesh",
    "write_objects",
    "canonical_mesh",
    "write_mesh_ply",
    "auto_voxel",
    "camera_depths",
    "load_open3d",
    "OBJECTS_FILE",
    "MESH_METHODS",
]

#: Name of the object table in an output folder.
OBJECTS_FILE = "objects.json"
#: Surface methods of :func:`fuse_mesh`.
MESH_METHODS = ("tsdf", "poisson")


#: Modules that open3d's ``__init__`` imports and graphseg never uses: its ML datasets (which import
#: scikit-learn and pandas) and its Plotly viewer (which imports dash and IPython). Together they are
#: about 2 s of a 2.5 s import. :func:`load_open3d` imports open3d without them; a later
#: ``import open3d.ml`` or ``open3d.visualization.draw_plotly(...)`` imports them as usual.
OPEN3D_DEFERRED = ("open3d.ml", "open3d.visualization.draw_plotly")


def _deferred_plotly(name: str) -> Any:
    """A stand-in for ``open3d.visualization.<name>`` that imports the Plotly viewer on first call."""

    def call(*args: Any, **kwargs: Any) -> Any:
        import importlib

        vis = sys.modules["open3d.visualization"]
        module = importlib.import_module("open3d.visualization.draw_plotly")
        for attr in ("draw_plotly", "draw_plotly_server"):  # as open3d's own import leaves them: the functions
            setattr(vis, attr, getattr(module, attr))
        return getattr(module, name)(*args, **kwargs)

    call.__name__ = call.__qualname__ = name
    return call


def _open3d_getattr(name: str) -> Any:
    """``open3d.ml`` on first access (module ``__getattr__``, PEP 562)."""
    if name == "ml":
        import importlib

        return importlib.import_module("open3d.ml")
    raise AttributeError(f"module 'open3d' has no attribute {name!r}")


def _lazy_module(name: str) -> None:
    """Put module ``name`` in ``sys.modules`` as a lazily loaded module (its code runs on first attribute access).

    An explicit ``import name`` then finds it there and, as with a module
    imported the usual way, leaves the names its parent package bound alone.
    """
    import importlib.util

    spec = importlib.util.find_spec(name)
    if spec is None or spec.loader is None:
        return
    spec.loader = importlib.util.LazyLoader(spec.loader)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)


def _import_open3d_deferred() -> Any:
    """``import open3d`` without the modules of :data:`OPEN3D_DEFERRED`, which load on first use instead.

    Empty modules stand in for them during the import (only for those not
    imported already). Afterwards ``open3d.ml`` imports on first access and
    the Plotly viewer's module is in ``sys.modules`` as a lazily loaded
    module, so nothing of the stand-ins stays behind.
    """
    import types

    placeholders = {name: types.ModuleType(name) for name in OPEN3D_DEFERRED if name not in sys.modules}
    if "open3d.ml" in placeholders:
        placeholders["open3d.ml"].__path__ = []
    if "open3d.visualization.draw_plotly" in placeholders:
        for attr in ("draw_plotly", "draw_plotly_server"):
            setattr(placeholders["open3d.visualization.draw_plotly"], attr, _deferred_plotly(attr))
    sys.modules.update(placeholders)
    try:
        import open3d
    finally:
        for name, module in placeholders.items():
            if sys.modules.get(name) is module:
                del sys.modules[name]
    if "open3d.visualization.draw_plotly" in placeholders and "open3d.visualization.draw_plotly" not in sys.modules:
        _lazy_module("open3d.visualization.draw_plotly")
    if "open3d.ml" in placeholders and open3d.__dict__.get("ml") is placeholders["open3d.ml"]:
        del open3d.ml
    if "ml" not in open3d.__dict__ and "__getattr__" not in open3d.__dict__:
        open3d.__getattr__ = _open3d_getattr
    return open3d


def load_open3d() -> Any:
    """Import open3d (extra ``open3d``), or raise :class:`MissingDependencyError` saying what failed.

    open3d's CUDA build warns at import on a machine without a GPU; that
    warning is silenced. Before the first import, ``OMP_WAIT_POLICY`` is set
    to ``PASSIVE`` unless already set (OpenMP threads that spin while waiting
    slow fusion down 10-20 times on a busy machine); it takes effect only if
    no OpenMP runtime was loaded before. A wheel that is installed but cannot load one of its
    system libraries (open3d 0.20 needs ``libusb-1.0.so.0``) is named as such.
    When graphseg imports open3d first, the modules it never uses
    (:data:`OPEN3D_DEFERRED`) load on their first use instead (2 s less).
    """
    if "open3d" not in sys.modules:
        # open3d's OpenMP threads spin while they wait: on a busy machine one
        # fusion takes 10-20 times longer (measured: 1.2 s instead of 0.07 s)
        os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=".*CUDA.*", category=ImportWarning)
            if "open3d" in sys.modules:
                import open3d
            else:
                open3d = _import_open3d_deferred()
    except ImportError as err:
        if getattr(err, "name", None) == "open3d" or "No module named 'open3d'" in str(err):
            raise MissingDependencyError("this feature needs 'open3d': pip install \"graphseg[open3d]\"") from err
        raise MissingDependencyError(f"open3d is installed but does not import ({str(err).splitlines()[0]}); pip install \"graphseg[open3d]\" (open3d 0.19 bundles its libraries)") from err
    return open3d


# ----------------------------------------------------------------------------- points and boxes
def object_points(scene: Scene, result: Result, obj: int) -> tuple[np.ndarray, np.ndarray]:
    """World points ``[P, 3]`` of every pixel of object ``obj`` with a valid point, and the view of each ``[P]``.

    From the scene's point maps (full resolution, not the result's downsampled
    clouds); a scene without point maps gives the result's cloud (view -1).

    Examples
    --------
    >>> from graphseg.method.segment import segment
    >>> from graphseg.testing.scenes import two_boxes_scene
    >>> scene, masks, matches = two_boxes_scene()
    >>> p, v = object_points(scene, segment(scene, masks, matches), 1)
    >>> p.shape[1], sorted(set(v.tolist()))
    (3, [0, 1, 2])
    """
    if not 1 <= obj <= result.num_objects:
        raise IndexError(f"object {obj} out of range [1, {result.num_objects}]")
    if not scene.has_points:
        cloud = result.object_cloud(obj)[0]
        return np.asarray(cloud, np.float64), np.full(len(cloud), -1, np.int64)
    pts: list[np.ndarray] = []
    views: list[np.ndarray] = []
    for v, (view, lab) in enumerate(zip(scene.views, result.labels)):
        sel = np.asarray(lab) == obj
        if not sel.any():
            continue
        p = np.asarray(view.points)[sel]
        p = p[np.isfinite(p).all(1)]
        pts.append(p.astype(np.float64))
        views.append(np.full(len(p), v, np.int64))
    if not pts:
        return np.zeros((0, 3)), np.zeros(0, np.int64)
    return np.concatenate(pts), np.concatenate(views)


def principal_box(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The box along the points' principal axes: ``center [3]``, ``rotation [3, 3]`` (columns = axes, det +1), ``extent [3]``.

    Notes
    -----
    O(P).

    Examples
    --------
    >>> c, R, e = principal_box(np.array([[0.0, 0, 0], [4, 0, 0], [0, 1, 0], [4, 1, 0]]))
    >>> c.round(6).tolist(), e.round(6).tolist()
    ([2.0, 0.5, 0.0], [4.0, 1.0, 0.0])
    """
    P = np.asarray(points, np.float64).reshape(-1, 3)
    if len(P) == 0:
        raise ValueError("principal_box: expected at least one point (got 0)")
    mu = P.mean(0)
    _, _, vt = np.linalg.svd(P - mu, full_matrices=False) if len(P) > 1 else (None, None, np.eye(3))
    R = np.eye(3)
    R[:, : vt.shape[0]] = vt.T
    if vt.shape[0] < 3:  # fewer than 3 points: complete the frame
        R = np.linalg.qr(R)[0]
    if np.linalg.det(R) < 0:
        R[:, 2] *= -1
    local = (P - mu) @ R
    lo, hi = local.min(0), local.max(0)
    return mu + R @ ((lo + hi) / 2), R, hi - lo


def upright_box(points: np.ndarray, up: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The smallest-footprint box whose third axis is ``up``: ``center [3]``, ``rotation [3, 3]``, ``extent [3]``.

    The points are seen along ``up``; of the rectangles aligned with an edge of
    their 2D convex hull (rotating calipers; the smallest rectangle is one of
    them) the one of least area gives the first two axes (the first the longer
    side).

    Notes
    -----
    O(P log P) for the hull, then O(H^2) for its H edges.

    Examples
    --------
    >>> import numpy as np
    >>> sq = np.array([[1.0, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0], [0, 0, 2]])   # a diamond, and a point above it
    >>> c, R, e = upright_box(sq, np.array([0.0, 0, 1]))
    >>> e.round(6).tolist(), c.round(6).tolist(), round(float(np.linalg.det(R)), 6)
    ([1.414214, 1.414214, 2.0], [0.0, 0.0, 1.0], 1.0)
    """
    from scipy.spatial import ConvexHull, QhullError

    P = np.asarray(points, np.float64).reshape(-1, 3)
    if len(P) == 0:
        raise ValueError("upright_box: expected at least one point (got 0)")
    n = np.asarray(up, np.float64)
    n = n / np.linalg.norm(n)
    a = np.cross(n, np.eye(3)[int(np.argmin(np.abs(n)))])
    a /= np.linalg.norm(a)
    b = np.cross(n, a)
    xy = np.c_[P @ a, P @ b]
    try:
        hull = xy[ConvexHull(xy).vertices]
    except QhullError:  # fewer than 3 distinct points, or all on a line
        hull = xy
    best = (np.inf, 0.0)
    edges = np.roll(hull, -1, axis=0) - hull if len(hull) > 1 else np.array([[1.0, 0.0]])
    for e in edges:
        if not np.any(e):
            continue
        t = np.arctan2(e[1], e[0])
        c, s = np.cos(t), np.sin(t)
        r = hull @ np.array([[c, -s], [s, c]])
        area = float(np.prod(r.max(0) - r.min(0)))
        if area < best[0] - 1e-15:
            best = (area, float(t))
    t = best[1]
    u = np.cos(t) * a + np.sin(t) * b
    v = np.cross(n, u)
    R = np.stack([u, v, n], axis=1)
    local = P @ R
    lo, hi = local.min(0), local.max(0)
    ext = hi - lo
    if ext[1] > ext[0]:  # first axis along the longer side
        R = np.stack([v, -u, n], axis=1)
        local = P @ R
        lo, hi = local.min(0), local.max(0)
        ext = hi - lo
    return R @ ((lo + hi) / 2), R, ext


def _up(result: Result) -> np.ndarray | None:
    p = (result.info.get("background") or {}).get("plane")
    if p is None or len(p) != 4 or not np.isfinite(p).all() or not np.linalg.norm(p[:3]) > 0:
        return None
    return np.asarray(p[:3], np.float64) / np.linalg.norm(p[:3])


def object_geometry(scene: Scene, result: Result) -> list[dict[str, Any]]:
    """The ``objects.json`` entries of every object with at least one point (without the mesh fields).

    Parameters
    ----------
    scene : Scene
        The lifted scene of ``result`` (its views in the same order).
    result : Result

    Returns
    -------
    list of dict
        ``id``, ``name`` (None), ``views``, ``view_names``, ``num_points``,
        ``centroid``, ``aabb`` (``min``, ``max``), ``extent``, ``obb``
        (``center``, ``rotation``, ``extent``, ``upright``); plain floats and lists.

    Notes
    -----
    O(total pixels) plus O(P log P) per object.
    """
    _check(scene, result)
    up = _up(result)
    out = []
    for k in range(1, result.num_objects + 1):
        P, views = object_points(scene, result, k)
        if len(P) == 0:
            continue
        lo, hi = P.min(0), P.max(0)
        c, R, e = upright_box(P, up) if up is not None else principal_box(P)
        seen = sorted(set(views.tolist()) - {-1})
        if not seen:  # no point maps: the views whose label images hold the object
            seen = [v for v, lab in enumerate(result.labels) if (np.asarray(lab) == k).any()]
        out.append(
            {
                "id": k,
                "name": None,
                "views": len(seen),
                "view_names": [result.view_names[v] for v in seen],
                "num_points": int(len(P)),
                "centroid": P.mean(0).tolist(),
                "aabb": {"min": lo.tolist(), "max": hi.tolist()},
                "extent": (hi - lo).tolist(),
                "obb": {"center": c.tolist(), "rotation": R.tolist(), "extent": e.tolist(), "upright": up is not None},
            }
        )
    return out


def _check(scene: Scene, result: Result) -> None:
    if len(scene.views) != len(result.labels):
        raise ValueError(f"expected the scene of the result ({len(result.labels)} views) (got {len(scene.views)} views)")
    for view, lab in zip(scene.views, result.labels):
        if view.shape != np.asarray(lab).shape:
            raise ValueError(f"view {view.name}: labels are {list(np.shape(lab))} but the image is {list(view.shape)}")


# ----------------------------------------------------------------------------- meshes
def _camera_depth(view: Any) -> np.ndarray:
    """Camera-frame z of the view's world points ``[H, W]`` float32, 0 where invalid."""
    z = np.asarray(view.camera_points(), np.float32)[..., 2]
    return np.where(np.isfinite(z) & (z > 0), z, 0).astype(np.float32)


def camera_depths(scene: Scene) -> list[np.ndarray]:
    """Per view, the camera-frame depth of its world points ``[H, W]`` float32 (0 = invalid): what the TSDF integrates.

    From the point maps (and poses), so estimated point maps are fused as they
    were lifted. O(total pixels).
    """
    return [_camera_depth(v) for v in scene.views]


def auto_voxel(scene: Scene, result: Result, obj: int, *, depths: Sequence[np.ndarray] | None = None) -> float:
    """A TSDF voxel for object ``obj``: 1.25 times the median pixel footprint on it, at most 1/20 of its largest side.

    The footprint of a pixel at depth ``z`` is ``z / f``; so the voxel follows
    the image resolution and the distance, not a fixed size in metres.
    ``depths``: the views' camera-frame depth (:func:`camera_depths`), computed when None.
    """
    feet, sides = [], []
    for v, (view, lab) in enumerate(zip(scene.views, result.labels)):
        sel = np.asarray(lab) == obj
        if not sel.any() or view.K is None:
            continue
        z = (_camera_depth(view) if depths is None else depths[v])[sel]
        z = z[z > 0]
        if z.size:
            feet.append(float(np.median(z)) / float(np.asarray(view.K)[0, 0]))
    P, _ = object_points(scene, result, obj)
    if len(P):
        sides.append(float((P.max(0) - P.min(0)).max()))
    foot = 1.25 * float(np.median(feet)) if feet else 0.005
    return max(min(foot, (max(sides) / 20) if sides and max(sides) > 0 else foot), 1e-6)


def fuse_mesh(
    scene: Scene,
    result: Result,
    obj: int,
    *,
    method: str = "tsdf",
    voxel_size: float | None = None,
    trunc_voxels: float = 3.0,
    poisson_depth: int = 8,
    depths: Sequence[np.ndarray] | None = None,
) -> Any:
    """The fused mesh of object ``obj`` (``open3d.geometry.TriangleMesh``, world frame, metres).

    Parameters
    ----------
    scene : Scene
        The lifted scene of ``result``: world ``points``, ``K`` and ``cam_to_world`` per view.
    result : Result
    obj : int
        Object id ``1..K``.
    method : {"tsdf", "poisson"}, keyword-only
        ``"tsdf"``: the object's masked depth of every view integrated into a
        ``ScalableTSDFVolume`` (colours too), then marching cubes.
        ``"poisson"``: a screened Poisson surface of its points (normals facing
        the camera of each point), trimmed to their box (grown by one voxel) and
        to vertices above the 5th percentile of support.
    voxel_size : float, optional, keyword-only
        TSDF voxel (m); default :func:`auto_voxel`.
    trunc_voxels : float, keyword-only
        TSDF truncation, in voxels.
    poisson_depth : int, keyword-only
        Octree depth of the Poisson solve.
    depths : list of float32 ``[H, W]``, optional, keyword-only
        :func:`camera_depths` of the scene, when already computed (for many objects).

    Returns
    -------
    open3d.geometry.TriangleMesh
        Possibly empty (no triangles) when the object has too few points.

    Raises
    ------
    MissingDependencyError
        Without open3d.
    ValueError
        For an unknown method, an object id out of range, or views without pose or intrinsics.

    Notes
    -----
    TSDF: O(object pixels x truncation / voxel) per view; Poisson: O(P log P).
    """
    if method not in MESH_METHODS:
        raise ValueError(f"unknown mesh method {method!r}; choose one of {', '.join(MESH_METHODS)}")
    if not 1 <= obj <= result.num_objects:
        raise IndexError(f"object {obj} out of range [1, {result.num_objects}]")
    _check(scene, result)
    for view in scene.views:
        if view.K is None or view.cam_to_world is None or view.points is None:
            raise ValueError(f"view {view.name}: fusing a mesh needs K, cam_to_world and a point map")
    o3d = load_open3d()
    if depths is None and method == "tsdf":
        depths = camera_depths(scene)
    vox = float(voxel_size) if voxel_size is not None else auto_voxel(scene, result, obj, depths=depths)
    if not vox > 0:
        raise ValueError(f"voxel_size: expected a number > 0 (got {voxel_size!r})")
    if method == "poisson":
        return _poisson(o3d, scene, result, obj, vox, poisson_depth)
    vol = o3d.pipelines.integration.ScalableTSDFVolume(
        voxel_length=vox, sdf_trunc=trunc_voxels * vox, color_type=o3d.pipelines.integration.TSDFVolumeColorType.RGB8
    )
    assert depths is not None
    for view, lab, z in zip(scene.views, result.labels, depths):
        sel = np.asarray(lab) == obj
        if not sel.any():
            continue
        depth = np.where(sel, z, 0).astype(np.float32)
        if not (depth > 0).any():
            continue
        h, w = view.shape
        K = np.asarray(view.K, np.float64)
        intr = o3d.camera.PinholeCameraIntrinsic(w, h, K[0, 0], K[1, 1], K[0, 2], K[1, 2])
        rgbd = o3d.geometry.RGBDImage.create_from_color_and_depth(
            o3d.geometry.Image(np.ascontiguousarray(view.rgb, np.uint8)),
            o3d.geometry.Image(np.ascontiguousarray(depth)),
            depth_scale=1.0,
            depth_trunc=float(depth.max()) + 1.0,
            convert_rgb_to_intensity=False,
        )
        vol.integrate(rgbd, intr, np.linalg.inv(np.asarray(view.cam_to_world, np.float64)))
    mesh = vol.extract_triangle_mesh()
    mesh.remove_degenerate_triangles()
    mesh.remove_unreferenced_vertices()
    return mesh


def _poisson(o3d: Any, scene: Scene, result: Result, obj: int, vox: float, depth: int) -> Any:
    P, views = object_points(scene, result, obj)
    if len(P) < 10:
        return o3d.geometry.TriangleMesh()
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(P))
    pcd = pcd.voxel_down_sample(vox / 2)
    pts = np.asarray(pcd.points)
    # the camera of each kept point: that of its nearest original point
    from scipy.spatial import cKDTree

    _, idx = cKDTree(P).query(pts)
    cams = np.array([view.camera_center for view in scene.views])[views[idx]]
    pcd.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=4 * vox, max_nn=30))
    nrm = np.asarray(pcd.normals)
    flip = np.einsum("ij,ij->i", nrm, cams - pts) < 0
    nrm[flip] *= -1
    pcd.normals = o3d.utility.Vector3dVector(nrm)
    mesh, dens = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(pcd, depth=int(depth))
    dens = np.asarray(dens)
    if dens.size:
        mesh.remove_vertices_by_mask(dens < np.quantile(dens, 0.05))
    box = o3d.geometry.AxisAlignedBoundingBox(pts.min(0) - vox, pts.max(0) + vox)
    mesh = mesh.crop(box)
    mesh.remove_degenerate_triangles()
    mesh.remove_unreferenced_vertices()
    return mesh


def canonical_mesh(mesh: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Vertices float32 ``[V, 3]``, triangles int32 ``[F, 3]`` and colours uint8 ``[V, 3]`` (or None) in a canonical order.

    Vertices are sorted by their float32 coordinates (z, then y, then x);
    each triangle starts at its smallest vertex index (its orientation kept) and
    the triangles are sorted. Two fusions that differ only in the order open3d's
    threads emitted the surface give the same arrays, so the same file.

    Examples
    --------
    >>> class M:
    ...     vertices = [[1.0, 0, 0], [0, 0, 0], [0, 1, 0]]
    ...     triangles = [[0, 2, 1]]
    ...     vertex_colors = []
    >>> V, F, C = canonical_mesh(M())
    >>> V.tolist(), F.tolist(), C
    ([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], [[0, 1, 2]], None)
    """
    V = np.asarray(mesh.vertices, np.float64).astype(np.float32).reshape(-1, 3)
    F = np.asarray(mesh.triangles, np.int64).reshape(-1, 3)
    cols = np.asarray(mesh.vertex_colors, np.float64).reshape(-1, 3)
    C = np.clip(np.rint(cols * 255), 0, 255).astype(np.uint8) if len(cols) == len(V) and len(V) else None
    order = np.lexsort((V[:, 0], V[:, 1], V[:, 2]))
    rank = np.empty(len(V), np.int64)
    rank[order] = np.arange(len(V))
    V = V[order]
    C = None if C is None else C[order]
    F = rank[F]
    if len(F):
        shift = np.argmin(F, axis=1)
        F = np.stack([F[np.arange(len(F)), (shift + k) % 3] for k in range(3)], axis=1)
        F = F[np.lexsort((F[:, 2], F[:, 1], F[:, 0]))]
    return V, F.astype(np.int32), C


def write_mesh_ply(path: str | os.PathLike[str], vertices: np.ndarray, triangles: np.ndarray, colors: np.ndarray | None = None) -> None:
    """Write a triangle mesh as binary little-endian PLY (float32 xyz, uint8 rgb, ``uchar`` count + ``int`` indices).

    Examples
    --------
    >>> import tempfile, os
    >>> d = tempfile.mkdtemp()
    >>> write_mesh_ply(os.path.join(d, "m.ply"), np.eye(3), np.array([[0, 1, 2]]))
    >>> with open(os.path.join(d, "m.ply"), "rb") as f:
    ...     f.read().split(b"end_header")[0].decode().splitlines()[2:]
    ['element vertex 3', 'property float x', 'property float y', 'property float z', 'element face 1', 'property list uchar int vertex_indices']
    """
    V = np.asarray(vertices, np.float32).reshape(-1, 3)
    F = np.asarray(triangles, np.int64).reshape(-1, 3)
    if len(F) and (F.min() < 0 or F.max() >= len(V)):
        raise ValueError(f"triangles: expected vertex indices in [0, {len(V)}) (got {int(F.min())}..{int(F.max())})")
    vfields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
    header = ["ply", "format binary_little_endian 1.0", f"element vertex {len(V)}", "property float x", "property float y", "property float z"]
    if colors is not None:
        vfields += [("red", "u1"), ("green", "u1"), ("blue", "u1")]
        header += ["property uchar red", "property uchar green", "property uchar blue"]
    header += [f"element face {len(F)}", "property list uchar int vertex_indices", "end_header"]
    vrec = np.empty(len(V), dtype=vfields)
    vrec["x"], vrec["y"], vrec["z"] = V.T
    if colors is not None:
        c = np.asarray(colors, np.uint8).reshape(-1, 3)
        vrec["red"], vrec["green"], vrec["blue"] = c.T
    frec = np.empty(len(F), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    frec["n"] = 3
    frec["i"] = F
    with open(path, "wb") as f:
        f.write(("\n".join(header) + "\n").encode("ascii"))
        f.write(vrec.tobytes())
        f.write(frec.tobytes())


def write_objects(
    folder: str | os.PathLike[str],
    scene: Scene,
    result: Result,
    *,
    meshes: bool | None = None,
    method: str = "tsdf",
    voxel_size: float | None = None,
) -> dict[str, Any]:
    """Write ``objects.json`` and ``objects/NNN_mesh.ply`` into the existing folder ``folder``; return the JSON document.

    Parameters
    ----------
    folder : path-like
        An output folder being built (no safety checks here: see :mod:`graphseg.output`).
    scene, result
        The lifted scene and its result.
    meshes : bool or None, keyword-only
        None: fuse meshes when open3d imports and every view has a pose,
        intrinsics and a point map (else ``mesh: null`` and ``mesh_note`` says
        why); True: require them (raise otherwise); False: no meshes.
    method : {"tsdf", "poisson"}, keyword-only
    voxel_size : float, optional, keyword-only
        See :func:`fuse_mesh`.

    Returns
    -------
    dict
        The document written (see the module docstring).

    Examples
    --------
    >>> import tempfile, json, os
    >>> from graphseg.method.segment import segment
    >>> from graphseg.testing.scenes import two_boxes_scene
    >>> scene, masks, matches = two_boxes_scene()
    >>> d = tempfile.mkdtemp()
    >>> doc = write_objects(d, scene, segment(scene, masks, matches), meshes=False)
    >>> with open(os.path.join(d, "objects.json")) as f:
    ...     json.load(f)["objects"][1]["mesh"], doc["mesh_note"]
    (None, 'meshes not asked for')
    """
    if method not in MESH_METHODS:
        raise ValueError(f"unknown mesh method {method!r}; choose one of {', '.join(MESH_METHODS)}")
    folder = Path(folder)
    objs = object_geometry(scene, result)
    note: str | None = None
    o3d = None
    if meshes is False:
        note = "meshes not asked for"
    else:
        missing = [v.name for v in scene.views if v.K is None or v.cam_to_world is None or v.points is None]
        if missing:
            note = f"no mesh: view {missing[0]} has no pose, intrinsics or point map"
            if meshes:
                raise ValueError(note)
        else:
            try:
                o3d = load_open3d()
            except MissingDependencyError as err:
                if meshes:
                    raise
                note = f"no mesh: {err}"
    depths = camera_depths(scene) if o3d is not None and method == "tsdf" and objs else None
    for o in objs:
        o["mesh"] = None
        if o3d is None:
            continue
        try:
            mesh = fuse_mesh(scene, result, o["id"], method=method, voxel_size=voxel_size, depths=depths)
        except RuntimeError as err:  # open3d's own errors: the object gets no mesh, the run keeps its output
            o["mesh_note"] = f"fusion failed: {str(err).splitlines()[0] if str(err) else type(err).__name__}"
            continue
        V, F, C = canonical_mesh(mesh)
        if len(F) == 0:
            o["mesh_note"] = "too few points for a surface"
            continue
        rel = f"objects/{o['id']:03d}_mesh.ply"
        (folder / "objects").mkdir(parents=True, exist_ok=True)
        write_mesh_ply(folder / rel, V, F, C)
        o["mesh"] = rel
        o["mesh_vertices"] = len(V)
        o["mesh_triangles"] = len(F)
    doc = {
        "kind": "graphseg-objects",
        "version": 1,
        "frame": "world",
        "units": "m",
        "method": method if o3d is not None else None,
        "voxel_size": voxel_size,
        "open3d": getattr(o3d, "__version__", None),
        "mesh_note": note,
        "objects": objs,
    }
    (folder / OBJECTS_FILE).write_text(json.dumps(doc, indent=1, ensure_ascii=True), encoding="utf-8")
    return doc
