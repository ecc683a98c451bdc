"""How much the RGB-only benchmark depends on the draw of RANSAC: several ``bench_rgb_only.py`` runs side by side.

Each input is the JSON of one ``bench_rgb_only.py --half all`` run that differs
from the others only in its random draws, for example the default and
``--config`` files setting ``backends.options.sfm.ransac_seed`` (COLMAP's
two-view RANSAC of the matching) or ``backends.options.sfm.seed`` (its mapper).
Nothing is run; the script reads the files.

Per scene: the RGB-only IoU of every draw, their mean and spread (max - min),
and the SfM points, focal length (over the true one) and rotation error of every
draw. Per half: the mean IoU of every draw and the mean over draws, for all
scenes and for the 10-view rings, the largest spread of a half's mean, and how
many scenes moved by more than 0.02 and 0.05.

Writes the tables as Markdown next to the JSON (same name, ``.md``). The output
may not be one of the inputs.

Usage: python benchmarks/rgb_only_draws.py RUN.json RUN.json [...] [--labels A B ...] --json PATH
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, os.path.dirname(__file__))
from _common import print_table, write_json  # noqa: E402


class InputError(ValueError):
    """A run file that cannot be read: one line naming the file and the field."""


def load_run(path: str) -> dict[str, dict[str, Any]]:
    """Rows of one ``bench_rgb_only.py`` JSON by scene name (``half``, ``views``, ``rgb`` IoU and SfM measures)."""
    try:
        data = json.loads(Path(path).read_text())
    except (OSError, ValueError) as err:
        raise InputError(f"{path}: not a readable JSON file ({err.__class__.__name__})") from None
    rows = data.get("rows") if isinstance(data, dict) else None
    if not isinstance(rows, list) or not rows:
        raise InputError(f"{path}: rows: expected the per-scene rows of bench_rgb_only.py")
    out = {}
    for k, r in enumerate(rows):
        rgb = r.get("rgb") if isinstance(r, dict) else None
        if not isinstance(rgb, dict) or not isinstance(rgb.get("iou"), (int, float)) or not isinstance(r.get("name"), str) or r.get("half") not in ("tune", "check"):
            raise InputError(f"{path}: rows[{k}]: expected name, half (tune or check) and rgb.iou")
        out[r["name"]] = {
            "half": r["half"],
            "iou": float(rgb["iou"]),
            "sfm_points": rgb.get("sfm_points"),
            "focal": rgb.get("focal_ratio"),
            "rot_deg": rgb.get("rot_err_deg"),
        }
    return out


def _mean(vals: list[float]) -> float:
    return float(sum(vals) / len(vals)) if vals else float("nan")


def compare(runs: list[dict[str, dict[str, Any]]], labels: list[str]) -> dict[str, Any]:
    """Per-scene and per-half tables of several runs of the same scenes (see the module docstring)."""
    names = list(runs[0])
    for label, run in zip(labels, runs):
        if set(run) != set(names):
            missing = sorted(set(names) ^ set(run))[:3]
            raise InputError(f"{label}: rows: the runs hold different scenes ({', '.join(missing)} ...)")
    scenes = []
    for n in names:
        iou = [run[n]["iou"] for run in runs]
        scenes.append(
            {
                "scene": n,
                "half": runs[0][n]["half"],
                **{f"iou {lab}": v for lab, v in zip(labels, iou)},
                "mean": _mean(iou),
                "spread": max(iou) - min(iou),
                "sfm_points": " / ".join(str(run[n]["sfm_points"]) for run in runs),
                "focal": " / ".join("-" if run[n]["focal"] is None else f"{run[n]['focal']:.2f}" for run in runs),
                "rot_deg": " / ".join("-" if run[n]["rot_deg"] is None else f"{run[n]['rot_deg']:.1f}" for run in runs),
            }
        )
    halves = []
    for half in ("tune", "check"):
        sel = [n for n in names if runs[0][n]["half"] == half]
        rings = [n for n in sel if n.startswith("ring")]
        means = [_mean([run[n]["iou"] for n in sel]) for run in runs]
        ring_means = [_mean([run[n]["iou"] for n in rings]) for run in runs]
        spread = [s["spread"] for s in scenes if s["half"] == half]
        halves.append(
            {
                "half": half,
                "scenes": len(sel),
                **{f"iou {lab}": v for lab, v in zip(labels, means)},
                "iou mean": _mean(means),
                "iou spread": max(means) - min(means),
                **{f"rings {lab}": v for lab, v in zip(labels, ring_means)},
                "rings mean": _mean(ring_means),
                "moved > 0.02": sum(s > 0.02 for s in spread),
                "moved > 0.05": sum(s > 0.05 for s in spread),
            }
        )
    return {"labels": labels, "halves": halves, "scenes": scenes}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+", help="bench_rgb_only.py JSON files of the same scenes")
    ap.add_argument("--labels", nargs="+", help="one name per run (default: the file names)")
    ap.add_argument("--json", required=True, help="output JSON (a .md table is written next to it)")
    args = ap.parse_args(argv)
    labels = args.labels or [Path(p).stem for p in args.runs]
    try:
        if len(args.runs) < 2:
            raise InputError(f"{args.runs[0]}: runs: expected at least two runs to compare")
        if len(labels) != len(args.runs):
            raise InputError(f"--labels: expected {len(args.runs)} labels (got {len(labels)})")
        out = Path(args.json).resolve()
        if out in {Path(p).resolve() for p in args.runs} or out.with_suffix(".md") in {Path(p).resolve() for p in args.runs}:
            raise InputError(f"{args.json}: --json: the output would replace one of the inputs")
        result = compare([load_run(p) for p in args.runs], labels)
    except InputError as err:
        print(f"rgb_only_draws: error: {err}", file=sys.stderr)
        return 2
    half_cols = ["half", "scenes", *[f"iou {lab}" for lab in labels], "iou mean", "iou spread", *[f"rings {lab}" for lab in labels], "rings mean", "moved > 0.02", "moved > 0.05"]
    scene_cols = ["scene", "half", *[f"iou {lab}" for lab in labels], "mean", "spread", "sfm_points", "focal", "rot_deg"]
    md = ["# RGB-only IoU over draws of RANSAC", "", "Runs: " + ", ".join(f"`{lab}` = `{p}`" for lab, p in zip(labels, args.runs)), "", "## Per half", ""]
    md.append(print_table(result["halves"], half_cols))
    md += ["", "## Per scene", ""]
    md.append(print_table(result["scenes"], scene_cols))
    write_json(args.json, {"argv": sys.argv[1:] if argv is None else argv, "runs": args.runs, **result})
    Path(args.json).with_suffix(".md").write_text("\n".join(md) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
