"""Test-only stand-in for the part of torchvision that SAM 2's reference code uses.

PyPI's torchvision cannot be imported beside the CPU torch that graphseg's tests
run on, but ``sam2.sam2_image_predictor`` (through ``sam2.utils.transforms``)
and ``sam2.automatic_mask_generator`` import it at module level. They use:

* ``torchvision.transforms.ToTensor``: HWC ``uint8`` array -> CHW float in 0..1.
* ``torchvision.transforms.Resize((s, s))`` on a CHW float tensor (bilinear,
  ``antialias=True``; the module is put through ``torch.jit.script``).
* ``torchvision.transforms.Normalize(mean, std)``: ``(x - mean) / std`` per channel.
* ``torchvision.ops.boxes.batched_nms`` and ``box_area``.

Each is written here in plain torch from torchvision's documented behaviour
(same ATen calls, same float32 arithmetic), nothing else. :func:`installed`
puts the stand-in into ``sys.modules`` only while the reference modules are
imported and used, then removes it and the ``sam2`` modules that were imported
under it, so that no other test sees a fake ``torchvision``.
"""

from __future__ import annotations

import contextlib
import importlib
import importlib.machinery
import sys
import types
from collections.abc import Iterator
from enum import Enum
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from torch import Tensor, nn

__all__ = ["ToTensor", "Resize", "Normalize", "InterpolationMode", "nms", "batched_nms", "box_area", "installed", "REFERENCE_MODULES"]

# the sam2 modules that import torchvision (directly or through sam2.utils.transforms)
REFERENCE_MODULES = ("sam2.utils.transforms", "sam2.sam2_image_predictor", "sam2.automatic_mask_generator")


# ----------------------------------------------------------------------------- transforms
class InterpolationMode(Enum):
    NEAREST = "nearest"
    BILINEAR = "bilinear"
    BICUBIC = "bicubic"


class ToTensor:
    """HWC (or HW) numpy array / PIL image -> CHW tensor; ``uint8`` is divided by 255 (default float dtype)."""

    def __call__(self, pic: Any) -> Tensor:
        if not isinstance(pic, np.ndarray):
            pic = np.array(pic, copy=True)  # PIL image: HWC (or HW) uint8 for the modes SAM 2 takes
        if pic.ndim not in (2, 3):
            raise ValueError(f"pic should be 2/3 dimensional. Got {pic.ndim} dimensions.")
        if pic.ndim == 2:
            pic = pic[:, :, None]
        img = torch.from_numpy(pic.transpose((2, 0, 1))).contiguous()
        if img.dtype == torch.uint8:
            return img.to(dtype=torch.get_default_dtype()).div(255)
        return img


def _resized_size(h: int, w: int, size: list[int], max_size: int | None) -> list[int]:
    if len(size) == 2:
        return [size[0], size[1]]
    short, long = (w, h) if w <= h else (h, w)
    new_short = size[0]
    new_long = int(new_short * long / short)
    if max_size is not None:
        if max_size <= new_short:
            raise ValueError("max_size must be strictly greater than the requested size")
        if new_long > max_size:
            new_short = int(max_size * new_short / new_long)
            new_long = max_size
    return [new_long, new_short] if w <= h else [new_short, new_long]


def resize(img: Tensor, size: list[int], interpolation: str = "bilinear", max_size: int | None = None, antialias: bool = True) -> Tensor:
    """``torchvision.transforms.functional.resize`` for tensors ``[..., C, H, W]``."""
    h, w = img.shape[-2], img.shape[-1]
    out = _resized_size(h, w, size, max_size)
    if out[0] == h and out[1] == w:
        return img
    if interpolation not in ("bilinear", "bicubic"):
        antialias = False
    squeeze = img.dim() < 4
    if squeeze:
        img = img.unsqueeze(0)
    out_dtype = img.dtype
    out_is_float = img.is_floating_point()
    cast = out_dtype != torch.float32 and out_dtype != torch.float64
    if cast:
        img = img.to(torch.float32)
    if interpolation == "nearest":
        img = F.interpolate(img, size=out, mode=interpolation)
    else:
        img = F.interpolate(img, size=out, mode=interpolation, align_corners=False, antialias=antialias)
    if interpolation == "bicubic" and out_dtype == torch.uint8:
        img = img.clamp(min=0, max=255)
    if squeeze:
        img = img.squeeze(0)
    if cast:
        if not out_is_float:
            img = torch.round(img)
        img = img.to(out_dtype)
    return img


