"""Test helpers for plugins: a temporary ``*.dist-info`` with entry points, and loopback plugins.

:func:`write_dist_info` writes the metadata folder that ``pip install`` would
create for a plugin package, so a test puts its folder on ``sys.path`` (for
example with ``monkeypatch.syspath_prepend``), calls the registries'
``refresh()`` and exercises the real entry-point path, while nothing
test-only appears in a user's installed choices. ``LoopbackEdgeAdder`` (a
legacy plain callable that joins nothing) and ``LoopbackContractor``
(union-find) are targets for such tests.

Examples
--------
>>> import numpy as np
>>> LoopbackContractor()(np.array([[0], [1]]), 2).tolist()
[0, 0]
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from graphseg.graphs.contract import union_find_contraction
from graphseg.graphs.evidence import EdgeSet, Evidence
from graphseg.graphs.graph import CorrespondenceGraph

__all__ = ["write_dist_info", "refresh_registries", "LoopbackEdgeAdder", "LoopbackContractor"]


def write_dist_info(
    root: str | os.PathLike[str],
    name: str,
    entry_points: Mapping[str, Mapping[str, str]],
    *,
    version: str = "0.1.0",
) -> Path:
    """Write ``root/NAME-VERSION.dist-info`` with ``METADATA`` and ``entry_points.txt``.

    Parameters
    ----------
    root : path
        Folder that goes on ``sys.path`` (created if missing).
    name : str
        Distribution name.
    entry_points : mapping group -> {entry name: "module:attr"}

    Returns
    -------
    Path
        The ``.dist-info`` folder.

    Examples
    --------
    >>> import tempfile
    >>> d = write_dist_info(tempfile.mkdtemp(), "demo", {"graphseg.edge_adders": {"x": "m:X"}})
    >>> print((d / "entry_points.txt").read_text().strip())
    [graphseg.edge_adders]
    x = m:X
    """
    folder = Path(root) / f"{name.replace('-', '_')}-{version}.dist-info"
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: {version}\n")
    lines: list[str] = []
    for group, eps in entry_points.items():
        lines.append(f"[{group}]")
        lines += [f"{k} = {v}" for k, v in eps.items()]
        lines.append("")
    (folder / "entry_points.txt").write_text("\n".join(lines))
    return folder


def refresh_registries() -> None:
    """Re-scan the entry points of every graphseg registry (after ``sys.path`` changed)."""
    from graphseg.backends import registry as backends
    from graphseg.graphs.registry import contractors, edge_adders, operations
    from graphseg.io import scene_formats

    for reg in (edge_adders, contractors, operations, scene_formats, *(getattr(backends, n) for n in ("segmenters", "matchers", "lifters", "features"))):
        reg.refresh()


class LoopbackEdgeAdder:
    """Adds no edge; counts its calls (a legacy plain callable without ``Options``)."""

    name = "testing_loopback"
    calls = 0

    def __call__(self, graph: CorrespondenceGraph, evidence: Evidence) -> EdgeSet:
        type(self).calls += 1
        return EdgeSet(np.zeros((2, 0), np.int64), {"criterion": np.zeros(0, "<U16")})


class LoopbackContractor:
    """Union-find under another name."""

    name = "testing_loopback"

    def __call__(self, edge_index: Any, num_nodes: int, *, rng: Any = None) -> np.ndarray:
        return union_find_contraction(edge_index, num_nodes)
