"""Image helpers shared by the backends of every kind: a view's uint8 RGB, grey, ImageNet normalisation, CIE Lab.

The model adapters (``sam2``, ``loftr``, ``roma``, ``dinov2``, ``da3``) read a
view's colour image with :func:`view_rgb` and normalise it with
:data:`IMAGENET_MEAN` / :data:`IMAGENET_STD`; the classical ``flow`` and
``sift`` matchers work on :func:`gray`.

Examples
--------
>>> import numpy as np
>>> from graphseg.scene import View
>>> rgb = view_rgb(View("a", np.full((2, 3, 3), 0.5, np.float32)))
>>> rgb.dtype.name, int(rgb[0, 0, 0])
('uint8', 127)
>>> gray(np.zeros((2, 3, 3), np.uint8)).shape
(2, 3)
"""

from __future__ import annotations

import numpy as np

from ..scene import SceneError, View

__all__ = ["IMAGENET_MEAN", "IMAGENET_STD", "view_rgb", "gray", "to_lab", "checked_rgb8"]

#: Per-channel RGB mean and standard deviation (0..1 scale) of ImageNet, as the models were trained.
IMAGENET_MEAN = (0.485, 0.456, 0.406)
IMAGENET_STD = (0.229, 0.224, 0.225)


def view_rgb(view: View) -> np.ndarray:
    """The view's image as uint8 ``[H, W, 3]`` (float images in 0..1 are scaled by 255).

    Raises :class:`~graphseg.scene.SceneError` naming the view when the image is
    not ``[H, W, 3]``. O(H W).
    """
    rgb = np.asarray(view.rgb)
    if rgb.ndim != 3 or rgb.shape[2] != 3:
        raise SceneError(f"expected rgb of shape [H, W, 3] (got {list(rgb.shape)})", where=view.name, field="rgb")
    if rgb.dtype != np.uint8:
        rgb = np.clip(rgb * (255.0 if rgb.max() <= 1.0 else 1.0), 0, 255).astype(np.uint8)
    return rgb


def checked_rgb8(image: np.ndarray, shape: tuple[int, ...], where: str) -> np.ndarray:
    """``image`` as an array, checked to be uint8 ``[H, W, 3]`` with ``(H, W) == shape``; a ValueError names ``where`` otherwise.

    The label-image steps after segmentation (:func:`graphseg.method.trim.trim_rims`,
    :func:`graphseg.method.grow.grow_rims`) read colours with it. O(1).

    Examples
    --------
    >>> checked_rgb8(np.zeros((2, 3, 3), np.uint8), (2, 3), "view 0").shape
    (2, 3, 3)
    """
    im = np.asarray(image)
    if im.shape[:2] != tuple(shape) or im.ndim != 3 or im.shape[2] != 3:
        raise ValueError(f"{where}: expected an image of shape [{shape[0]}, {shape[1]}, 3] (got {list(im.shape)})")
    if im.dtype != np.uint8:
        raise ValueError(f"{where}: expected a uint8 image (got {im.dtype})")
    return im


def gray(rgb: np.ndarray) -> np.ndarray:
    """uint8 RGB ``[H, W, 3]`` -> uint8 grey ``[H, W]`` (OpenCV's ``COLOR_RGB2GRAY`` weights). O(H W)."""
    import cv2

    return cv2.cvtColor(np.ascontiguousarray(rgb), cv2.COLOR_RGB2GRAY)


def to_lab(rgb: np.ndarray, blur: float = 0.0) -> np.ndarray:
    """uint8 RGB ``[H, W, 3]`` -> uint8 CIE Lab ``[H, W, 3]`` (OpenCV's 8-bit scaling), after a Gaussian blur of ``blur`` pixels (0: none).

    The colour tests of the ``reprojection`` matcher and of the ``sfm``
    lifter's point transfer compare these. O(H W).

    Examples
    --------
    >>> to_lab(np.full((2, 2, 3), 255, np.uint8))[0, 0].tolist()
    [255, 128, 128]
    """
    import cv2

    im = np.ascontiguousarray(rgb, dtype=np.uint8)
    if blur > 0:
        im = np.asarray(cv2.GaussianBlur(im, (0, 0), blur))
    return np.asarray(cv2.cvtColor(im, cv2.COLOR_RGB2LAB))
