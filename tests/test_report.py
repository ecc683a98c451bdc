import numpy as np

from graphseg.metrics import evaluate
from graphseg.report import render_report


def _page(metrics):
    return render_report(
        title="t", view_names=["a"], overlays=[np.zeros((4, 4, 3), np.uint8)], points=np.zeros((1, 3)), point_colors=np.zeros((1, 3), np.uint8), metrics=metrics, summary={}
    )


def test_report_counts_objects_and_shows_panoptic_quality():
    gt = [np.array([[1, 1, 0, 0, 2, 2]])]
    metrics = evaluate([np.array([[1, 1, 3, 4, 2, 2]])], gt, [np.zeros((1, 6, 3), np.float32)])
    page = _page(metrics)
    assert "objects: 4 predicted, 2 true" in page
    assert "panoptic quality 0.6667 (SQ 1 &times; RQ 0.6667" in page


def test_report_reads_old_metrics_without_panoptic_keys():
    page = _page({"objects": [], "mean": {"iou": 0.5}, "num_gt": 1, "num_pred": 3})
    assert "objects: 3 predicted, 1 true</p>" in page and "panoptic" not in page
    assert "objects:" not in _page({"objects": [], "mean": {"iou": 0.5}})