class Resize(nn.Module):
    """``torchvision.transforms.Resize`` on tensors (scriptable)."""

    def __init__(self, size: Any, interpolation: Any = InterpolationMode.BILINEAR, max_size: int | None = None, antialias: bool = True) -> None:
        super().__init__()
        self.size: list[int] = [int(size)] if isinstance(size, int) else [int(s) for s in size]
        self.interpolation: str = interpolation.value if isinstance(interpolation, InterpolationMode) else str(interpolation)
        self.max_size = max_size
        self.antialias: bool = bool(antialias)

    def forward(self, img: Tensor) -> Tensor:
        return resize(img, self.size, self.interpolation, self.max_size, self.antialias)


class Normalize(nn.Module):
    """``torchvision.transforms.Normalize``: ``(x - mean[c]) / std[c]`` on a float ``[..., C, H, W]`` tensor (scriptable)."""

    def __init__(self, mean: list[float], std: list[float], inplace: bool = False) -> None:
        super().__init__()
        self.mean: list[float] = [float(m) for m in mean]
        self.std: list[float] = [float(s) for s in std]
        self.inplace: bool = inplace

    def forward(self, tensor: Tensor) -> Tensor:
        if not tensor.is_floating_point():
            raise TypeError("Input tensor should be a float tensor.")
        if not self.inplace:
            tensor = tensor.clone()
        mean = torch.as_tensor(self.mean, dtype=tensor.dtype, device=tensor.device)
        std = torch.as_tensor(self.std, dtype=tensor.dtype, device=tensor.device)
        if bool((std == 0).any()):
            raise ValueError("std evaluated to zero, leading to division by zero.")
        return tensor.sub_(mean.view(-1, 1, 1)).div_(std.view(-1, 1, 1))


# ----------------------------------------------------------------------------- ops
def box_area(boxes: Tensor) -> Tensor:
    """Area of ``[x1, y1, x2, y2]`` boxes: ``(x2 - x1) * (y2 - y1)`` (ints stay ints, small floats become float32)."""
    if boxes.is_floating_point():
        boxes = boxes if boxes.dtype in (torch.float32, torch.float64) else boxes.float()
    else:
        boxes = boxes if boxes.dtype in (torch.int32, torch.int64) else boxes.int()
    return (boxes[:, 2] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 1])


def nms(boxes: Tensor, scores: Tensor, iou_threshold: float) -> Tensor:
    """``torchvision.ops.nms`` (CPU kernel): greedy, drops boxes with IoU > threshold; kept indices, best score first.

    Boxes are ``[x1, y1, x2, y2]`` with area ``(x2 - x1) (y2 - y1)``; the order
    is ``scores.sort(0, descending=True)`` (the kernel's call, ties as ATen's
    sort leaves them); IoU is computed in the boxes' dtype, and a NaN IoU (two
    empty boxes) suppresses nothing.
    """
    if boxes.dim() != 2 or boxes.size(1) != 4 or scores.dim() != 1 or boxes.size(0) != scores.size(0):
        raise ValueError(f"bad nms input shapes {list(boxes.shape)} and {list(scores.shape)}")
    if boxes.dtype != scores.dtype:
        raise RuntimeError("dets should have the same type as scores")
    if boxes.numel() == 0:
        return torch.empty(0, dtype=torch.int64, device=boxes.device)
    x1, y1, x2, y2 = (boxes[:, k].contiguous() for k in range(4))
    areas = (x2 - x1) * (y2 - y1)
    order = scores.sort(0, descending=True)[1]
    n = boxes.size(0)
    suppressed = torch.zeros(n, dtype=torch.bool)
    keep: list[int] = []
    zero = torch.zeros((), dtype=boxes.dtype)
    for pos in range(n):
        i = int(order[pos])
        if suppressed[i]:
            continue
        keep.append(i)
        rest = order[pos + 1 :]
        rest = rest[~suppressed[rest]]
        if rest.numel() == 0:
            continue
        w = torch.maximum(zero, torch.minimum(x2[i], x2[rest]) - torch.maximum(x1[i], x1[rest]))
        h = torch.maximum(zero, torch.minimum(y2[i], y2[rest]) - torch.maximum(y1[i], y1[rest]))
        inter = w * h
        ovr = inter / (areas[i] + areas[rest] - inter)
        suppressed[rest[ovr > iou_threshold]] = True
    return torch.tensor(keep, dtype=torch.int64, device=boxes.device)


