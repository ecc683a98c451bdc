"""The ``da3`` lifter: Depth Anything 3 (any-view model) from the user's checkpoint.

Each image is resized as Depth Anything 3's own ``inference`` does by default
(``process_res_method="upper_bound_resize"``, :func:`resize_for_da3`) and
normalised with ImageNet statistics (RGB). One forward pass over all N views
gives per-view depth, depth confidence, extrinsics (world-to-camera) and
intrinsics at the model's input size; they
become world point maps ``c2w * backproject(depth, K)``, resized to the images by
the documented nearest-neighbour rule (:mod:`graphseg.io.precomputed`), and
:func:`graphseg.backends.lifters.align.finish_lift` brings them to metres (known camera
poses, else the nominal working distance).

The network is built from the package's own registry config
(``depth_anything_3.registry.MODEL_REGISTRY[model]``) with ``create_object``;
graphseg never imports ``depth_anything_3.api`` (it needs moviepy) and never
downloads. Install: ``pip install "graphseg[da3]"`` then
``pip install --no-deps depth-anything-3==0.1.1`` (its declared dependencies
would pull torchvision and opencv-python).

Examples
--------
>>> model_size_14((480, 640), 504)
(378, 504)
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from ...registry import TORCH_CPU, MissingDependencyError
from ...scene import Scene, SceneError, backproject
from ..imaging import IMAGENET_MEAN, IMAGENET_STD
from ..options import ModelBackend
from .align import Alignment, lift_from_alignment

__all__ = ["DA3Lifter", "load_da3", "model_size_14", "resize_for_da3", "INSTALL"]

INSTALL = 'pip install "graphseg[da3]" && pip install --no-deps depth-anything-3==0.1.1'
_MEAN = np.array(IMAGENET_MEAN, np.float32)
_STD = np.array(IMAGENET_STD, np.float32)


def _bound_size(shape: tuple[int, int], size: int) -> tuple[int, int]:
    h, w = shape
    if max(h, w) == size:
        return h, w
    s = size / max(h, w)
    return max(1, int(round(h * s))), max(1, int(round(w * s)))


def _nearest_14(x: int) -> int:
    down = x // 14 * 14
    return max(14, down + 14 if down + 14 - x <= x - down else down)  # ties go up, as DA3's


def model_size_14(shape: tuple[int, int], size: int) -> tuple[int, int]:
    """``(h, w)`` of the model input: DA3's ``upper_bound_resize`` size rule.

    The long side is scaled to ``size`` (each side rounded to an integer), then
    each side goes to its nearest multiple of DA3's patch size 14 (ties up; at
    least 14).

    Examples
    --------
    >>> model_size_14((720, 1280), 504)  # 283.5 -> 284 -> 280
    (280, 504)
    """
    h, w = _bound_size(shape, size)
    return _nearest_14(h), _nearest_14(w)


def resize_for_da3(rgb: np.ndarray, size: int) -> np.ndarray:
    """``rgb`` at :func:`model_size_14` as DA3's ``InputProcessor`` makes it (``upper_bound_resize``).

    Two OpenCV resizes, as there: the long side to ``size`` (cubic when
    enlarging, else area), then each side to its multiple of 14 (cubic when
    either side grows, else area).
    """
    import cv2

    rgb = np.ascontiguousarray(rgb)
    h, w = rgb.shape[:2]
    bh, bw = _bound_size((h, w), size)
    if (bh, bw) != (h, w):
        rgb = cv2.resize(rgb, (bw, bh), interpolation=cv2.INTER_CUBIC if size > max(h, w) else cv2.INTER_AREA)
    th, tw = _nearest_14(bh), _nearest_14(bw)
    if (th, tw) != (bh, bw):
        rgb = cv2.resize(rgb, (tw, th), interpolation=cv2.INTER_CUBIC if th > bh or tw > bw else cv2.INTER_AREA)
    return rgb


def _import(module: str) -> Any:
    try:
        return importlib.import_module(module)
    except ImportError as err:
        first = f"{TORCH_CPU} && " if module.split(".")[0] == "torch" else ""
        raise MissingDependencyError(f"the da3 lifter needs {module!r} ({err}): {first}{INSTALL}; checkpoint: --backend-option da3.checkpoint=PATH") from err


def load_da3(model: str, checkpoint: str | Path | None = None) -> Any:
    """Build the DA3 network ``model`` (e.g. ``"da3-small"``) and load ``checkpoint`` (strict).

    ``checkpoint``: a ``.safetensors`` file (the Hugging Face ``model.safetensors``)
    or a torch file of a state dict (optionally under ``"state_dict"`` / ``"model"``);
    a leading ``model.`` on every key (the Hub wrapper's) is removed. None
    keeps random weights (tests, benchmarks).
    """
    _import("torch")
    for dep in ("addict", "einops", "omegaconf"):
        _import(dep)
    cfg_mod = _import("depth_anything_3.cfg")
    registry = _import("depth_anything_3.registry")
    if model not in registry.MODEL_REGISTRY:
        raise SceneError(f"unknown DA3 model {model!r}; choose one of {', '.join(registry.MODEL_REGISTRY)}", where="da3", field="model")
    import contextlib
    import io
    import logging

    with contextlib.redirect_stdout(io.StringIO()):  # DA3's logger prints to stdout
        net = cfg_mod.create_object(cfg_mod.load_config(registry.MODEL_REGISTRY[model]))
    logging.getLogger("depth_anything_3").setLevel(logging.WARNING)
    if checkpoint is not None:
        from ..weights import load_state_dict_file

        path = Path(checkpoint)
        state = load_state_dict_file(path, "da3", field="checkpoint", strip_prefix="model.")
        try:
            missing, unexpected = net.load_state_dict(state, strict=False)
        except RuntimeError as err:  # size mismatches
            missing, unexpected = [str(err).splitlines()[1].strip() if len(str(err).splitlines()) > 1 else str(err)], []
        if missing or unexpected:
            raise SceneError(
                f"does not match {model} ({len(missing)} missing keys, e.g. {missing[:2]}; {len(unexpected)} unexpected, e.g. {unexpected[:2]}); "
                "set --backend-option da3.model=NAME to the checkpoint's model",
                where=str(path),
                field="checkpoint",
            )
    return net.eval()


class DA3Lifter(ModelBackend):
    """The ``da3`` lifter (options: :class:`DA3Lifter.Options`)."""

    name = "da3"
    extra = "da3"

    class Options(BaseModel):
        model_config = ConfigDict(extra="forbid")
        checkpoint: str | None = Field(None, description="model.safetensors or a torch state-dict file")
        model: str = Field("da3-small", description="DA3 registry config: da3-small, da3-base, da3-large, da3-giant, ...")
        size: int = Field(504, ge=14, description="long side of the model input (pixels, multiple of 14)")
        min_conf: float = Field(0.0, ge=0, description="pixels below this depth confidence are left invalid")
        scale: Literal["auto", "nominal", "none"] = "auto"
        use_ray_pose: bool = Field(False, description="DA3's ray-based pose head instead of the camera decoder")
        random_weights: bool = Field(False, description="testing and benchmarks only: no checkpoint, random weights")
        threads: int | None = Field(None, ge=1, description="torch CPU threads")

    def __init__(self, options: Any = None, /, **kwargs: Any) -> None:
        super().__init__(options, **kwargs)
        opts = self.options
        if opts.checkpoint is None and not opts.random_weights:
            raise SceneError(f"no checkpoint given; set --backend-option da3.checkpoint=PATH; {INSTALL}", where="da3", field="checkpoint")
        if opts.checkpoint is not None and not Path(opts.checkpoint).is_file():
            raise SceneError(f"no such file; set --backend-option da3.checkpoint=PATH; {INSTALL}", where=str(opts.checkpoint), field="checkpoint")
        self.net = load_da3(opts.model, opts.checkpoint)

    def predict(self, rgbs: list[np.ndarray], hw: tuple[int, int]) -> dict[str, np.ndarray]:
        """Raw DA3 outputs for uint8 RGB images: ``depth``, ``conf`` ``[N, h, w]``, ``extrinsics`` ``[N, 3, 4]`` (w2c), ``intrinsics`` ``[N, 3, 3]``.

        ``hw``: the model input size; images for which it is :func:`model_size_14`
        of option ``size`` are resized by :func:`resize_for_da3`, others straight to ``hw``.
        """
        import cv2
        import torch

        def resize(r: np.ndarray) -> np.ndarray:
            if model_size_14(r.shape[:2], self.options.size) == tuple(hw):
                return resize_for_da3(r, self.options.size)
            grow = hw[0] > r.shape[0] or hw[1] > r.shape[1]
            return cv2.resize(np.ascontiguousarray(r), (hw[1], hw[0]), interpolation=cv2.INTER_CUBIC if grow else cv2.INTER_AREA)

        x = np.stack([(resize(r).astype(np.float32) / 255.0 - _MEAN) / _STD for r in rgbs])
        t = torch.from_numpy(x.transpose(0, 3, 1, 2).copy())[None]
        import contextlib
        import io

        threads = torch.get_num_threads()
        if self.options.threads:
            torch.set_num_threads(self.options.threads)
        try:
            with torch.inference_mode(), contextlib.redirect_stdout(io.StringIO()):
                out = self.net(t, use_ray_pose=self.options.use_ray_pose)
        finally:
            torch.set_num_threads(threads)
        return {
            "depth": out["depth"][0].float().numpy(),
            "conf": out["depth_conf"][0].float().numpy(),
            "extrinsics": out["extrinsics"][0].double().numpy(),
            "intrinsics": out["intrinsics"][0].double().numpy(),
        }

    def __call__(self, scene: Scene) -> Scene:
        hw = model_size_14(scene.views[0].shape, self.options.size)
        raw = self.predict([v.rgb for v in scene.views], hw)
        n = scene.num_views
        c2w = np.tile(np.eye(4), (n, 1, 1))
        pts, conf = [], []
        for k in range(n):
            w2c = np.eye(4)
            w2c[:3] = raw["extrinsics"][k]
            T = np.linalg.inv(w2c)
            U, _, Vt = np.linalg.svd(T[:3, :3])  # exact rotation (float32 network output)
            T[:3, :3] = U @ np.diag([1.0, 1.0, np.linalg.det(U @ Vt)]) @ Vt
            c2w[k] = T
            d = raw["depth"][k].astype(np.float32)
            c = raw["conf"][k].astype(np.float32)
            d = np.where(np.isfinite(d) & (c >= self.options.min_conf), d, np.float32(0))
            pts.append(backproject(d, raw["intrinsics"][k], T))
            conf.append(np.where(d > 0, c, np.float32(0)))
        al = Alignment(points=pts, confidence=conf, cam_to_world=c2w, K=raw["intrinsics"].copy(), info={})
        if not all(np.isfinite(p).any() for p in pts):
            raise SceneError("DA3 gave no valid depth for some view (check the checkpoint and --backend-option da3.model)", where=scene.name, field="points")
        return lift_from_alignment(scene, al, hw, scale=self.options.scale, lifter=self.name)
