import numpy as np

from graphseg.scene import Scene, View
from graphseg.sim.strip import rgb_only


def test_rgb_only_keeps_ground_truth_and_does_not_mutate():
    v = View("0", np.zeros((2, 3, 3), np.uint8), depth=np.ones((2, 3), np.float32), K=np.eye(3), cam_to_world=np.eye(4), instances=np.ones((2, 3), np.int32))
    scene = Scene([v], {1: "a"})
    out = rgb_only(scene, keep_intrinsics=False)
    assert out.views[0].depth is None and out.views[0].K is None and out.views[0].cam_to_world is None
    assert out.views[0].instances is not None and out.objects == {1: "a"}
    assert scene.views[0].depth is not None and scene.views[0].K is not None
