"""Precomputed model outputs as inputs: a matches folder and a point-map folder.

Models such as SAM, RoMa, DUSt3R, MASt3R or VGGT are often run elsewhere (on a
GPU machine); their outputs enter graphseg through three folders (the
``precomputed`` segmenter reads the masks folder with :func:`read_masks`):

::

    MASKS/VIEW.png             a label image, 8- or 16-bit (0 = no mask, k = mask k), or
    MASKS/VIEW.npz             masks bool [K, H, W] (one boolean mask per entry, may overlap)
    MATCHES/VIEWI__VIEWJ.npz   xy_i float [M, 2], xy_j float [M, 2], certainty float [M] (optional,
                               default 1), view_i / view_j str (optional), image_size_i /
                               image_size_j int [2] = (H, W) the coordinates refer to (optional)
    POINTS/VIEW.npz            points float [h, w, 3] world frame (NaN = invalid), confidence
                               float [h, w] (optional), K [3, 3] and cam_to_world [4, 4] (optional)

File names
    ``encode_name(view)`` keeps ``A-Z a-z 0-9 . -`` and single inner underscores
    and percent-encodes every other byte (UTF-8), so an encoded name never
    contains ``__`` nor starts or ends with ``_``: ``VIEWI__VIEWJ`` splits in
    exactly one way, for any view name. A matches file may also carry the two
    names as ``view_i`` / ``view_j`` strings, which then win over its file name.
    Pixel coordinates are ``(x, y)`` = (column, row) of the scene's images.
Resize rule
    A point map of another size ``(h, w)`` than the image ``(H, W)`` is resized
    by nearest neighbour with pixel centres aligned: image pixel ``(x, y)``
    takes source pixel ``(floor((x + 0.5) w / W), floor((y + 0.5) h / H))``;
    ``K`` is scaled the same way (``fx' = fx W / w``, ``cx' = (cx + 0.5) W / w - 0.5``,
    likewise in y). Matches whose ``image_size`` differs from the image are
    scaled with the same centre-aligned rule. The point map must cover the whole
    image (undo any crop of the model's input before saving).

Every problem raises :class:`~graphseg.scene.SceneError` naming the file and the
field; array sizes are read from the ``.npy`` headers and checked before any
array is loaded; nothing is unpickled.

Examples
--------
>>> import tempfile, numpy as np
>>> encode_name("view_01"), encode_name("a__b/c"), decode_name("a%5F%5Fb%2Fc")
('view_01', 'a%5F%5Fb%2Fc', 'a__b/c')
>>> with tempfile.TemporaryDirectory() as d:
...     _ = write_point_map(d, "v", np.zeros((2, 3, 3), np.float32))
...     read_point_map(d, "v", (4, 6)).points.shape
(4, 6, 3)
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from urllib.parse import unquote

import numpy as np

from ..scene import Matches, Scene, SceneError, is_rigid
from .files import NpzFile, npz_headers

__all__ = [
    "write_masks",
    "read_masks",
    "encode_name",
    "decode_name",
    "pair_file_name",
    "PointMap",
    "read_point_map",
    "read_point_map_file",
    "write_point_map",
    "apply_point_maps",
    "read_pair_matches",
    "peek_pair_names",
    "read_matches_folder",
    "write_matches_folder",
    "write_point_maps",
    "save_inputs",
    "resize_nearest",
    "scale_intrinsics",
    "MAX_ELEMENTS",
]

#: Largest array (number of elements) any precomputed file may hold.
MAX_ELEMENTS = 400_000_000
_SAFE = re.compile(r"[A-Za-z0-9.\-]")


def encode_name(name: str) -> str:
    """The file-name stem of a view name (see the module docstring; injective).

    Examples
    --------
    >>> encode_name("_x_"), encode_name("000")
    ('%5Fx%5F', '000')
    """
    out = []
    n = len(name)
    for k, ch in enumerate(name):
        if _SAFE.fullmatch(ch):
            out.append(ch)
        elif ch == "_" and 0 < k < n - 1 and name[k - 1] != "_" and name[k + 1] != "_":
            out.append(ch)
        else:
            out.append("".join(f"%{b:02X}" for b in ch.encode("utf-8", "surrogatepass")))
    return "".join(out)


def decode_name(stem: str) -> str:
    """Inverse of :func:`encode_name`.

    Examples
    --------
    >>> decode_name(encode_name("é v/1")) == "é v/1"
    True
    """
    return unquote(stem)


def pair_file_name(view_i: str, view_j: str) -> str:
    """``encode_name(view_i) + "__" + encode_name(view_j) + ".npz"``.

    Examples
    --------
    >>> pair_file_name("000", "001")
    '000__001.npz'
    """
    return f"{encode_name(view_i)}__{encode_name(view_j)}.npz"


# ----------------------------------------------------------------------------- npz reading
def _npz_headers(path: Path) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
    """Shapes and dtypes of the arrays of an ``.npz`` read from their headers (nothing loaded; :func:`~graphseg.io.files.npz_headers`)."""
    return npz_headers(path)


def _check(headers: Mapping[str, tuple[tuple[int, ...], np.dtype]], key: str, where: str, *, ndim: int, last: int | None = None, kind: str = "fiu") -> tuple[int, ...]:
    shape, dtype = headers[key]
    if len(shape) != ndim or (last is not None and shape[-1] != last):
        want = {1: "[M]", 2: "[M, 2]" if last == 2 else "[H, W]", 3: "[H, W, 3]"}.get(ndim, f"{ndim} dims")
        if key in ("K", "cam_to_world"):
            want = "[3, 3]" if key == "K" else "[4, 4]"
        raise SceneError(f"expected shape {want} (got {list(shape)})", where=where, field=key)
    if dtype.kind not in kind:
        raise SceneError(f"expected numbers (got dtype {dtype})", where=where, field=key)
    if int(np.prod(shape, dtype=np.int64)) > MAX_ELEMENTS:
        raise SceneError(f"too large ({list(shape)}; at most {MAX_ELEMENTS} elements)", where=where, field=key)
    return shape


def _load(path: Path, keys: Sequence[str]) -> dict[str, np.ndarray]:
    with NpzFile(path) as z:
        return z.read(keys)


def _finite(arr: np.ndarray, where: str, field: str, *, allow_nan: bool = False) -> np.ndarray:
    bad = np.isinf(arr) if allow_nan else ~np.isfinite(arr)
    if bad.any():
        raise SceneError("contains inf" if allow_nan else "contains NaN or inf", where=where, field=field)
    return arr


def _string(z: Mapping[str, np.ndarray], key: str, where: str) -> str | None:
    if key not in z:
        return None
    a = z[key]
    if a.dtype.kind != "U" or a.size != 1:
        raise SceneError("expected a single string", where=where, field=key)
    return str(a.reshape(-1)[0])


# ----------------------------------------------------------------------------- resizing
def resize_nearest(arr: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Nearest-neighbour resize of ``[h, w, ...]`` to ``[H, W, ...]`` with pixel centres aligned.

    Image pixel ``(x, y)`` takes source pixel ``(floor((x + 0.5) w / W), floor((y + 0.5) h / H))``.
    O(H W).

    Examples
    --------
    >>> resize_nearest(np.array([[1, 2]]), (2, 4)).tolist()
    [[1, 1, 2, 2], [1, 1, 2, 2]]
    """
    h, w = arr.shape[:2]
    H, W = shape
    if (h, w) == (H, W):
        return arr
    ys = np.minimum(((np.arange(H) + 0.5) * h / H).astype(np.int64), h - 1)
    xs = np.minimum(((np.arange(W) + 0.5) * w / W).astype(np.int64), w - 1)
    return arr[ys[:, None], xs[None, :]]


