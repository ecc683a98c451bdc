"""Import ``romatch`` (RoMa) where torchvision cannot be imported.

``romatch`` 0.1.2 imports torchvision at module level for three things: the
VGG19-BN layer layout of RoMa's fine CNN encoder (``torchvision.models.vgg19_bn``;
the weights come from the RoMa checkpoint, never from torchvision), and image
transforms used only when images are given as files or PIL images (graphseg
passes tensors). PyPI's torchvision cannot be imported beside the CPU torch
wheel graphseg targets, so :func:`import_romatch` imports romatch with a small
stand-in ``torchvision`` that provides exactly that layer layout and raises on
the transforms. The stand-in lives in ``sys.modules`` only during the import;
a real, working torchvision is used when present.

Examples
--------
>>> layers = vgg19_bn_features()
>>> len(layers), type(layers[0]).__name__, type(layers[6]).__name__
(53, 'Conv2d', 'MaxPool2d')
"""

from __future__ import annotations

import sys
import types
from typing import Any

__all__ = ["import_romatch", "vgg19_bn_features"]

_VGG19: list[Any] = [64, 64, "M", 128, 128, "M", 256, 256, 256, 256, "M", 512, 512, 512, 512, "M", 512, 512, 512, 512, "M"]


def vgg19_bn_features() -> Any:
    """The ``features`` block of VGG19 with batch norm (torchvision's layer order and names), random weights.

    Returns
    -------
    torch.nn.Sequential
        53 layers: (conv 3x3, batch norm, ReLU) per channel entry, max-pool per ``M``.
    """
    from torch import nn

    layers: list[Any] = []
    c = 3
    for v in _VGG19:
        if v == "M":
            layers.append(nn.MaxPool2d(kernel_size=2, stride=2))
        else:
            layers += [nn.Conv2d(c, int(v), kernel_size=3, padding=1), nn.BatchNorm2d(int(v)), nn.ReLU(inplace=True)]
            c = int(v)
    return nn.Sequential(*layers)


class _Unavailable:
    """A transform that can be built (romatch builds some eagerly) but not applied."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        pass

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        raise RuntimeError("torchvision is not available: pass image tensors to romatch, not files or PIL images")


def _stand_in() -> dict[str, types.ModuleType]:
    tv = types.ModuleType("torchvision")
    models = types.ModuleType("torchvision.models")
    vgg = types.ModuleType("torchvision.models.vgg")
    transforms = types.ModuleType("torchvision.transforms")
    functional = types.ModuleType("torchvision.transforms.functional")

    class _Weights:
        IMAGENET1K_V1 = None

    def vgg19_bn(weights: Any = None, **kwargs: Any) -> Any:
        if weights is not None:
            raise RuntimeError("graphseg never downloads torchvision weights")
        return types.SimpleNamespace(features=vgg19_bn_features())

    vgg.VGG19_BN_Weights = _Weights  # type: ignore[attr-defined]
    models.vgg = vgg  # type: ignore[attr-defined]
    models.vgg19_bn = vgg19_bn  # type: ignore[attr-defined]
    for name in ("ToTensor", "Resize", "Normalize", "Compose", "Grayscale"):
        setattr(transforms, name, _Unavailable)
    functional.InterpolationMode = types.SimpleNamespace(BILINEAR="bilinear", BICUBIC="bicubic", NEAREST="nearest")  # type: ignore[attr-defined]
    transforms.functional = functional  # type: ignore[attr-defined]
    tv.models = models  # type: ignore[attr-defined]
    tv.transforms = transforms  # type: ignore[attr-defined]
    return {"torchvision": tv, "torchvision.models": models, "torchvision.models.vgg": vgg, "torchvision.transforms": transforms, "torchvision.transforms.functional": functional}


def _torchvision_works() -> bool:
    if isinstance(sys.modules.get("torchvision"), types.ModuleType) and getattr(sys.modules["torchvision"], "__file__", None):
        return True
    try:
        import torchvision  # noqa: F401
    except Exception:
        for k in [k for k in sys.modules if k == "torchvision" or k.startswith("torchvision.")]:
            del sys.modules[k]
        return False
    return True


def import_romatch() -> Any:
    """Import ``romatch`` (with the stand-in torchvision when the real one cannot be imported).

    Raises
    ------
    MissingDependencyError
        Naming ``graphseg[roma]`` when romatch or one of its imports is missing.
    """
    from ..options import require_backend

    if "romatch" in sys.modules and sys.modules["romatch"] is not None:
        return sys.modules["romatch"]
    if _torchvision_works():
        return require_backend("romatch", "roma", "roma")
    saved = {k: sys.modules.get(k) for k in _stand_in()}
    sys.modules.update(_stand_in())
    try:
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return require_backend("romatch", "roma", "roma")
    finally:
        for k, v in saved.items():
            if v is None:
                sys.modules.pop(k, None)
            else:
                sys.modules[k] = v
