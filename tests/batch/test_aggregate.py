import json

import pytest

from graphseg.batch.aggregate import METRICS, aggregate, to_markdown, write_aggregate


def rec(split, label, views, iou, status="ok"):
    m = {k: iou for k in METRICS}
    return {"status": status, "split": split, "label": label, "num_views": views, "metrics": m if status == "ok" else None,
            "timings": {"segment": 1.0, "graph": 2.0}, "scene": "s", "error": None if status == "ok" else "boom"}


def test_groups_mean_std_and_failures():
    recs = [rec("a", "g", 3, 0.5), rec("a", "g", 3, 1.0), rec("a", "g", 5, 0.9), rec("a", "m", 3, 0.2), rec("a", "g", 3, 0, "failed")]
    agg = aggregate(recs)
    rows = {(r["method"], r["views"]): r for r in agg["rows"]}
    assert rows[("g", 3)]["count"] == 2 and rows[("g", 3)]["failed"] == 1
    assert rows[("g", 3)]["iou_mean"] == pytest.approx(0.75) and rows[("g", 3)]["iou_std"] == pytest.approx(0.25)
    assert rows[("g", 5)]["iou_std"] == 0.0
    assert [r["views"] for r in agg["rows"] if r["method"] == "g"] == [3, 5]  # numeric order
    assert agg["totals"] == {"tasks": 5, "ok": 4, "failed": 1}
    assert agg["failed"][0]["error"] == "boom"
    md = to_markdown(agg)
    assert "| a | g | 3 | 2 | 0.750 ± 0.250" in md and "boom" in md


def test_empty_and_missing_metrics():
    agg = aggregate([{**rec("a", "g", None, 0.5), "metrics": None}])
    assert agg["rows"][0]["iou_mean"] is None and agg["rows"][0]["views"] == "all"
    assert aggregate([]) == {"rows": [], "failed": [], "totals": {"tasks": 0, "ok": 0, "failed": 0}}


def test_write_files(tmp_path):
    paths = write_aggregate(tmp_path, [rec("a", "g", 3, 0.5), rec("a", "g", 5, 0.7)])
    assert set(paths) == {"md", "csv", "json", "png"}
    assert json.loads(paths["json"].read_text())["rows"][1]["iou_mean"] == 0.7
    assert paths["csv"].read_text().splitlines()[0].startswith("split,method,views,count")
    assert paths["png"].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not list(tmp_path.glob(".*tmp*"))