def scale_intrinsics(K: np.ndarray, src: tuple[int, int], dst: tuple[int, int]) -> np.ndarray:
    """``K`` of an ``src = (h, w)`` image expressed for ``dst = (H, W)`` (pixel centres aligned).

    Examples
    --------
    >>> scale_intrinsics(np.array([[10.0, 0, 1.5], [0, 10, 0.5], [0, 0, 1]]), (2, 4), (4, 8))[:2].tolist()
    [[20.0, 0.0, 3.5], [0.0, 20.0, 1.5]]
    """
    sy, sx = dst[0] / src[0], dst[1] / src[1]
    S = np.array([[sx, 0, 0.5 * sx - 0.5], [0, sy, 0.5 * sy - 0.5], [0, 0, 1]])
    return S @ np.asarray(K, np.float64)


def _scale_xy(xy: np.ndarray, src: tuple[int, int], dst: tuple[int, int]) -> np.ndarray:
    if tuple(src) == tuple(dst):
        return xy
    s = np.array([dst[1] / src[1], dst[0] / src[0]], np.float64)
    return ((xy.astype(np.float64) + 0.5) * s - 0.5).astype(np.float32)


# ----------------------------------------------------------------------------- point maps
@dataclass
class PointMap:
    """One view's precomputed point map, already at the image size.

    Attributes
    ----------
    points : float32 ``[H, W, 3]`` world frame, NaN = invalid
    confidence : float32 ``[H, W]`` or None
    K : float64 ``[3, 3]`` or None (scaled to the image size)
    cam_to_world : float64 ``[4, 4]`` or None
    source_shape : ``(h, w)`` of the file
    """

    points: np.ndarray
    confidence: np.ndarray | None
    K: np.ndarray | None
    cam_to_world: np.ndarray | None
    source_shape: tuple[int, int]


