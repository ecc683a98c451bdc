"""The ``dust3r`` lifter: a user-exported DUSt3R (or MASt3R) ONNX encoder/decoder pair.

Pipeline: every view is encoded once; every selected pair ``(i, j)`` and its
mirror ``(j, i)`` are decoded into both views' point maps in the frame of the
first view, with confidences; :func:`graphseg.backends.lifters.align.global_align`
aligns them (maximum-confidence spanning tree, Procrustes, refinement) and
:func:`graphseg.backends.lifters.align.finish_lift` brings the result to metres (known
camera poses, else the nominal working distance).

The ONNX interface (names are defaults; map others with ``names``):

encoder ``encoder.onnx``
    inputs ``image`` float32 ``[1, 3, h, w]`` (RGB scaled to ``[-1, 1]``, as
    DUSt3R's ``ImgNorm``) and optionally ``true_shape`` ``[1, 2]`` = ``(h, w)``
    (int64, or the integer type the model declares);
    outputs ``features`` ``[1, T, D]`` and optionally ``pos`` int64 ``[1, T, 2]``.
decoder ``decoder.onnx``
    inputs ``features1``, ``pos1``, ``features2``, ``pos2`` and optionally
    ``true_shape1`` / ``true_shape2``; outputs ``pts3d1`` ``[1, h, w, 3]``,
    ``conf1`` ``[1, h, w]`` (view 1 in its own frame) and ``pts3d2``, ``conf2``
    (view 2 in view 1's frame: DUSt3R's ``pts3d_in_other_view``).

Every image becomes the model input as DUSt3R's ``load_images`` makes it
(:func:`input_geometry`, :func:`preprocess`): its long side resized to ``size``
with Pillow (Lanczos when shrinking, bicubic otherwise), then a centre crop to
multiples of ``patch_size`` (a square image to 4:3 unless ``square_ok``; ``size``
224: short side to 224 and a centre square). The point maps come back to the
image by nearest neighbour through the same resize and crop (:func:`uncrop`);
pixels the crop cut off are invalid (NaN, confidence 0). A model with a fixed
input size gets the same rule when it gives that size, else the image is
resized to cover the input and centre-cropped.

No weights ship with graphseg; ``docs/models.md`` shows how to export them.

Examples
--------
>>> try:
...     DUSt3RLifter()
... except Exception as err:
...     print(str(err).split(";")[0])
dust3r: encoder: no checkpoint given
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from ...registry import MissingDependencyError, require
from ...scene import Scene, SceneError
from ..options import ModelBackend
from .align import PairPointMaps, finish_lift, global_align

__all__ = ["DUSt3RLifter", "ROLES", "InputGeometry", "input_geometry", "model_size", "preprocess", "uncrop"]

#: Tensor roles and their default ONNX names.
ROLES = {
    "image": "image",
    "true_shape": "true_shape",
    "features": "features",
    "pos": "pos",
    "features1": "features1",
    "pos1": "pos1",
    "features2": "features2",
    "pos2": "pos2",
    "true_shape1": "true_shape1",
    "true_shape2": "true_shape2",
    "pts3d1": "pts3d1",
    "conf1": "conf1",
    "pts3d2": "pts3d2",
    "conf2": "conf2",
}
_HINT = 'pip install "graphseg[dust3r]"; export the model as in docs/models.md'
_INT_TYPES = {"tensor(int64)": "int64", "tensor(int32)": "int32"}


@dataclass(frozen=True)
class InputGeometry:
    """How an image of size ``shape`` becomes the model input.

    The image is resized to ``resized`` ``(H', W')``, then the model input
    ``hw`` ``(h, w)`` is cut from it at row ``top``, column ``left``.
    """

    shape: tuple[int, int]
    resized: tuple[int, int]
    top: int
    left: int
    hw: tuple[int, int]


def _centre_crop(shape: tuple[int, int], resized: tuple[int, int], half: tuple[float, float]) -> InputGeometry:
    """The crop box ``(cx - half_w, cy - half_h, cx + half_w, cy + half_h)`` with ``c = (W' // 2, H' // 2)``, rounded as Pillow's ``crop`` rounds."""
    cy, cx = resized[0] // 2, resized[1] // 2
    y0, y1 = int(round(cy - half[0])), int(round(cy + half[0]))
    x0, x1 = int(round(cx - half[1])), int(round(cx + half[1]))
    return InputGeometry(shape, resized, y0, x0, (y1 - y0, x1 - x0))


def input_geometry(shape: tuple[int, int], size: int = 512, patch: int = 16, *, fixed: tuple[int, int] | None = None, square_ok: bool = False) -> InputGeometry:
    """The resize and centre crop DUSt3R's ``load_images`` applies to an image of ``shape = (H, W)``.

    Parameters
    ----------
    shape : (int, int)
        Image height and width.
    size : int
        ``load_images``' ``size``: the long side is resized to it (``round(side * size / max(H, W))``);
        224 resizes the short side to 224 instead and crops a centre square.
    patch : int
        The crop keeps ``(2 (W' // 2)) // patch * patch`` columns (rows likewise), centred at ``W' // 2``.
    fixed : (int, int), optional
        A model's fixed input ``(h, w)``: the rule above with ``size = max(h, w)`` when it gives
        ``(h, w)``; else the image is resized (aspect kept) to just cover ``(h, w)`` and centre-cropped.
    square_ok : bool
        False (DUSt3R's default): a square resized image is cropped to 4:3 (``h = 3 w / 4``).

    Returns
    -------
    InputGeometry

    Raises
    ------
    ValueError
        If the image is too small to give one patch.

    Notes
    -----
    O(1).

    Examples
    --------
    >>> g = input_geometry((333, 500), 512)  # 500x333 -> 512x341 -> crop 512x336 from row 2
    >>> g.resized, g.top, g.left, g.hw
    ((341, 512), 2, 0, (336, 512))
    >>> input_geometry((480, 640), fixed=(384, 512)).hw
    (384, 512)
    """
    H, W = (int(shape[0]), int(shape[1]))
    if H < 1 or W < 1:
        raise ValueError(f"expected an image shape (H, W) >= 1 (got {tuple(shape)})")
    if fixed is not None:
        hf, wf = int(fixed[0]), int(fixed[1])
        try:
            g: InputGeometry | None = input_geometry((H, W), max(hf, wf), patch, square_ok=square_ok)
        except ValueError:
            g = None
        if g is not None and g.hw == (hf, wf):
            return g
        s = max(hf / H, wf / W)
        resized = (max(hf, int(round(H * s))), max(wf, int(round(W * s))))
        return _centre_crop((H, W), resized, (hf / 2, wf / 2))
    S = max(H, W)
    long = int(round(size * max(W / H, H / W))) if size == 224 else size
    resized = (int(round(H * long / S)), int(round(W * long / S)))
    cy, cx = resized[0] // 2, resized[1] // 2
    if size == 224:
        half = (float(min(cx, cy)), float(min(cx, cy)))
    else:
        half = ((2 * cy) // patch * patch / 2, (2 * cx) // patch * patch / 2)
        if not square_ok and resized[0] == resized[1]:
            half = (3 * half[1] / 4, half[1])
    g = _centre_crop((H, W), resized, half)
    if min(g.hw) < 1:
        raise ValueError(f"image {H}x{W} is too small for the model input (size {size}, patch {patch})")
    return g


def model_size(shape: tuple[int, int], size: int, patch: int) -> tuple[int, int]:
    """The model input ``(h, w)`` of an image of ``shape`` (:func:`input_geometry`'s ``hw``).

    Examples
    --------
    >>> model_size((480, 640), 512, 16)
    (384, 512)
    >>> model_size((512, 512), 512, 16)  # DUSt3R crops square images to 4:3
    (384, 512)
    """
    return input_geometry(shape, size, patch).hw


def preprocess(rgb: np.ndarray, geometry: InputGeometry) -> np.ndarray:
    """uint8 RGB ``[H, W, 3]`` -> float32 ``[1, 3, h, w]`` in ``[-1, 1]``, as DUSt3R's ``load_images``.

    Pillow resize to ``geometry.resized`` (Lanczos when the long side shrinks, bicubic
    otherwise), crop at ``(top, left)`` to ``geometry.hw``, then ``x / 255`` normalised with
    mean 0.5 and std 0.5 (``ImgNorm``). O(H W).

    Examples
    --------
    >>> rgb = np.zeros((6, 8, 3), np.uint8); rgb[..., 0] = 255
    >>> x = preprocess(rgb, input_geometry((6, 8), 16, 4))
    >>> x.shape, float(x[0, 0].min()), float(x[0, 1].max())
    ((1, 3, 12, 16), 1.0, -1.0)
    """
    Image = require("PIL.Image", "dust3r")
    rgb = np.asarray(rgb)
    if rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.dtype != np.uint8:
        raise ValueError(f"expected uint8 RGB [H, W, 3] (got {rgb.dtype} {list(rgb.shape)})")
    if tuple(rgb.shape[:2]) != tuple(geometry.shape):
        raise ValueError(f"expected an image of {list(geometry.shape)} (got {list(rgb.shape[:2])})")
    img = Image.fromarray(np.ascontiguousarray(rgb), "RGB")
    (Hr, Wr), (h, w) = geometry.resized, geometry.hw
    if (Hr, Wr) != tuple(rgb.shape[:2]):
        img = img.resize((Wr, Hr), Image.LANCZOS if max(rgb.shape[:2]) > max(Hr, Wr) else Image.BICUBIC)
    arr = np.asarray(img)[geometry.top : geometry.top + h, geometry.left : geometry.left + w]
    if arr.shape[:2] != (h, w):
        raise ValueError(f"crop {h}x{w} at ({geometry.top}, {geometry.left}) does not fit the resized {Hr}x{Wr} image")
    return ((arr.astype(np.float32) / np.float32(255.0) - np.float32(0.5)) / np.float32(0.5)).transpose(2, 0, 1)[None].copy()


def uncrop(arr: np.ndarray, geometry: InputGeometry, fill: float = np.nan) -> np.ndarray:
    """A model-input map ``[h, w, ...]`` at the image size ``[H, W, ...]``: nearest neighbour, ``fill`` outside the crop.

    Image pixel ``(x, y)`` takes resized pixel ``(floor((x + 0.5) W' / W), floor((y + 0.5) H' / H))``,
    minus the crop offset. O(H W).

    Examples
    --------
    >>> g = InputGeometry((2, 3), (2, 6), 0, 1, (2, 4))  # 3 columns -> 6 -> columns 1..4 kept
    >>> uncrop(np.arange(8.0).reshape(2, 4), g, fill=-1).tolist()  # x -> floor(2 x + 1) - 1
    [[0.0, 2.0, -1.0], [4.0, 6.0, -1.0]]
    """
    arr = np.asarray(arr)
    (H, W), (Hr, Wr), (h, w) = geometry.shape, geometry.resized, geometry.hw
    if arr.shape[:2] != (h, w):
        raise ValueError(f"expected a map of {[h, w]} (got {list(arr.shape[:2])})")
    ys = np.minimum(((np.arange(H) + 0.5) * Hr / H).astype(np.int64), Hr - 1) - geometry.top
    xs = np.minimum(((np.arange(W) + 0.5) * Wr / W).astype(np.int64), Wr - 1) - geometry.left
    oky, okx = (ys >= 0) & (ys < h), (xs >= 0) & (xs < w)
    out = np.full((H, W, *arr.shape[2:]), fill, dtype=np.result_type(arr.dtype, np.float32))
    out[np.ix_(oky, okx)] = arr[np.ix_(ys[oky], xs[okx])]
    return out


def _intrinsics_to_image(K: np.ndarray, geometry: InputGeometry) -> np.ndarray:
    """``K`` of the model input expressed for the image (crop offset, then the resize; pixel centres aligned)."""
    from ...io.precomputed import scale_intrinsics

    shift = np.array([[1.0, 0, geometry.left], [0, 1, geometry.top], [0, 0, 1]])
    return scale_intrinsics(shift @ np.asarray(K, np.float64), geometry.resized, geometry.shape)


class DUSt3RLifter(ModelBackend):
    """The ``dust3r`` lifter (options: :class:`DUSt3RLifter.Options`)."""

    name = "dust3r"
    extra = "dust3r"

    class Options(BaseModel):
        model_config = ConfigDict(extra="forbid")
        encoder: str | None = Field(None, description="path to the encoder .onnx")
        decoder: str | None = Field(None, description="path to the decoder .onnx (default: decoder.onnx next to the encoder)")
        size: int = Field(512, ge=16, description="long side of the resized image (DUSt3R's load_images size; 224: short side), when the ONNX input size is dynamic")
        patch_size: int = Field(16, ge=1)
        square_ok: bool = Field(False, description="keep square images square (DUSt3R's default crops them to 4:3)")
        names: dict[str, str] = Field(default_factory=dict, description="role -> ONNX tensor name overrides (roles: ROLES)")
        pair_mode: Literal["all", "pose"] = Field("all", description="'pose': only pairs with close known poses (graphseg.geometry.select_pairs)")
        iterations: int = Field(10, ge=0, description="refinement rounds of the global alignment")
        min_conf: float = Field(0.0, ge=0, description="pixels below this confidence are ignored and left invalid (DUSt3R's viewer uses 3)")
        scale: Literal["auto", "nominal", "none"] = "auto"
        threads: int | None = Field(None, ge=1, description="onnxruntime intra-op threads")
        seed: int | None = 0

    def __init__(self, options: Any = None, /, **kwargs: Any) -> None:
        super().__init__(options, **kwargs)
        opts = self.options
        if opts.encoder is None:
            raise SceneError(f"no checkpoint given; set --backend-option dust3r.encoder=PATH (and dust3r.decoder=PATH); {_HINT}", where="dust3r", field="encoder")
        enc = Path(opts.encoder)
        dec = Path(opts.decoder) if opts.decoder else enc.with_name("decoder.onnx")
        for path, field in ((enc, "encoder"), (dec, "decoder")):
            if not path.is_file():
                raise SceneError(f"no such file; set --backend-option dust3r.{field}=PATH; {_HINT}", where=str(path), field=field)
        unknown = sorted(set(opts.names) - set(ROLES))
        if unknown:
            raise SceneError(f"unknown roles {unknown}; choose from {', '.join(ROLES)}", where="dust3r", field="names")
        self.names = {**ROLES, **opts.names}
        try:
            ort = require("onnxruntime", "dust3r")
            require("PIL.Image", "dust3r")  # DUSt3R's resize (Pillow's Lanczos / bicubic)
        except MissingDependencyError as err:
            raise MissingDependencyError(f"{err} (the dust3r lifter runs --backend-option dust3r.encoder=PATH with onnxruntime and Pillow)") from err
        so = ort.SessionOptions()
        if opts.threads:
            so.intra_op_num_threads = opts.threads
        so.log_severity_level = 3
        try:
            self.encoder = ort.InferenceSession(str(enc), so, providers=["CPUExecutionProvider"])
            self.decoder = ort.InferenceSession(str(dec), so, providers=["CPUExecutionProvider"])
        except Exception as err:  # onnxruntime raises its own exception types
            raise SceneError(f"cannot load the ONNX model ({str(err).splitlines()[0]})", where=str(enc), field="encoder") from err
        self._check(enc, dec)

    def _role(self, role: str) -> str:
        return self.names[role]

    def _check(self, enc: Path, dec: Path) -> None:
        ein = {i.name: i for i in self.encoder.get_inputs()}
        eout = {o.name for o in self.encoder.get_outputs()}
        din = {i.name for i in self.decoder.get_inputs()}
        dout = {o.name for o in self.decoder.get_outputs()}
        if self._role("image") not in ein:
            raise SceneError(f"no input {self._role('image')!r} (inputs: {', '.join(ein)}); map it with names.image", where=str(enc), field="image")
        if self._role("features") not in eout:
            raise SceneError(f"no output {self._role('features')!r} (outputs: {', '.join(eout)}); map it with names.features", where=str(enc), field="features")
        for role in ("pts3d1", "conf1", "pts3d2", "conf2"):
            if self._role(role) not in dout:
                raise SceneError(f"no output {self._role(role)!r} (outputs: {', '.join(dout)}); map it with names.{role}", where=str(dec), field=role)
        known = {self._role(r) for r in ("features1", "pos1", "features2", "pos2", "true_shape1", "true_shape2")}
        extra = sorted(din - known)
        if extra:
            raise SceneError(f"unmapped inputs {extra}; map them with names.features1/pos1/features2/pos2/true_shape1/true_shape2", where=str(dec), field="inputs")
        shape = ein[self._role("image")].shape
        self.fixed_hw = (int(shape[2]), int(shape[3])) if len(shape) == 4 and all(isinstance(s, int) for s in shape[2:]) else None

    # ------------------------------------------------------------------ inference
    def geometry(self, shape: tuple[int, int]) -> InputGeometry:
        """The resize and crop an image of ``shape`` gets (:func:`input_geometry` with this model's options)."""
        o = self.options
        return input_geometry(shape, o.size, o.patch_size, fixed=self.fixed_hw, square_ok=o.square_ok)

    def _shape_feed(self, session: Any, name: str, hw: tuple[int, int]) -> np.ndarray:
        kind = next(i.type for i in session.get_inputs() if i.name == name)
        return np.array([hw], _INT_TYPES.get(kind, "int64"))

    def _encode(self, rgb: np.ndarray, geometry: InputGeometry) -> dict[str, np.ndarray]:
        feeds: dict[str, np.ndarray] = {self._role("image"): preprocess(rgb, geometry)}
        if self._role("true_shape") in {i.name for i in self.encoder.get_inputs()}:
            feeds[self._role("true_shape")] = self._shape_feed(self.encoder, self._role("true_shape"), geometry.hw)
        names = [o.name for o in self.encoder.get_outputs()]
        out = dict(zip(names, self.encoder.run(None, feeds)))
        got = {"features": out[self._role("features")]}
        if self._role("pos") in out:
            got["pos"] = out[self._role("pos")]
        return got

    def _decode(self, a: dict[str, np.ndarray], b: dict[str, np.ndarray], hw: tuple[int, int]) -> tuple[np.ndarray, ...]:
        din = {i.name for i in self.decoder.get_inputs()}
        feeds: dict[str, np.ndarray] = {}
        for k, enc in (("1", a), ("2", b)):
            for role in ("features", "pos"):
                if self._role(role + k) in din:
                    if role not in enc:
                        raise SceneError(f"the decoder needs {self._role(role + k)!r} but the encoder gives no {self._role(role)!r}", where="dust3r", field=role)
                    feeds[self._role(role + k)] = enc[role]
            if self._role("true_shape" + k) in din:
                feeds[self._role("true_shape" + k)] = self._shape_feed(self.decoder, self._role("true_shape" + k), hw)
        names = [o.name for o in self.decoder.get_outputs()]
        out = dict(zip(names, self.decoder.run(None, feeds)))
        res = []
        for role, want in (("pts3d1", (*hw, 3)), ("conf1", hw), ("pts3d2", (*hw, 3)), ("conf2", hw)):
            arr = np.asarray(out[self._role(role)], np.float32)
            arr = arr.reshape(arr.shape[1:]) if arr.ndim == len(want) + 1 and arr.shape[0] == 1 else arr
            if arr.shape != want:
                raise SceneError(f"expected [1, {', '.join(map(str, want))}] (got {list(np.shape(out[self._role(role)]))})", where="dust3r decoder", field=role)
            res.append(arr)
        return tuple(res)

    def predict_pair(self, rgb1: np.ndarray, rgb2: np.ndarray) -> dict[str, Any]:
        """DUSt3R's pairwise inference on two uint8 RGB images of one size, at the model input size.

        Returns
        -------
        dict
            ``pts3d1`` ``[h, w, 3]`` (view 1 in its own frame), ``conf1`` ``[h, w]``,
            ``pts3d2``, ``conf2`` (view 2 in view 1's frame: DUSt3R's ``pts3d_in_other_view``)
            and ``geometry`` (:class:`InputGeometry`, the resize and crop both images got).
        """
        g = self.geometry(np.shape(rgb1)[:2])
        if self.geometry(np.shape(rgb2)[:2]) != g:
            raise ValueError(f"expected two images of one size (got {list(np.shape(rgb1)[:2])} and {list(np.shape(rgb2)[:2])})")
        p1, c1, p2, c2 = self._decode(self._encode(rgb1, g), self._encode(rgb2, g), g.hw)
        return {"pts3d1": p1, "conf1": c1, "pts3d2": p2, "conf2": c2, "geometry": g}

    def _pairs(self, scene: Scene) -> list[tuple[int, int]]:
        from ...geometry import scene_scale, select_pairs

        poses = [v.cam_to_world for v in scene.views]
        if self.options.pair_mode == "pose" and all(T is not None for T in poses):
            pairs = select_pairs(poses, mode="pose", scale=scene_scale([None] * len(poses), poses))
        else:
            n = scene.num_views
            pairs = [(i, j) for i in range(n) for j in range(i + 1, n)]
        return pairs

    def __call__(self, scene: Scene) -> Scene:
        n = scene.num_views
        if n < 2:
            raise SceneError("the dust3r lifter needs at least 2 views", where=scene.name, field="views")
        g = self.geometry(scene.views[0].shape)
        for v in scene.views[1:]:
            if self.geometry(v.shape) != g:
                raise SceneError(f"expected every view at {list(g.shape)} (got {list(v.shape)}); the dust3r lifter aligns point maps of one size", where=v.name, field="rgb")
        feats = [self._encode(v.rgb, g) for v in scene.views]
        maps = []
        for i, j in self._pairs(scene):
            for a, b in ((i, j), (j, i)):
                p1, c1, p2, c2 = self._decode(feats[a], feats[b], g.hw)
                maps.append(PairPointMaps(a, b, p1, p2, c1, c2))
        al = global_align(maps, n, iterations=self.options.iterations, min_conf=self.options.min_conf, rng=self.options.seed)
        pts = [uncrop(p, g) for p in al.points]
        conf = [uncrop(c, g, fill=0.0) for c in al.confidence]
        K = np.stack([_intrinsics_to_image(k, g) for k in al.K])
        return finish_lift(scene, pts, conf, al.cam_to_world, K, scale=self.options.scale, lifter=self.name)
