"""Issue 10's acceptance: the paper's RGB-only pipeline through the CLI with user checkpoints.

SAM 2 masks, LoFTR matches and Depth Anything 3 (or DUSt3R as an ONNX pair) point maps,
all built from random-weight checkpoints that the tests write, every backend set up only
with ``--backend-option NAME.KEY=VALUE``, on a folder of plain RGB images. With random
weights the segmentation is meaningless; what is checked is that the whole job runs on CPU
and writes a complete output folder naming the backends it used.
"""

import json

import pytest

pytest.importorskip("torch")
pytest.importorskip("sam2")
pytest.importorskip("kornia")
pytest.importorskip("depth_anything_3")

from graphseg.cli import main  # noqa: E402
from graphseg.io.images import write_rgb  # noqa: E402
from graphseg.testing.scenes import TWO_BOXES, box_scene  # noqa: E402
from tests.backends.test_da3 import checkpoint  # noqa: E402,F401
from tests.backends.test_dense_matchers import loftr_ckpt  # noqa: E402,F401
from tests.backends.test_dust3r import onnx_pair  # noqa: E402,F401
from tests.backends.test_sam import tiny_sam2  # noqa: E402,F401

OUTPUT = ("result.npz", "report.html", "run.json", "config.yaml", ".graphseg-output", "graphs/stage0.graphml")  # no ground truth: no metrics.json


@pytest.fixture
def rgb_only(tmp_path):
    """A folder of 3 plain RGB images (no scene.json, no depth, no poses)."""
    img = tmp_path / "images"
    img.mkdir()
    for v in box_scene(TWO_BOXES, views=3, shape=(48, 64)).views:
        write_rgb(img / f"{v.name}.png", v.rgb)
    return img


def sam2_loftr(tiny_sam2, loftr_ckpt):
    return [
        "--segmenter", "sam2",
        "--backend-option", f"sam2.checkpoint={tiny_sam2[1]}",
        "--backend-option", "sam2.image_size=256",
        "--backend-option", "sam2.points_per_side=3",
        "--backend-option", "sam2.pred_iou_thresh=-1.0e9",
        "--backend-option", "sam2.stability_score_thresh=0.0",
        "--matcher", "loftr",
        "--backend-option", f"loftr.checkpoint={loftr_ckpt}",
        "--backend-option", "loftr.image_size=[160, 120]",
    ]


def check_output(out, lifter):
    for name in OUTPUT:
        assert (out / name).exists(), name
    run = json.loads((out / "run.json").read_text())
    assert run["pipeline"]["segmenter"] == "sam2" and run["pipeline"]["matcher"] == "loftr" and run["pipeline"]["lifter"] == lifter
    assert len(list((out / "labels").glob("*.png"))) == 3


def test_sam2_loftr_da3_from_checkpoints(rgb_only, tiny_sam2, loftr_ckpt, checkpoint, tmp_path, capsys):
    out = tmp_path / "out"
    argv = ["run", rgb_only, "-o", out, *sam2_loftr(tiny_sam2, loftr_ckpt),
            "--lifter", "da3", "--backend-option", f"da3.checkpoint={checkpoint}", "--backend-option", "da3.size=70", "--quiet"]
    code = main([str(a) for a in argv])
    assert code == 0, capsys.readouterr().err
    check_output(out, "da3")


def test_sam2_loftr_dust3r_onnx(rgb_only, tiny_sam2, loftr_ckpt, onnx_pair, tmp_path, capsys):
    out = tmp_path / "out"
    argv = ["run", rgb_only, "-o", out, *sam2_loftr(tiny_sam2, loftr_ckpt),
            "--lifter", "dust3r", "--backend-option", f"dust3r.encoder={onnx_pair / 'encoder.onnx'}",
            "--backend-option", "dust3r.iterations=1", "--quiet"]
    code = main([str(a) for a in argv])
    assert code == 0, capsys.readouterr().err
    check_output(out, "dust3r")


def test_missing_checkpoint_fails_before_any_work(rgb_only, tmp_path, capsys):
    code = main([str(a) for a in ["run", rgb_only, "-o", tmp_path / "out", "--segmenter", "sam2", "--lifter", "da3", "--quiet"]])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1 and "sam2.checkpoint" in err
    assert not (tmp_path / "out").exists()
