import pytest
from pydantic import ValidationError

from graphseg.config import Config


def test_defaults_follow_the_paper():
    c = Config()
    assert c.pixel_match.percentile == 78 and c.pixel_match.tau is None
    assert c.chamfer_3d.tau == 5e-4
    assert c.background.max_overlap == 0.09
    assert c.pairs.max_rotation == 1.2
    assert c.contractor == "star"


@pytest.mark.parametrize("suffix", [".yaml", ".json"])
def test_save_load_roundtrip(tmp_path, suffix):
    c = Config(seed=3, contractor="union_find", chamfer_3d={"tau": 5e-5, "outliers": "dbscan"})
    c.save(tmp_path / f"c{suffix}")
    assert Config.load(tmp_path / f"c{suffix}") == c


def test_partial_file_and_unknown_keys(tmp_path):
    (tmp_path / "p.yaml").write_text("seed: 5\npixel_match:\n  percentile: 50\n")
    c = Config.load(tmp_path / "p.yaml")
    assert c.seed == 5 and c.pixel_match.percentile == 50 and c.chamfer_3d.tau == 5e-4
    (tmp_path / "bad.yaml").write_text("pixel_mach:\n  percentile: 50\n")
    with pytest.raises(ValidationError, match="pixel_mach"):
        Config.load(tmp_path / "bad.yaml")
    (tmp_path / "list.yaml").write_text("- 1\n")
    with pytest.raises(ValueError, match="mapping"):
        Config.load(tmp_path / "list.yaml")


def test_minus_and_options():
    m = Config.minus()
    assert m.stages == [["pixel_match"]]
    c = Config(stages=[["pixel_match", "dino"], ["chamfer_3d"]]).without_3d()
    assert c.stages == [["pixel_match", "dino"]]
    assert Config().options_for("chamfer_3d")["tau"] == 5e-4
    assert Config(adder_options={"mine": {"k": 1}}).options_for("mine") == {"k": 1}
    with pytest.raises(ValidationError):
        Config(stages=[])
    with pytest.raises(ValidationError):
        Config(pixel_match={"percentile": 120})
