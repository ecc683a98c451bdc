"""The ``dust3r`` lifter: a user-exported DUSt3R (or MASt3R) ONNX encoder/decoder pair.

Pipeline: every view is encoded once; every selected pair ``(i, j)`` and its
mirror ``(j, i)`` are decoded into both views' point maps in the frame of the
first view, with confidences; :func:`graphseg.backends.align.global_align`
aligns them (maximum-confidence spanning tree, Procrustes, refinement) and
:func:`graphseg.backends.align.finish_lift` brings the result to metres (known
camera poses, else the nominal working distance).

The ONNX interface (names are defaults; map others with ``names``):

encoder ``encoder.onnx``
    inputs ``image`` float32 ``[1, 3, h, w]`` (RGB scaled to ``[-1, 1]``, as
    DUSt3R's ``ImgNorm``) and optionally ``true_shape`` int64 ``[1, 2]``;
    outputs ``features`` ``[1, T, D]`` and optionally ``pos`` int64 ``[1, T, 2]``.
decoder ``decoder.onnx``
    inputs ``features1``, ``pos1``, ``features2``, ``pos2`` and optionally
    ``true_shape1`` / ``true_shape2``; outputs ``pts3d1`` ``[1, h, w, 3]``,
    ``conf1`` ``[1, h, w]`` (view 1 in its own frame) and ``pts3d2``, ``conf2``
    (view 2 in view 1's frame: DUSt3R's ``pts3d_in_other_view``).

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

from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from ..registry import MissingDependencyError, require
from ..scene import Scene, SceneError
from .align import PairPointMaps, global_align, lift_from_alignment
from .dino import patch_grid

__all__ = ["DUSt3RLifter", "ROLES", "preprocess", "model_size"]

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


def model_size(shape: tuple[int, int], size: int, patch: int) -> tuple[int, int]:
    """``(h, w)`` with the long side near ``size`` and both multiples of ``patch``, keeping the aspect.

    Examples
    --------
    >>> model_size((480, 640), 512, 16)
    (384, 512)
    """
    return patch_grid(shape, size, patch)


def preprocess(rgb: np.ndarray, hw: tuple[int, int]) -> np.ndarray:
    """uint8 ``[H, W, 3]`` -> float32 ``[1, 3, h, w]`` in ``[-1, 1]`` (area resize)."""
    import cv2

    img = cv2.resize(np.ascontiguousarray(rgb), (hw[1], hw[0]), interpolation=cv2.INTER_AREA)
    return ((img.astype(np.float32) / 255.0 - 0.5) / 0.5).transpose(2, 0, 1)[None].copy()


class DUSt3RLifter:
    """The ``dust3r`` lifter (options: :class:`DUSt3RLifter.Options`)."""

    name = "dust3r"

    class Options(BaseModel):
        model_config = ConfigDict(extra="forbid")
        encoder: str | None = Field(None, description="path to the encoder .onnx")
        decoder: str | None = Field(None, description="path to the decoder .onnx (default: decoder.onnx next to the encoder)")
        size: int = Field(512, ge=16, description="long side of the model input (pixels), when the ONNX input size is dynamic")
        patch_size: int = Field(16, ge=1)
        names: dict[str, str] = Field(default_factory=dict, description="role -> ONNX tensor name overrides (roles: ROLES)")
        pair_mode: Literal["all", "pose"] = Field("all", description="'pose': only pairs with close known poses (graphseg.method.pairs)")
        iterations: int = Field(10, ge=0, description="refinement rounds of the global alignment")
        min_conf: float = Field(0.0, ge=0, description="pixels below this confidence are ignored and left invalid (DUSt3R's viewer uses 3)")
        scale: Literal["auto", "nominal", "none"] = "auto"
        threads: int | None = Field(None, ge=1, description="onnxruntime intra-op threads")
        seed: int | None = 0

    def __init__(self, **options: Any) -> None:
        self.options = opts = self.Options(**options)
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
        except MissingDependencyError as err:
            raise MissingDependencyError(f"{err} (the dust3r lifter runs --backend-option dust3r.encoder=PATH with onnxruntime)") from err
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
    def _encode(self, rgb: np.ndarray, hw: tuple[int, int]) -> dict[str, np.ndarray]:
        feeds: dict[str, np.ndarray] = {self._role("image"): preprocess(rgb, hw)}
        if self._role("true_shape") in {i.name for i in self.encoder.get_inputs()}:
            feeds[self._role("true_shape")] = np.array([hw], np.int64)
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
                feeds[self._role("true_shape" + k)] = np.array([hw], np.int64)
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

    def _pairs(self, scene: Scene) -> list[tuple[int, int]]:
        from ..method.pairs import scene_scale, select_pairs

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
        shape = scene.views[0].shape
        hw = self.fixed_hw or model_size(shape, self.options.size, self.options.patch_size)
        feats = [self._encode(v.rgb, hw) for v in scene.views]
        maps = []
        for i, j in self._pairs(scene):
            for a, b in ((i, j), (j, i)):
                p1, c1, p2, c2 = self._decode(feats[a], feats[b], hw)
                maps.append(PairPointMaps(a, b, p1, p2, c1, c2))
        al = global_align(maps, n, iterations=self.options.iterations, min_conf=self.options.min_conf, rng=self.options.seed)
        return lift_from_alignment(scene, al, hw, scale=self.options.scale, lifter=self.name)
