from pathlib import Path

import pytest

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "ycbv"


@pytest.fixture
def ycbv_root():
    if not (SHARED / "0001").is_dir():
        pytest.skip("../shared/data/ycbv is not available")
    return SHARED
