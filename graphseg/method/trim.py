"""Rim trimming: object pixels at a label's border that look like the background beside them go back to it.

Depth estimated from images (stereo, the plane fill, a transferred point) runs
over the silhouette of an object: a band of table pixels one to a few pixels
wide gets the object's depth ("foreground fattening"), passes the background
step and is labelled with the object. Measured depth has no such band.
:func:`trim_rims` looks at every labelled pixel within ``rim`` pixels of an
unlabelled one and compares its colour with two local means: that of the
unlabelled pixels in a ``window`` around it, and that of the labelled pixels
deeper inside the objects (more than ``rim`` pixels from any unlabelled one) in
a window three times as wide. A pixel closer in colour to the unlabelled side
loses its label. Pixels between two objects are not touched (neither side is
unlabelled).

Examples
--------
>>> import numpy as np
>>> rgb = np.zeros((12, 12, 3), np.uint8); rgb[:, 6:] = 200   # a bright object on the right half
>>> lab = np.zeros((12, 12), np.int32); lab[:, 4:] = 1         # labelled two columns too far left
>>> out, info = trim_rims([lab], [rgb], window=5, rim=3, blur=0.0)
>>> out[0][0].tolist(), info["trimmed"]
([0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1], 24)
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..backends.imaging import checked_rgb8, to_lab

__all__ = ["trim_rims"]


def trim_rims(
    labels: Sequence[np.ndarray], images: Sequence[np.ndarray | None], *, window: int = 7, rim: int = 3, blur: float = 1.0, min_pixels: int = 3
) -> tuple[list[np.ndarray], dict[str, Any]]:
    """Unlabel border pixels whose colour is closer to the unlabelled pixels beside them than to the objects' interior.

    Parameters
    ----------
    labels : list of int ``[H, W]``
        Object ids per view (0 = none).
    images : list of uint8 ``[H, W, 3]`` or None
        RGB per view (None: that view is left as it is).
    window : int
        Side (pixels, odd) of the window whose unlabelled pixels give the
        background colour; the interior colour comes from a window ``3 *
        window`` wide.
    rim : int
        Only labelled pixels at most this far (Euclidean, pixels) from an
        unlabelled pixel are tested; the interior is the labelled pixels
        farther than that.
    blur : float
        Gaussian blur (pixels) of the image before the CIE Lab colours are read
        (:func:`graphseg.backends.imaging.to_lab`, OpenCV's 8-bit scaling).
    min_pixels : int
        A pixel is tested only when both windows hold at least this many pixels
        of their kind.

    Returns
    -------
    labels : list of int ``[H, W]``
        New arrays (the inputs are not modified).
    info : dict
        ``trimmed``: pixels unlabelled over all views; ``per_view``: the same per view.

    Notes
    -----
    One pass, O(H W) per view (box filters and one distance transform). The
    interior mean mixes every object near the pixel, not only its own: a rim
    between two objects' interiors is compared with both.
    """
    from scipy import ndimage

    if len(labels) != len(images):
        raise ValueError(f"expected one image per label image (got {len(labels)} labels and {len(images)} images)")
    if window < 1 or rim < 1 or min_pixels < 1:
        raise ValueError(f"expected window, rim and min_pixels >= 1 (got {window}, {rim}, {min_pixels})")
    if window % 2 == 0:
        raise ValueError(f"expected an odd window, so that it is centred on the pixel (got {window})")
    out: list[np.ndarray] = []
    per_view: list[int] = []
    near, far = (window, window), (3 * window, 3 * window)
    for v, (lab_in, rgb) in enumerate(zip(labels, images)):
        lab = np.array(lab_in, copy=True)
        if rgb is None:
            out.append(lab)
            per_view.append(0)
            continue
        im = checked_rgb8(rgb, lab.shape, f"view {v}")
        obj = lab > 0
        if not obj.any() or obj.all():
            out.append(lab)
            per_view.append(0)
            continue
        lab_col = to_lab(im, blur).astype(np.float32)
        depth_in = ndimage.distance_transform_edt(obj)
        cand = obj & (depth_in <= rim)
        bg = (~obj).astype(np.float32)
        core = (obj & (depth_in > rim)).astype(np.float32)

        m_bg, n_bg = _local_mean(lab_col, bg, near)
        m_in, n_in = _local_mean(lab_col, core, far)
        test = cand & (n_bg >= min_pixels - 0.5) & (n_in >= min_pixels - 0.5)
        drop = test & (np.linalg.norm(lab_col - m_bg, axis=-1) < np.linalg.norm(lab_col - m_in, axis=-1))
        lab[drop] = 0
        out.append(lab)
        per_view.append(int(drop.sum()))
    return out, {"trimmed": int(sum(per_view)), "per_view": per_view}


def _local_mean(image: np.ndarray, weight: np.ndarray, size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Mean of ``image`` ``[H, W, C]`` over the pixels of ``weight`` (0/1) in a ``size`` box around every pixel, and their count."""
    import cv2

    n = cv2.boxFilter(weight, -1, size, normalize=False, borderType=cv2.BORDER_CONSTANT)
    s = cv2.boxFilter(image * weight[..., None], -1, size, normalize=False, borderType=cv2.BORDER_CONSTANT)  # every channel at once
    return s / np.maximum(n, 1.0)[..., None], n
