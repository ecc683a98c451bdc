import pytest


@pytest.fixture(scope="module")
def arc_scene():
    """Six 320 x 240 photos on a 50-degree arc of a four-object scene (test_sfm.py, test_sfm_cli.py)."""
    pytest.importorskip("pybullet")
    from graphseg.sim.pybullet_scenes import CameraRig, synthesize

    return synthesize(seed=3, objects=4, views=6, size=(320, 240), cameras=CameraRig(arc_deg=50), settle_steps=240)
