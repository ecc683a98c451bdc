"""Issue 53, deliverable 3: one run path. A run validates the scene, builds each backend, lifts and
builds the effective config once each (before: validate 3 times, lift twice, for_lifter 3 times,
the backends twice), whether it comes through run_job (graphseg run) or pipeline.run."""

import collections

import pytest

from graphseg.scene import Scene
from graphseg.testing.scenes import TWO_BOXES, box_scene


@pytest.fixture
def counts(monkeypatch):
    import graphseg.backends.lifters.rgbd as rgbd
    import graphseg.config as config
    import graphseg.pipeline as pipeline
    import graphseg.scene as scene

    seen = collections.Counter()

    def count(owner, name, label, when=lambda *a, **k: True):
        orig = getattr(owner, name)

        def wrapped(*a, **k):
            if when(*a, **k):
                seen[label] += 1
            return orig(*a, **k)

        monkeypatch.setattr(owner, name, wrapped)

    count(scene.Scene, "validate", "validate")
    count(config.Config, "for_lifter", "effective config")
    count(rgbd.RGBDLifter, "__call__", "lift")
    count(pipeline, "resolve_backend", "build", when=lambda kind, spec, *a, **k: spec is None or isinstance(spec, (str, type)))
    return seen


def _depth_only():
    s = box_scene(TWO_BOXES)
    return Scene([v.replace(points=None) for v in s.views], s.objects, s.name)


def test_run_job_validates_builds_lifts_and_configures_once(counts, tmp_path):
    from graphseg.job import run_job

    job = run_job(_depth_only(), tmp_path / "out")
    assert job.result.num_objects == 2
    assert dict(counts) == {"validate": 1, "build": 3, "lift": 1, "effective config": 1}  # segmenter, matcher, lifter


def test_pipeline_run_validates_builds_lifts_and_configures_once(counts):
    from graphseg.pipeline import run

    assert run(_depth_only()).num_objects == 2
    assert dict(counts) == {"validate": 1, "build": 3, "lift": 1, "effective config": 1}
