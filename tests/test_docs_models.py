"""docs/models.md: the paper's configuration file is a valid Config; docs/formats.md names real functions."""

import re
from pathlib import Path

import yaml

from graphseg.config import Config

DOCS = Path(__file__).resolve().parents[1] / "docs"


def test_paper_config_file_validates():
    section = (DOCS / "models.md").read_text().split("## The paper's configuration as one config file")[1]
    block = re.findall(r"```yaml\n(.*?)```", section, flags=re.S)[0]
    cfg = Config.model_validate(yaml.safe_load(block))
    assert cfg.backends.lifter == "dust3r" and cfg.criterion_options("chamfer_3d")["tau"] == 5e-4 and cfg.criterion_options("pixel_match")["min_matches"] == 1 and cfg.background.max_overlap == 0.09


def test_formats_page_names_existing_functions():
    import graphseg.io.precomputed as pre

    text = (DOCS / "formats.md").read_text()
    for name in ("read_point_map", "write_point_map", "read_matches_folder", "write_matches_folder", "encode_name", "save_inputs"):
        assert name in text and hasattr(pre, name)
