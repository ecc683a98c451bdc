"""The aggregate of a batch: the paper's Table I layout, per-stage timings and a sparse-view plot.

Rows group the finished tasks by (split, method, views) and give count, mean
and standard deviation of IoU, F1, IoU_sel, precision and pixel utility.

Examples
--------
>>> recs = [{"status": "ok", "split": "s", "label": "graphseg", "num_views": 3,
...          "metrics": {"iou": 0.8, "f1": 0.9, "iou_sel": 0.7, "precision": 1.0, "pixel_utility": 0.9},
...          "timings": {"graph": 1.0}},
...         {"status": "ok", "split": "s", "label": "graphseg", "num_views": 3,
...          "metrics": {"iou": 0.6, "f1": 0.7, "iou_sel": 0.5, "precision": 0.8, "pixel_utility": 0.9},
...          "timings": {"graph": 3.0}}]
>>> row = aggregate(recs)["rows"][0]
>>> row["count"], round(row["iou_mean"], 3), round(row["iou_std"], 3), row["graph_s"]
(2, 0.7, 0.1, 2.0)
"""

from __future__ import annotations

import csv
import io
import json
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["METRICS", "aggregate", "write_aggregate", "plot_sparse_views", "to_markdown"]

#: The paper's Table I columns.
METRICS = ("iou", "f1", "iou_sel", "precision", "pixel_utility")


def _views_key(n: Any) -> int:
    return 10**9 if n is None else int(n)


def aggregate(records: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Group finished records by (split, method label, views); mean and std of each metric.

    Returns
    -------
    dict
        ``{"rows": [{"split", "method", "views", "count", "failed", "<m>_mean", "<m>_std", ...,
        "<stage>_s"}], "failed": [{"scene", "method", "views", "error"}], "totals": {...}}``.
        The standard deviation is the population one (``ddof=0``); metrics that are
        missing (a scene without ground truth) are left out of the mean.
    """
    groups: dict[tuple[str, str, Any], list[dict[str, Any]]] = {}
    for r in records:
        groups.setdefault((str(r.get("split")), str(r.get("label")), r.get("num_views")), []).append(r)
    rows = []
    for (split, method, views), recs in sorted(groups.items(), key=lambda kv: (kv[0][0], kv[0][1], _views_key(kv[0][2]))):
        ok = [r for r in recs if r.get("status") == "ok"]
        row: dict[str, Any] = {"split": split, "method": method, "views": "all" if views is None else views, "count": len(ok), "failed": len(recs) - len(ok)}
        for m in METRICS:
            vals = np.array([float(r["metrics"][m]) for r in ok if r.get("metrics") and isinstance(r["metrics"].get(m), (int, float))])
            row[f"{m}_mean"] = float(vals.mean()) if vals.size else None
            row[f"{m}_std"] = float(vals.std()) if vals.size else None
        stages = sorted({k for r in ok for k in (r.get("timings") or {})})
        for st in stages:
            vals = np.array([float(r["timings"][st]) for r in ok if st in (r.get("timings") or {})])
            row[f"{st}_s"] = float(vals.mean())
        rows.append(row)
    failed = [
        {"scene": r.get("scene"), "method": r.get("label"), "views": r.get("num_views"), "error": r.get("error")}
        for r in records
        if r.get("status") != "ok"
    ]
    totals = {"tasks": len(records), "ok": sum(r.get("status") == "ok" for r in records), "failed": len(failed)}
    return {"rows": rows, "failed": failed, "totals": totals}


def _fmt(mean: Any, std: Any) -> str:
    return "-" if mean is None else f"{mean:.3f} ± {std:.3f}"


def to_markdown(agg: dict[str, Any]) -> str:
    """The aggregate as Markdown: the metric table, the timing table and the failures."""
    lines = ["# graphseg batch", "", "## Quality (mean ± std over scenes)", ""]
    head = ["split", "method", "views", "n", *METRICS]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in agg["rows"]:
        cells = [r["split"], r["method"], str(r["views"]), str(r["count"])] + [_fmt(r[f"{m}_mean"], r[f"{m}_std"]) for m in METRICS]
        lines.append("| " + " | ".join(cells) + " |")
    stages = sorted({k[:-2] for r in agg["rows"] for k in r if k.endswith("_s")})
    if stages:
        lines += ["", "## Time per stage (mean seconds per scene)", ""]
        head = ["split", "method", "views", *stages]
        lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        for r in agg["rows"]:
            cells = [r["split"], r["method"], str(r["views"])] + [f"{r[s + '_s']:.2f}" if r.get(s + "_s") is not None else "-" for s in stages]
            lines.append("| " + " | ".join(cells) + " |")
    t = agg["totals"]
    lines += ["", f"{t['ok']} of {t['tasks']} tasks finished, {t['failed']} failed."]
    if agg["failed"]:
        lines += ["", "## Failed", ""]
        lines += [f"- {f['scene']} ({f['method']}, views {f['views'] if f['views'] is not None else 'all'}): {f['error']}" for f in agg["failed"]]
    return "\n".join(lines) + "\n"


def _to_csv(agg: dict[str, Any]) -> str:
    buf = io.StringIO()
    keys: list[str] = []
    for r in agg["rows"]:
        keys += [k for k in r if k not in keys]
    w = csv.DictWriter(buf, fieldnames=keys)
    w.writeheader()
    for r in agg["rows"]:
        w.writerow({k: ("" if r.get(k) is None else r.get(k)) for k in keys})
    return buf.getvalue()


def plot_sparse_views(agg: dict[str, Any], path: str | os.PathLike[str], metric: str = "iou") -> bool:
    """Quality against the number of views, one line per (split, method); returns False without matplotlib."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    fig, ax = plt.subplots(figsize=(6, 4), dpi=100)
    lines: dict[tuple[str, str], list[tuple[int, float, float]]] = {}
    for r in agg["rows"]:
        if isinstance(r["views"], int) and r[f"{metric}_mean"] is not None:
            lines.setdefault((r["split"], r["method"]), []).append((r["views"], r[f"{metric}_mean"], r[f"{metric}_std"]))
    for (split, method), pts in sorted(lines.items()):
        pts.sort()
        x, y, s = (np.array(v) for v in zip(*pts))
        ax.errorbar(x, y, yerr=s, marker="o", capsize=3, label=f"{method} ({split})")
    ax.set_xlabel("views")
    ax.set_ylabel(f"mean {metric}")
    ax.set_ylim(0, 1.02)
    ax.grid(alpha=0.3)
    if lines:
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return True


def _atomic_write(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)


def write_aggregate(out: str | os.PathLike[str], records: Sequence[dict[str, Any]]) -> dict[str, Path]:
    """Write ``aggregate.md``, ``aggregate.csv``, ``aggregate.json`` and ``sparse_views.png`` into ``out``."""
    root = Path(out)
    agg = aggregate(records)
    paths = {"md": root / "aggregate.md", "csv": root / "aggregate.csv", "json": root / "aggregate.json"}
    _atomic_write(paths["md"], to_markdown(agg))
    _atomic_write(paths["csv"], _to_csv(agg))
    _atomic_write(paths["json"], json.dumps(agg, indent=2))
    png = root / "sparse_views.png"
    tmp = root / f".sparse_views.tmp-{os.getpid()}.png"
    if plot_sparse_views(agg, tmp):
        os.replace(tmp, png)
        paths["png"] = png
    return paths
