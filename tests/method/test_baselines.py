import numpy as np
import pytest
from pydantic import ValidationError

from graphseg.config import Config
from graphseg.method.baselines import maskclustering, run_method, sam3d
from graphseg.result import Result
from graphseg.testing.scenes import two_boxes_scene

METHODS = ("graphseg", "graphseg-minus", "maskclustering", "sam3d")


@pytest.mark.parametrize("method", sorted(METHODS))
def test_every_method_returns_a_result(method):
    scene, masks, matches = two_boxes_scene()
    r = run_method(scene, masks, matches, Config(method=method))
    assert isinstance(r, Result) and len(r.labels) == scene.num_views
    assert r.num_objects >= 1


def test_baseline_stages():
    scene, masks, matches = two_boxes_scene()
    assert maskclustering(scene, masks, matches).config.stage_names() == [["view_consensus"]] * 3
    assert sam3d(scene, masks, matches).config.stage_names() == [["bidirectional_overlap"]]
    assert run_method(scene, masks, matches, Config(method="graphseg-minus")).config.stage_names() == [["pixel_match"]]


def test_unknown_method_rejected():
    with pytest.raises(ValidationError):
        Config(method="nope")


def test_segment_runs_the_method_its_config_names():
    from graphseg.method import segment
    from graphseg.method.baselines import sam3d
    from graphseg.testing.scenes import two_boxes_scene

    scene, masks, matches = two_boxes_scene()
    direct = segment(scene, masks, matches, Config(method="sam3d"))
    assert direct.config.method == "sam3d" and direct.config.stage_names() == [["bidirectional_overlap"]]
    base = sam3d(scene, masks, matches)
    assert all(np.array_equal(a, b) for a, b in zip(direct.labels, base.labels))
    assert segment(scene, masks, matches, Config(method="graphseg-minus")).config.stage_names() == [["pixel_match"]]
