"""A user's weights file: read it as a state dict, load it into a module, one-line errors.

Every model backend (SAM 2, LoFTR, RoMa, DINOv2, Depth Anything 3) loads
weights the user supplies; none downloads. :func:`load_state_dict_file` reads a
torch file (``weights_only``) or a ``.safetensors`` file, unwraps the usual
``{"state_dict": ...}`` / ``{"model": ...}`` wrappers and can strip a key
prefix; :func:`load_into` loads it strictly. Failures are one-line
:class:`~graphseg.scene.SceneError` s naming the file and the option.

Examples
--------
>>> import tempfile, torch
>>> from pathlib import Path
>>> path = Path(tempfile.mkdtemp()) / "w.pt"
>>> torch.save({"model": {"model.w": torch.zeros(2)}}, path)
>>> sorted(load_state_dict_file(path, "demo", strip_prefix="model."))
['w']
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..registry import MissingDependencyError
from ..scene import SceneError
from .options import require_backend

__all__ = ["load_state_dict_file", "load_into"]


def load_state_dict_file(
    path: Any,
    backend: str,
    option: str = "checkpoint",
    keys: tuple[str, ...] = ("state_dict", "model"),
    *,
    extra: str | None = None,
    field: str | None = None,
    strip_prefix: str | None = None,
) -> dict[str, Any]:
    """Read a state dict from a user's weights file.

    Parameters
    ----------
    path : path
        A ``torch.save`` file (read with ``weights_only=True``) or a
        ``.safetensors`` file.
    backend, option : str
        Name the option in errors: ``backends.options.BACKEND.OPTION``.
    keys : tuple of str
        Wrapper keys unwrapped in this order when their value is a dict
        (``{"state_dict": ...}``, ``{"model": ...}``, DINOv2's ``"teacher"``).
    extra : str, optional
        The extra named when ``safetensors`` is missing (default: ``backend``).
    field : str, optional
        Overrides the error field.
    strip_prefix : str, optional
        Removed from every key when all keys start with it (a Hub wrapper's
        ``"model."``).

    Returns
    -------
    dict
        Parameter name -> tensor.

    Raises
    ------
    SceneError
        The file cannot be read, or holds no dict.
    MissingDependencyError
        A ``.safetensors`` file without the ``safetensors`` package.
    """
    path = Path(path)
    field = field or f"backends.options.{backend}.{option}"
    try:
        if path.suffix == ".safetensors":
            state = require_backend("safetensors.torch", backend, extra or backend, option).load_file(str(path))
        else:
            import torch

            state = torch.load(str(path), map_location="cpu", weights_only=True)
    except MissingDependencyError:
        raise
    except Exception as err:
        first = str(err).strip().splitlines()[0][:200] if str(err).strip() else ""
        raise SceneError(f"cannot read the weights ({type(err).__name__}{': ' + first if first else ''})", where=str(path), field=field) from None
    for k in keys:
        if isinstance(state, dict) and isinstance(state.get(k), dict):
            state = state[k]
    if not isinstance(state, dict):
        raise SceneError(f"expected a state dict (got {type(state).__name__})", where=str(path), field=field)
    if strip_prefix and state and all(str(k).startswith(strip_prefix) for k in state):
        state = {k[len(strip_prefix) :]: v for k, v in state.items()}
    return state


def load_into(module: Any, state: dict[str, Any], path: Any, backend: str, option: str = "checkpoint", what: str = "") -> None:
    """``module.load_state_dict(state, strict=True)``; a mismatch is one line naming ``what`` (default: ``backend``)."""
    try:
        module.load_state_dict(state, strict=True)
    except (RuntimeError, TypeError, AttributeError) as err:  # missing/unexpected keys, sizes; a non-tensor value
        lines = [ln.strip() for ln in str(err).splitlines() if ln.strip()]
        detail = lines[1] if len(lines) > 1 else lines[0]
        raise SceneError(f"weights do not fit {what or backend} ({detail[:200]})", where=str(path), field=f"backends.options.{backend}.{option}") from None
