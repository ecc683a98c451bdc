"""Checks shared by the dataset readers: every value is validated as strictly as the native reader does.

Examples
--------
>>> intrinsics([[500, 0, 320], [0, 500, 240], [0, 0, 1]], where="meta.mat", field="intrinsic_matrix").shape
(3, 3)
>>> positive(0, where="meta.mat", field="factor_depth")
Traceback (most recent call last):
...
graphseg.scene.SceneError: meta.mat: factor_depth: expected a positive finite number (got 0.0)
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any

import numpy as np

from ..scene import SceneError, is_rigid

__all__ = ["matrix", "intrinsics", "rigid", "positive", "reading"]


def matrix(value: Any, shape: tuple[int, ...], *, where: str, field: str) -> np.ndarray:
    """``value`` as a finite float64 array of ``shape`` (a flat list of the right length is reshaped)."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise SceneError(f"expected a {'x'.join(map(str, shape))} matrix of numbers", where=where, field=field) from err
    if arr.shape != shape and arr.size == int(np.prod(shape)):
        arr = arr.reshape(shape)
    if arr.shape != shape:
        raise SceneError(f"expected a {'x'.join(map(str, shape))} matrix (got shape {list(arr.shape)})", where=where, field=field)
    if not np.isfinite(arr).all():
        raise SceneError("contains NaN or inf", where=where, field=field)
    return arr


def intrinsics(value: Any, *, where: str, field: str) -> np.ndarray:
    """A 3x3 camera matrix with positive focal lengths and last row ``0 0 1``."""
    K = matrix(value, (3, 3), where=where, field=field)
    if not (K[0, 0] > 0 and K[1, 1] > 0):
        raise SceneError(f"focal lengths must be positive (got fx={K[0, 0]:g}, fy={K[1, 1]:g})", where=where, field=field)
    if not np.allclose(K[2], [0, 0, 1]):
        raise SceneError(f"expected last row 0 0 1 (got {K[2].tolist()})", where=where, field=field)
    return K


def rigid(T: Any, *, where: str, field: str) -> np.ndarray:
    """A finite rigid 4x4 transform."""
    T = matrix(T, (4, 4), where=where, field=field)
    if not is_rigid(T):
        raise SceneError("not a rigid transform (rotation must be orthonormal with det +1, last row 0 0 0 1)", where=where, field=field)
    return T


def positive(value: Any, *, where: str, field: str) -> float:
    """A positive finite scalar (a 1-element array is accepted)."""
    try:
        arr = np.asarray(value, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        arr = np.array([np.nan])
    shown = arr[0].item() if arr.size == 1 else value
    if arr.size != 1 or not np.isfinite(arr[0]) or not arr[0] > 0:
        raise SceneError(f"expected a positive finite number (got {shown!r})", where=where, field=field)
    return float(arr[0])


@contextlib.contextmanager
def reading(where: str, field: str) -> Iterator[None]:
    """Turn ValueError, KeyError, IndexError, TypeError and LinAlgError raised inside into a SceneError."""
    try:
        yield
    except SceneError:
        raise
    except (ValueError, KeyError, IndexError, TypeError, np.linalg.LinAlgError, AttributeError) as err:
        text = str(err).splitlines()[0] if str(err) else ""
        raise SceneError(f"malformed ({type(err).__name__}{': ' + text if text else ''})", where=where, field=field) from err
