import pytest

from graphseg.io import write_scene_folder
from graphseg.testing.scenes import TWO_BOXES, box_scene


@pytest.fixture(scope="module")
def synth_dir(tmp_path_factory):
    """Two tiny native scenes under ``synth/`` (split label ``synth``)."""
    root = tmp_path_factory.mktemp("batch") / "synth"
    for k, name in enumerate(("a", "b")):
        write_scene_folder(box_scene(TWO_BOXES, views=4, shape=(48, 64), rng=k, jitter=0.02), root / name)
    return root
