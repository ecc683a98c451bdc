"""Acceptance of issue 9: a criterion living outside the repository, found only through its
entry point, runs as a third stage from a YAML config alone through the CLI."""

import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from graphseg import Result
from graphseg.cli import main
from graphseg.io import write_scene_folder
from graphseg.testing.plugins import refresh_registries, write_dist_info
from graphseg.testing.scenes import TWO_BOXES, box_scene

REPO = Path(__file__).resolve().parents[2]

PLUGIN = '''
"""An outside criterion: joins nodes whose 3D centroids lie within `radius` metres."""
import numpy as np
from pydantic import BaseModel, ConfigDict, Field
from scipy.spatial import cKDTree

from graphseg.graphs import Criterion, EdgeSet


class CentroidRadius(Criterion):
    name = "centroid_radius"

    class Options(BaseModel):
        model_config = ConfigDict(extra="forbid")
        radius: float = Field(0.05, gt=0)

    requires = frozenset({"points"})
    reduce = {"gap": "min"}
    tags = {"dimension": "3d"}

    def __call__(self, graph, evidence):
        n = graph.num_nodes
        total, count = np.zeros((n, 3)), np.zeros(n)
        for lab, pts in zip(evidence.node_labels, evidence.points):
            ok = (lab >= 0) & np.isfinite(pts).all(-1)
            np.add.at(total, lab[ok], pts[ok])
            count += np.bincount(lab[ok], minlength=n)
        c = total / np.maximum(count, 1)[:, None]
        pairs = cKDTree(c).query_pairs(self.options.radius, output_type="ndarray")
        pairs = pairs[(count[pairs[:, 0]] > 0) & (count[pairs[:, 1]] > 0)]
        gap = np.linalg.norm(c[pairs[:, 0]] - c[pairs[:, 1]], axis=1)
        return EdgeSet(pairs.T.astype(np.int64), {"gap": gap})
'''


@pytest.fixture
def outside_plugin(tmp_path, monkeypatch):
    site = tmp_path / "site"
    site.mkdir()
    (site / "centroid_radius_plugin.py").write_text(textwrap.dedent(PLUGIN))
    write_dist_info(site, "centroid-radius", {"graphseg.edge_adders": {"centroid_radius": "centroid_radius_plugin:CentroidRadius"}})
    monkeypatch.syspath_prepend(str(site))
    refresh_registries()
    yield site
    monkeypatch.undo()
    refresh_registries()


@pytest.fixture(scope="module")
def scene_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("ext") / "scene"
    write_scene_folder(box_scene(TWO_BOXES, views=3, shape=(96, 128)), d)
    return d


def _config(path, radius_key="radius", radius=1.0):
    path.write_text(
        "stages:\n"
        "  - [{pixel_match: {normalization: pair_hits, tau: 0.3, min_matches: 5}}]\n"
        "  - [{chamfer_3d: {tau: 5.0e-5}}]\n"
        f"  - [{{centroid_radius: {{{radius_key}: {radius}}}}}]\n"
        "split: {enabled: false}\n"  # the 3D split would part the two boxes the third stage joins: they do not touch
    )
    return path


def test_third_stage_from_yaml_through_the_cli(outside_plugin, scene_dir, tmp_path):
    cfg = _config(tmp_path / "cfg.yaml")
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), str(outside_plugin)])}
    proc = subprocess.run(
        [sys.executable, "-m", "graphseg.cli", "run", str(scene_dir), "-o", str(out), "--config", str(cfg), "--quiet"],
        cwd=REPO, env=env, capture_output=True, text=True, timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    result = Result.load(out / "result.npz")
    assert result.config.stage_names() == [["pixel_match"], ["chamfer_3d"], ["centroid_radius"]]
    g = result.graphs[2]
    crit = g.edge_attr["criterion"]
    assert (crit == "centroid_radius").sum() >= 1 and "gap" in g.edge_attr
    assert (g.edge_attr["stage"][crit == "centroid_radius"] == 2).all()
    # without the third stage the two boxes stay apart; with a 1 m radius they are joined
    assert g.num_nodes == 2 and result.num_objects == 1
    for graph in result.graphs:
        assert (graph.node_attr["object"] == 1).all()
    # the output folder's GraphML of that stage holds the criterion's edges and every node's object id
    from graphseg.graphs import read_graphml

    gml = read_graphml(out / "graphs" / "stage2.graphml")
    assert (gml.edge_attr["criterion"] == "centroid_radius").sum() == (crit == "centroid_radius").sum()
    assert (gml.node_attr["object"] == 1).all()


def test_third_stage_with_a_small_radius_adds_no_edge(outside_plugin, scene_dir, tmp_path):
    out = tmp_path / "out"
    assert main(["run", str(scene_dir), "-o", str(out), "--config", str(_config(tmp_path / "c.yaml", radius=1e-4)), "--quiet"]) == 0
    result = Result.load(out / "result.npz")
    assert not (result.graphs[2].edge_attr["criterion"] == "centroid_radius").any()
    assert result.num_objects == 2
    assert sorted(np.unique(result.graphs[0].node_attr["object"]).tolist()) == [1, 2]


def test_misspelt_option_exit_2_fast_no_output(outside_plugin, scene_dir, tmp_path, capsys):
    cfg = _config(tmp_path / "bad.yaml", radius_key="radiuss")
    out = tmp_path / "out"
    t = time.perf_counter()
    code = main(["run", str(scene_dir), "-o", str(out), "--config", str(cfg), "--quiet"])
    elapsed = time.perf_counter() - t
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert "centroid_radius: unknown option 'radiuss'; valid options: radius" in err[0] and str(cfg) in err[0]
    assert elapsed < 1.0, elapsed
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.yaml", "site"]  # nothing left behind


def test_unknown_criterion_lists_the_installed_ones(outside_plugin, scene_dir, tmp_path, capsys):
    cfg = tmp_path / "c.yaml"
    cfg.write_text("stages: [[pixel_match], [centroid_radiu]]\n")
    code = main(["run", str(scene_dir), "-o", str(tmp_path / "out"), "--config", str(cfg), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and "unknown edge criterion 'centroid_radiu'" in err and "centroid_radius" in err
    assert not (tmp_path / "out").exists()
