"""The backends' layout: one package per kind, one module per backend, no old flat paths.

``graphseg/backends/`` is split by kind (``segmenters/``, ``matchers/``,
``lifters/``, ``features/``). The flat modules of before the split
(``graphseg.backends.sfm``, ``.sam``, ...) and the method's re-export modules
(``graphseg.method.pairs``, ``.sparse_chamfer``) are gone: version 0.1.0 never
shipped them. Importing the backends imports no torch and raises no warning.
"""

from __future__ import annotations

import importlib
import importlib.util
import subprocess
import sys

import pytest

#: Module paths that re-exported other modules' names, and where those names live.
REMOVED = {
    "graphseg.backends.align": "graphseg.backends.lifters.align",
    "graphseg.backends.automask": "graphseg.backends.segmenters.automask",
    "graphseg.backends.convexity": "graphseg.backends.segmenters.convexity",
    "graphseg.backends.da3": "graphseg.backends.lifters.da3",
    "graphseg.backends.dense_matchers": "graphseg.backends.matchers.loftr",
    "graphseg.backends.densify": "graphseg.backends.lifters.densify",
    "graphseg.backends.dino": "graphseg.backends.features.dino",
    "graphseg.backends.dust3r": "graphseg.backends.lifters.dust3r",
    "graphseg.backends.hed": "graphseg.backends.segmenters.hed",
    "graphseg.backends.parts": "graphseg.backends.segmenters.oracle_parts",
    "graphseg.backends.precomputed": "graphseg.backends.lifters.precomputed",
    "graphseg.backends.romatch_compat": "graphseg.backends.matchers.romatch_compat",
    "graphseg.backends.sam": "graphseg.backends.segmenters.sam",
    "graphseg.backends.sfm": "graphseg.backends.lifters.sfm",
    "graphseg.backends.stereo": "graphseg.backends.lifters.stereo",
    "graphseg.method.pairs": "graphseg.geometry",
    "graphseg.method.sparse_chamfer": "graphseg.graphs.chamfer",
}


@pytest.mark.parametrize("old", sorted(REMOVED))
def test_no_reexport_module_is_left(old):
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module(old)
    assert importlib.util.find_spec(REMOVED[old]) is not None  # its names live here


def test_backend_classes_live_in_their_kind_package():
    from graphseg.backends import registry

    for kind in ("segmenters", "matchers", "lifters", "features"):
        reg = getattr(registry, kind)
        for name in reg.names():
            cls = reg.get(name)
            assert cls.__module__.startswith(f"graphseg.backends.{kind}."), (kind, name, cls.__module__)
            assert getattr(importlib.import_module(f"graphseg.backends.{kind}"), cls.__name__) is cls


def test_backend_modules_import_no_torch_and_warn_nothing():
    mods = [f"graphseg.backends.{k}" for k in ("segmenters", "matchers", "lifters", "features")] + ["graphseg.backends.registry", "graphseg.backends.onnx_export"]
    code = "import sys\n" + "".join(f"import {m}\n" for m in mods) + "heavy = [m for m in ('torch', 'onnxruntime', 'pycolmap', 'cv2', 'kornia') if m in sys.modules]\nassert not heavy, heavy\n"
    out = subprocess.run([sys.executable, "-W", "error", "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