def read_point_map(folder: str | os.PathLike[str], view: str, shape: tuple[int, int]) -> PointMap:
    """Read ``FOLDER/encode_name(view).npz`` and resize it to ``shape = (H, W)``.

    Raises
    ------
    SceneError
        Missing file, missing/misshaped/non-finite arrays, a non-rigid pose.

    Notes
    -----
    O(H W); sizes are checked from the headers before loading.
    """
    path = Path(folder) / f"{encode_name(view)}.npz"
    if not path.is_file():
        raise SceneError(f"no point map for view {view!r}", where=str(path), field="points")
    return read_point_map_file(path, shape)


def read_point_map_file(path: str | os.PathLike[str], shape: tuple[int, int]) -> PointMap:
    """Read one point-map ``.npz`` file and resize it to ``shape = (H, W)`` (see :func:`read_point_map`)."""
    path = Path(path)
    where = str(path)
    if not path.is_file():
        raise SceneError("no such file", where=where, field="points")
    hd = _npz_headers(path)
    if "points" not in hd:
        raise SceneError("missing array 'points' [H, W, 3]", where=where, field="points")
    h, w, _ = _check(hd, "points", where, ndim=3, last=3, kind="f")
    if h < 1 or w < 1:
        raise SceneError(f"empty point map ({[h, w, 3]})", where=where, field="points")
    if "confidence" in hd:
        cs = _check(hd, "confidence", where, ndim=2)
        if cs != (h, w):
            raise SceneError(f"expected [{h}, {w}] like points (got {list(cs)})", where=where, field="confidence")
    for key, n in (("K", 3), ("cam_to_world", 4)):
        if key in hd and hd[key][0] != (n, n):
            raise SceneError(f"expected shape [{n}, {n}] (got {list(hd[key][0])})", where=where, field=key)
        if key in hd and hd[key][1].kind not in "fiu":
            raise SceneError(f"expected numbers (got dtype {hd[key][1]})", where=where, field=key)
    z = _load(path, ["points", "confidence", "K", "cam_to_world"])
    pts = _finite(np.asarray(z["points"], np.float32), where, "points", allow_nan=True)
    conf = None
    if "confidence" in z:
        conf = np.asarray(z["confidence"], np.float32)
        if np.isinf(conf).any() or (conf < 0).any():
            raise SceneError("expected finite values >= 0 (NaN = invalid)", where=where, field="confidence")
    K = T = None
    if "K" in z:
        K = _finite(np.asarray(z["K"], np.float64), where, "K")
        if K[0, 0] <= 0 or K[1, 1] <= 0:
            raise SceneError("focal lengths must be positive", where=where, field="K")
        K = scale_intrinsics(K, (h, w), shape)
    if "cam_to_world" in z:
        T = _finite(np.asarray(z["cam_to_world"], np.float64), where, "cam_to_world")
        if not is_rigid(T):
            raise SceneError("not a rigid transform (rotation must be orthonormal with det +1, last row 0 0 0 1)", where=where, field="cam_to_world")
    pts = np.ascontiguousarray(resize_nearest(pts, shape))
    if conf is not None:
        conf = np.ascontiguousarray(resize_nearest(conf, shape))
    return PointMap(pts, conf, K, T, (h, w))


