"""Similarity alignment of two point sets (Umeyama 1991).

Used to bring a structure-from-motion reconstruction (arbitrary frame and
scale) onto known camera positions, so its point maps come out in metres.

Examples
--------
>>> import numpy as np
>>> src = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
>>> s, R, t = umeyama(src, 2 * src + [1, 2, 3])
>>> round(s, 6), np.round(R, 6).tolist() == np.eye(3).tolist(), np.round(t, 6).tolist()
(2.0, True, [1.0, 2.0, 3.0])
"""

from __future__ import annotations

import numpy as np

__all__ = ["umeyama"]


def umeyama(src: np.ndarray, dst: np.ndarray, *, with_scale: bool = True) -> tuple[float, np.ndarray, np.ndarray]:
    """The similarity ``(s, R, t)`` minimising ``sum ||dst - (s R src + t)||^2``.

    Parameters
    ----------
    src, dst : float ``[N, 3]``
        Corresponding points, ``N >= 3`` for a unique rotation (``N >= 1``
        gives some least-squares answer; ``N == 2`` leaves the roll about
        the line free).
    with_scale : bool
        False fixes ``s = 1`` (a rigid fit).

    Returns
    -------
    s : float
    R : float64 ``[3, 3]``
        A proper rotation (det +1).
    t : float64 ``[3]``
        So that ``dst ~= s * src @ R.T + t``.

    Raises
    ------
    ValueError
        When the shapes differ, are not ``[N, 3]``, are empty or contain NaN.

    Notes
    -----
    One 3x3 SVD after O(N) moments (Umeyama, PAMI 1991, eqs. 40-42).
    """
    a = np.asarray(src, np.float64)
    b = np.asarray(dst, np.float64)
    if a.ndim != 2 or a.shape[1:] != (3,) or a.shape != b.shape or a.shape[0] == 0:
        raise ValueError(f"expected src and dst of one shape [N, 3] with N >= 1 (got {list(a.shape)} and {list(b.shape)})")
    if not (np.isfinite(a).all() and np.isfinite(b).all()):
        raise ValueError("src and dst must be finite (got NaN or inf)")
    mu_a, mu_b = a.mean(0), b.mean(0)
    da, db = a - mu_a, b - mu_b
    cov = db.T @ da / a.shape[0]
    U, S, Vt = np.linalg.svd(cov)
    D = np.eye(3)
    if np.linalg.det(U) * np.linalg.det(Vt) < 0:
        D[2, 2] = -1
    R = U @ D @ Vt
    var_a = float((da**2).sum() / a.shape[0])
    s = float(np.trace(np.diag(S) @ D) / var_a) if with_scale and var_a > 0 else 1.0
    t = mu_b - s * R @ mu_a
    return s, R, t
