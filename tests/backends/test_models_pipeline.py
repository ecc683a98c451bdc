"""The paper's 2D backends inside the pipeline: sam2 masks and loftr matches from checkpoint files."""

import pytest

from graphseg.config import Config
from graphseg.pipeline import compute_masks, compute_matches
from graphseg.sim.boxes import Box
from graphseg.testing.scenes import box_scene

torch = pytest.importorskip("torch")
pytest.importorskip("sam2")
pytest.importorskip("kornia")


def test_pipeline_takes_sam2_and_loftr_options_from_the_config(tmp_path):
    from kornia.feature import LoFTR
    from sam2.build_sam import build_sam2

    torch.manual_seed(0)
    sam = build_sam2("configs/sam2.1/sam2.1_hiera_t.yaml", ckpt_path=None, device="cpu", hydra_overrides_extra=["++model.image_size=256"])
    torch.save({"model": sam.state_dict()}, tmp_path / "sam2.1_hiera_tiny.pt")
    torch.save({"state_dict": LoFTR(pretrained=None).state_dict()}, tmp_path / "loftr_outdoor.ckpt")
    scene = box_scene([Box((0.0, 0.0, 0.05), (0.1, 0.1, 0.1))], views=2, shape=(48, 64), rng=0)
    cfg = Config.model_validate(
        {
            "backends": {
                "segmenter": "sam2",
                "matcher": "loftr",
                "options": {
                    "sam2": {"checkpoint": str(tmp_path / "sam2.1_hiera_tiny.pt"), "image_size": 256, "points_per_side": 3, "pred_iou_thresh": -1e9, "stability_score_thresh": 0.0},
                    "loftr": {"checkpoint": str(tmp_path / "loftr_outdoor.ckpt"), "image_size": [64, 48], "match_threshold": 0.0},
                },
                "num_matches": 1,
            }
        }
    )
    masks = compute_masks(scene, config=cfg)
    assert len(masks) == 2 and all(m.dtype == bool and m.shape == (48, 64) for ms in masks for m in ms)
    assert all(len(ms) >= 1 for ms in masks)
    matches = compute_matches(scene, config=cfg, pairs=[(0, 1)])
    assert set(matches) == {(0, 1)}
    assert len(matches[(0, 1)]) <= 1  # backends.num_matches reaches the matcher through its signature