def write_point_map(
    folder: str | os.PathLike[str],
    view: str,
    points: np.ndarray,
    confidence: np.ndarray | None = None,
    *,
    K: np.ndarray | None = None,
    cam_to_world: np.ndarray | None = None,
) -> Path:
    """Write one view's point map as ``FOLDER/encode_name(view).npz`` (float32, compressed)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    pts = np.asarray(points, np.float32)
    if pts.ndim != 3 or pts.shape[2] != 3:
        raise ValueError(f"expected points of shape [H, W, 3] (got {list(pts.shape)})")
    arrays: dict[str, np.ndarray] = {"points": pts}
    if confidence is not None:
        arrays["confidence"] = np.asarray(confidence, np.float32)
    if K is not None:
        arrays["K"] = np.asarray(K, np.float64)
    if cam_to_world is not None:
        arrays["cam_to_world"] = np.asarray(cam_to_world, np.float64)
    path = folder / f"{encode_name(view)}.npz"
    np.savez_compressed(path, **arrays)  # type: ignore[arg-type]
    return path


def apply_point_maps(scene: Scene, folder: str | os.PathLike[str]) -> Scene:
    """The scene with every view's ``points`` (and ``confidence``, ``K``, ``cam_to_world``) from ``folder``.

    A file's ``K`` / ``cam_to_world`` replace the view's (they share the point
    map's frame); without them the view keeps its own. Every view needs a file.
    """
    views = []
    for v in scene.views:
        pm = read_point_map(folder, v.name, v.shape)
        views.append(
            v.replace(
                points=pm.points,
                confidence=pm.confidence,
                K=pm.K if pm.K is not None else v.K,
                cam_to_world=pm.cam_to_world if pm.cam_to_world is not None else v.cam_to_world,
            )
        )
    return Scene(views, dict(scene.objects), scene.name, {**scene.meta, "points": str(folder)})


def write_point_maps(folder: str | os.PathLike[str], scene: Scene) -> list[Path]:
    """Write every view's ``points`` / ``confidence`` / ``K`` / ``cam_to_world`` (views need points)."""
    out = []
    for v in scene.views:
        if v.points is None:
            raise SceneError("no point map to save (run a lifter first)", where=v.name, field="points")
        out.append(write_point_map(folder, v.name, v.points, v.confidence, K=v.K, cam_to_world=v.cam_to_world))
    return out


# ----------------------------------------------------------------------------- matches
def _split_pair(stem: str, where: str) -> tuple[str, str]:
    parts = stem.split("__")
    if len(parts) != 2 or not parts[0] or not parts[1]:
        raise SceneError("expected a file name VIEWI__VIEWJ.npz with encoded view names (or view_i / view_j arrays inside)", where=where, field="name")
    return decode_name(parts[0]), decode_name(parts[1])


def read_pair_matches(path: str | os.PathLike[str], shapes: tuple[tuple[int, int], tuple[int, int]] | None = None) -> tuple[str, str, Matches]:
    """Read one matches file; returns ``(view_i, view_j, Matches)``.

    ``shapes`` = the two images' ``(H, W)``: coordinates given for another
    ``image_size_i`` / ``image_size_j`` are rescaled to them.
    """
    path = Path(path)
    where = str(path)
    hd = _npz_headers(path)
    for key in ("xy_i", "xy_j"):
        if key not in hd:
            raise SceneError(f"missing array {key!r} [M, 2]", where=where, field=key)
    m = _check(hd, "xy_i", where, ndim=2, last=2)[0]
    if _check(hd, "xy_j", where, ndim=2, last=2)[0] != m:
        raise SceneError(f"expected [{m}, 2] like xy_i (got {list(hd['xy_j'][0])})", where=where, field="xy_j")
    if "certainty" in hd and _check(hd, "certainty", where, ndim=1)[0] != m:
        raise SceneError(f"expected [{m}] like xy_i (got {list(hd['certainty'][0])})", where=where, field="certainty")
    for key in ("image_size_i", "image_size_j"):
        if key in hd and (hd[key][0] != (2,) or hd[key][1].kind not in "iu"):
            raise SceneError(f"expected int [2] = (H, W) (got {hd[key][1]} {list(hd[key][0])})", where=where, field=key)
    z = _load(path, ["xy_i", "xy_j", "certainty", "view_i", "view_j", "image_size_i", "image_size_j"])
    vi, vj = _string(z, "view_i", where), _string(z, "view_j", where)
    if vi is None or vj is None:
        vi, vj = _split_pair(path.stem, where)
    xy_i = _finite(np.asarray(z["xy_i"], np.float32), where, "xy_i")
    xy_j = _finite(np.asarray(z["xy_j"], np.float32), where, "xy_j")
    cert = np.ones(m, np.float32) if "certainty" not in z else _finite(np.asarray(z["certainty"], np.float32), where, "certainty")
    if shapes is not None:
        for key, xy, shape in (("image_size_i", xy_i, shapes[0]), ("image_size_j", xy_j, shapes[1])):
            if key in z:
                src = tuple(int(s) for s in z[key])
                if min(src) < 1:
                    raise SceneError(f"expected a positive (H, W) (got {list(src)})", where=where, field=key)
                xy[...] = _scale_xy(xy, src, shape)  # type: ignore[arg-type]
    return vi, vj, Matches(xy_i, xy_j, cert)


def read_matches_folder(folder: str | os.PathLike[str], scene: Scene) -> dict[tuple[int, int], Matches]:
    """Matches ``{(i, j): Matches}`` (``i < j``, scene order) for the scene's views from a folder.

    Files naming a view the scene does not have are skipped (a view selection);
    a pair stored as ``(j, i)`` is swapped. Two files for one pair are an error.
    """
    root = Path(folder)
    if not root.is_dir():
        raise SceneError("no such folder", where=str(root), field="matches")
    index = {v.name: k for k, v in enumerate(scene.views)}
    shapes = [v.shape for v in scene.views]
    out: dict[tuple[int, int], Matches] = {}
    seen: dict[tuple[int, int], Path] = {}
    for path in sorted(root.glob("*.npz")):
        vi, vj = peek_pair_names(path)
        if vi not in index or vj not in index:
            continue
        i, j = index[vi], index[vj]
        if i == j:
            raise SceneError(f"matches of view {vi!r} with itself", where=str(path), field="name")
        _, _, m = read_pair_matches(path, (shapes[i], shapes[j]))
        if i > j:
            i, j, m = j, i, Matches(m.xy_j, m.xy_i, m.certainty)
        if (i, j) in seen:
            raise SceneError(f"a second file for the pair ({vi!r}, {vj!r}) (first: {seen[(i, j)].name})", where=str(path), field="name")
        seen[(i, j)] = path
        out[(i, j)] = m
    return dict(sorted(out.items()))


def peek_pair_names(path: str | os.PathLike[str]) -> tuple[str, str]:
    """The ``(view_i, view_j)`` names of a matches file (stored strings, else its file name)."""
    path = Path(path)
    hd = _npz_headers(path)
    if "view_i" in hd and "view_j" in hd:
        for key in ("view_i", "view_j"):
            if hd[key][1].kind != "U" or int(np.prod(hd[key][0], dtype=np.int64)) != 1 or hd[key][1].itemsize > 4096:
                raise SceneError("expected a single string", where=str(path), field=key)
        z = _load(path, ["view_i", "view_j"])
        return str(z["view_i"].reshape(-1)[0]), str(z["view_j"].reshape(-1)[0])
    return _split_pair(path.stem, str(path))


def write_matches_folder(folder: str | os.PathLike[str], scene: Scene, matches: Mapping[tuple[int, int], Matches]) -> list[Path]:
    """Write ``matches`` keyed by view indices of ``scene`` as ``VIEWI__VIEWJ.npz`` files.

    Each file also stores ``view_i`` / ``view_j`` and the image sizes.
    """
    root = Path(folder)
    root.mkdir(parents=True, exist_ok=True)
    names: dict[str, tuple[int, int]] = {}
    out = []
    for (i, j), m in matches.items():
        vi, vj = scene.views[i].name, scene.views[j].name
        fname = pair_file_name(vi, vj)
        if fname.lower() in names:
            raise ValueError(f"pairs {names[fname.lower()]} and {(i, j)} map to one file name {fname!r} (case-insensitive)")
        names[fname.lower()] = (i, j)
        path = root / fname
        np.savez_compressed(
            path,
            xy_i=m.xy_i,
            xy_j=m.xy_j,
            certainty=m.certainty,
            view_i=np.array(vi),
            view_j=np.array(vj),
            image_size_i=np.array(scene.views[i].shape, np.int64),
            image_size_j=np.array(scene.views[j].shape, np.int64),
        )
        out.append(path)
    return out


# ----------------------------------------------------------------------------- masks
def write_masks(folder: str | os.PathLike[str], name: str, masks: list[np.ndarray] | np.ndarray) -> Path:
    """Write one view's masks: a label image as 16-bit ``NAME.png``, a list/stack of bool masks as ``NAME.npz``.

    Parameters
    ----------
    folder : path
        Created if missing.
    name : str
        File stem (``encode_name(view)`` for a view name with other characters).
    masks : int ``[H, W]`` label image (values in ``[0, 65535]``) or bool ``[K, H, W]`` / list of ``[H, W]``

    Returns
    -------
    Path
        The file written.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as d:
    ...     write_masks(d, "v", [np.eye(2, dtype=bool)]).name, read_masks(d, "v")[0].tolist()
    ('v.npz', [[True, False], [False, True]])
    """
    import cv2

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    arr = masks if isinstance(masks, np.ndarray) else np.stack([np.asarray(m, bool) for m in masks])
    if arr.ndim == 2:
        if arr.min(initial=0) < 0 or arr.max(initial=0) >= 2**16:
            raise ValueError("label images must hold values in [0, 65535]")
        path = folder / f"{name}.png"
        cv2.imwrite(str(path), arr.astype(np.uint16))
    else:
        path = folder / f"{name}.npz"
        np.savez_compressed(path, masks=arr.astype(bool))
    return path


def read_masks(folder: str | os.PathLike[str], name: str) -> np.ndarray | list[np.ndarray]:
    """Read ``NAME.npz`` (key ``masks``, bool ``[K, H, W]``) or ``NAME.png`` (label image).

    ``name`` is a view name or its file stem (:func:`encode_name`, as
    :func:`save_inputs` writes it).

    Returns
    -------
    int32 ``[H, W]`` label image, or list of bool ``[H, W]`` masks

    Raises
    ------
    SceneError
        Naming the file and the field ``masks``: no file, an unreadable,
        oversized or tampered ``.npz`` (sizes are checked before loading), or
        arrays of the wrong shape or dtype.
    """
    folder = Path(folder)
    if not any((folder / f"{name}{s}").is_file() for s in (".npz", ".png")):
        name = encode_name(name)  # names saved by save_inputs
    npz, png = folder / f"{name}.npz", folder / f"{name}.png"
    if npz.exists():
        with NpzFile(npz) as z:  # the zip-bomb and size rules of every .npz graphseg reads
            if "masks" not in z:
                raise SceneError("expected a 'masks' array", where=str(npz), field="masks")
            arr = z["masks"]
        if arr.ndim != 3 or arr.dtype.kind not in "biu":
            raise SceneError(f"expected bool [K, H, W] (got {arr.dtype} {list(arr.shape)})", where=str(npz), field="masks")
        if not len(arr):  # no masks: an all-zero label image of the same size
            return np.zeros(arr.shape[1:], np.int32)
        return list(arr.astype(bool))
    if png.exists():
        from .images import read_label

        return read_label(png, field="masks")  # pixel budget, clean errors, no OpenCV log lines
    raise SceneError(f"no masks for view {name!r} ({npz.name} or {png.name})", where=str(folder), field="masks")


def save_inputs(
    folder: str | os.PathLike[str],
    scene: Scene,
    masks: Sequence[Any] | None = None,
    matches: Mapping[tuple[int, int], Matches] | None = None,
) -> dict[str, Path]:
    """Save a run's model outputs as ``FOLDER/masks``, ``FOLDER/matches`` and ``FOLDER/points``.

    ``scene`` is the lifted scene (with point maps); ``masks`` / ``matches`` as
    given to :func:`graphseg.segment`. Running on the scene's RGB images with
    these three folders reproduces the run exactly (see
    :func:`graphseg.pipeline.prepare`).

    Returns
    -------
    dict
        ``{"masks": PATH, "matches": PATH, "points": PATH}`` for what was written.
    """
    root = Path(folder)
    out: dict[str, Path] = {}
    if any(v.points is not None for v in scene.views):
        write_point_maps(root / "points", scene)
        out["points"] = root / "points"
    if masks is not None:
        if len(masks) != scene.num_views:
            raise ValueError(f"expected one mask set per view ({scene.num_views}) (got {len(masks)})")
        for v, m in zip(scene.views, masks):
            if isinstance(m, np.ndarray) and m.ndim == 2 and m.dtype.kind in "iu" and m.max(initial=0) >= 2**16:
                m = [m == k for k in np.unique(m) if k != 0]
            if isinstance(m, list) and not m:
                m = np.zeros(v.shape, np.int32)
            write_masks(root / "masks", encode_name(v.name), m)
        out["masks"] = root / "masks"
    if matches is not None:
        write_matches_folder(root / "matches", scene, matches)
        out["matches"] = root / "matches"
    return out

