"""The folders of model outputs computed elsewhere, shared by the precomputed lifter and matcher.

:func:`precomputed_folder` checks the folder a precomputed backend reads, and
:func:`precomputed_choice` turns the CLI's ``--points DIR`` / ``--matches DIR``
into the backend that reads it (formats: :mod:`graphseg.io.precomputed`;
backends: :mod:`graphseg.backends.lifters.precomputed`,
:mod:`graphseg.backends.matchers.precomputed`).

Examples
--------
>>> FLAGS["points"], FLAGS["matches"]
(('lifter', 'precomputed-points'), ('matcher', 'precomputed-matches'))
"""

from __future__ import annotations

import os
from pathlib import Path

from ..scene import SceneError

__all__ = ["FLAGS", "precomputed_folder", "precomputed_choice"]

#: CLI flag -> (backend kind, registry name) of the backend that reads that folder.
FLAGS = {"points": ("lifter", "precomputed-points"), "matches": ("matcher", "precomputed-matches")}


def precomputed_folder(folder: str | os.PathLike[str] | None, backend: str, field: str) -> Path:
    """The folder a precomputed ``backend`` reads (``field``: ``"points"`` or ``"matches"``), checked.

    Raises :class:`~graphseg.scene.SceneError` naming the CLI flag and the
    backend option when ``folder`` is None, and the path when it is not a folder.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as d:
    ...     precomputed_folder(d, "lifter", "points").is_dir()
    True
    """
    if folder is None:
        raise SceneError(
            f"the precomputed {backend} needs a folder: --{field} DIR (or --backend-option {FLAGS[field][1]}.folder=DIR)",
            where=FLAGS[field][1],
            field="folder",
        )
    root = Path(folder)
    if not root.is_dir():
        raise SceneError("no such folder", where=str(root), field=field)
    return root


def precomputed_choice(flag: str, folder: str | os.PathLike[str], chosen: str | None) -> tuple[str, dict[str, str]]:
    """Backend name and options for the CLI's ``--points DIR`` / ``--matches DIR``.

    Raises :class:`SceneError` when the folder is missing or ``chosen`` (the
    ``--lifter`` / ``--matcher`` given too) names another backend.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as d:
    ...     precomputed_choice("points", d, None)[0]
    'precomputed-points'
    """
    kind, name = FLAGS[flag]
    root = Path(folder)
    if not root.is_dir():
        raise SceneError("no such folder", where=str(root), field=flag)
    if chosen not in (None, name):
        raise SceneError(f"--{flag} needs the {name} {kind} (got --{kind} {chosen})", where=str(root), field=flag)
    return name, {"folder": str(root.resolve())}