def batched_nms(boxes: Tensor, scores: Tensor, idxs: Tensor, iou_threshold: float) -> Tensor:
    """``torchvision.ops.batched_nms``: NMS within each category ``idxs``; kept indices, best score first.

    Like torchvision: up to 4000 box coordinates, boxes of different categories
    are shifted apart by ``idxs * (max coordinate + 1)`` and one NMS runs;
    above that, NMS runs per category and the kept indices are sorted by score.
    """
    if boxes.numel() > 4000:
        keep_mask = torch.zeros_like(scores, dtype=torch.bool)
        for c in torch.unique(idxs):
            cur = torch.where(idxs == c)[0]
            keep_mask[cur[nms(boxes[cur], scores[cur], iou_threshold)]] = True
        kept = torch.where(keep_mask)[0]
        return kept[scores[kept].sort(descending=True)[1]]
    if boxes.numel() == 0:
        return torch.empty((0,), dtype=torch.int64, device=boxes.device)
    max_coordinate = boxes.max()
    offsets = idxs.to(boxes) * (max_coordinate + torch.tensor(1).to(boxes))
    return nms(boxes + offsets[:, None], scores, iou_threshold)


# ----------------------------------------------------------------------------- install
def _module(name: str, **attrs: Any) -> types.ModuleType:
    mod = types.ModuleType(name)
    mod.__spec__ = importlib.machinery.ModuleSpec(name, None)
    mod.__file__ = None  # not a real torchvision (graphseg.backends.matchers.romatch_compat checks __file__)
    for k, v in attrs.items():
        setattr(mod, k, v)
    return mod


def _stand_in() -> dict[str, types.ModuleType]:
    fns = {"resize": resize, "InterpolationMode": InterpolationMode}
    functional = _module("torchvision.transforms.functional", **fns)
    transforms = _module("torchvision.transforms", ToTensor=ToTensor, Resize=Resize, Normalize=Normalize, InterpolationMode=InterpolationMode, functional=functional)
    boxes = _module("torchvision.ops.boxes", nms=nms, batched_nms=batched_nms, box_area=box_area)
    ops = _module("torchvision.ops", nms=nms, batched_nms=batched_nms, box_area=box_area, boxes=boxes)
    tv = _module("torchvision", transforms=transforms, ops=ops, __version__="0.0.0+graphseg-test-standin")
    return {m.__name__: m for m in (tv, transforms, functional, ops, boxes)}


@contextlib.contextmanager
def installed() -> Iterator[dict[str, types.ModuleType]]:
    """Import SAM 2's reference modules with the stand-in torchvision; undo everything on exit.

    Yields ``{module name: module}`` for :data:`REFERENCE_MODULES`. On exit the
    stand-in and those modules leave ``sys.modules`` (and their parent
    packages' attributes); a real torchvision, if one was imported, is put back.
    """
    names = list(_stand_in()) + list(REFERENCE_MODULES)
    saved = {k: sys.modules[k] for k in names if k in sys.modules}
    for k in REFERENCE_MODULES:  # imported before with a real torchvision: import again with the stand-in
        sys.modules.pop(k, None)
    sys.modules.update(_stand_in())
    try:
        yield {k: importlib.import_module(k) for k in REFERENCE_MODULES}
    finally:
        for k in names:
            sys.modules.pop(k, None)
        for k in names:  # parent packages point at the submodules they had before (or none)
            parent, _, child = k.rpartition(".")
            if parent not in sys.modules:
                continue
            if k in saved:
                setattr(sys.modules[parent], child, saved[k])
            else:
                with contextlib.suppress(AttributeError):
                    delattr(sys.modules[parent], child)
        sys.modules.update(saved)
