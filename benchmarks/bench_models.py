"""CPU time and peak memory of the 2D model backends with random weights.

Each case runs in its own process (peak memory = that process's max RSS); the
weights are written first by a separate process, so loading is timed through
the backend exactly as a user's checkpoint would be.

Cases (the sizes users run):

* ``sam2-tiny``, ``sam2-large``: SAM 2.1 at 1024 px on a 640x480 image: load,
  image encoder, one decoder batch of 64 prompts, and the automatic mask
  generator with a ``--grid``-point grid (SAM's default is 32).
* ``loftr``: LoFTR (kornia) on a 640x480 pair at 640x480.
* ``roma``: RoMa outdoor (ViT-L/14 DINOv2 + VGG19), 560x560 coarse and 864x864
  refinement, symmetric, on a 640x480 pair; ``tiny-roma`` at 640x480.
* ``dinov2-vits14``, ``dinov2-vitl14``: features of a 640x480 image at 448 px.

Random weights do not change the cost of a forward pass, but they change how
many SAM candidates pass the IoU/stability filters (so the automask time after
decoding is not representative); the decoder time per batch is.

Usage::

    python benchmarks/bench_models.py                 # all cases
    python benchmarks/bench_models.py --cases loftr roma --grid 16
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CASES = ["sam2-tiny", "sam2-large", "loftr", "roma", "tiny-roma", "dinov2-vits14", "dinov2-vitl14"]


def _pair(h: int = 480, w: int = 640):
    from graphseg.scene import View

    rng = np.random.default_rng(0)
    yy, xx = np.mgrid[0:h, 0:w]
    base = np.stack([(xx * 255 // w), (yy * 255 // h), ((xx + yy) % 256)], -1).astype(np.float64)
    a = np.clip(base + rng.normal(0, 20, base.shape), 0, 255).astype(np.uint8)
    return View("a", a), View("b", np.roll(a, 16, axis=1))


# ----------------------------------------------------------------------------- weights
def prepare(case: str, cache: Path) -> dict[str, str]:
    """Write random weights for ``case`` under ``cache`` (reused when present)."""
    import torch

    torch.manual_seed(0)
    out: dict[str, str] = {}
    if case.startswith("sam2"):
        size = {"sam2-tiny": "t", "sam2-large": "l"}[case]
        name = {"t": "tiny", "l": "large"}[size]
        p = cache / f"sam2.1_hiera_{name}.pt"
        if not p.exists():
            from sam2.build_sam import build_sam2

            m = build_sam2(f"configs/sam2.1/sam2.1_hiera_{size}.yaml", ckpt_path=None, device="cpu")
            torch.save({"model": m.state_dict()}, p)
        out["checkpoint"] = str(p)
    elif case == "loftr":
        p = cache / "loftr_outdoor.ckpt"
        if not p.exists():
            from kornia.feature import LoFTR

            torch.save({"state_dict": LoFTR(pretrained=None).state_dict()}, p)
        out["checkpoint"] = str(p)
    elif case == "roma":
        p, d = cache / "roma_outdoor.pth", cache / "dinov2_vitl14_pretrain.pth"
        if not (p.exists() and d.exists()):
            from graphseg.backends.features.dino import build_dinov2

            dino = build_dinov2("vitl14").state_dict()
            from romatch.models.matcher import RegressionMatcher
            from romatch.models.model_zoo.roma_models import roma_model

            orig = RegressionMatcher.load_state_dict
            RegressionMatcher.load_state_dict = lambda self, sd, strict=True: None  # type: ignore[method-assign]
            try:
                m = roma_model(resolution=(560, 560), upsample_preds=True, device="cpu", weights={}, dinov2_weights=dino, amp_dtype=torch.float32, use_custom_corr=False, upsample_res=(864, 864))
            finally:
                RegressionMatcher.load_state_dict = orig  # type: ignore[method-assign]
            torch.save(dino, d)
            torch.save(m.state_dict(), p)
        out["checkpoint"], out["dinov2_checkpoint"] = str(p), str(d)
    elif case == "tiny-roma":
        p = cache / "tiny_roma_v1_outdoor.pth"
        if not p.exists():
            from graphseg.backends.matchers.romatch_compat import import_romatch

            import_romatch()
            from kornia.feature import XFeatModel
            from romatch.models.model_zoo.roma_models import tiny_roma_v1_model

            torch.save(tiny_roma_v1_model(weights=None, xfeat=XFeatModel()).state_dict(), p)
        out["checkpoint"] = str(p)
    elif case.startswith("dinov2"):
        arch = case.split("-")[1]
        p = cache / f"dinov2_{arch}_pretrain.pth"
        if not p.exists():
            from graphseg.backends.features.dino import build_dinov2

            torch.save(build_dinov2(arch).state_dict(), p)
        out["checkpoint"] = str(p)
    return out


# ----------------------------------------------------------------------------- measure
class _Clock:
    """Records wall time (``NAME_s``) and this process's CPU time over all threads (``NAME_cpu``)."""

    def __init__(self, t: dict[str, object], name: str) -> None:
        self.t, self.name = t, name

    def __enter__(self) -> None:
        self.w, self.c = time.perf_counter(), time.process_time()

    def __exit__(self, *exc: object) -> None:
        self.t[f"{self.name}_s"] = round(time.perf_counter() - self.w, 3)
        self.t[f"{self.name}_cpu"] = round(time.process_time() - self.c, 3)


def measure(case: str, files: dict[str, str], grid: int) -> dict[str, object]:
    """Run one case in this process; returns stage times (wall ``_s`` and CPU ``_cpu`` seconds)."""
    vi, vj = _pair()
    t: dict[str, object] = {}
    if case.startswith("sam2"):
        from graphseg.backends.registry import segmenters
        from graphseg.backends.segmenters.automask import generate_masks
        from graphseg.backends.segmenters.sam import sam2_predictor

        with _Clock(t, "load"):
            seg = segmenters.resolve("sam2", checkpoint=files["checkpoint"], points_per_side=grid)
        with _Clock(t, "encoder"):
            predict = sam2_predictor(seg.model, vi.rgb)
        pts = np.random.default_rng(0).uniform(0, 1, (64, 2)) * [640, 480]
        with _Clock(t, "decoder_batch64"):
            predict(pts, np.ones(64, np.int64))
        with _Clock(t, f"automask_grid{grid}"):
            props = generate_masks(predict, vi.rgb.shape[:2], seg.options)
        t["masks"] = len(props.masks)
        t["grid32_estimate_s"] = round(float(t["encoder_s"]) + 16 * float(t["decoder_batch64_s"]), 2)  # type: ignore[arg-type]
    elif case in ("loftr", "roma", "tiny-roma"):
        from graphseg.backends.matchers.sampling import sample_by_certainty
        from graphseg.backends.registry import matchers

        with _Clock(t, "load"):
            m = matchers.resolve("loftr" if case == "loftr" else "roma", **files)
        with _Clock(t, "match"):
            raw = m.raw_matches(vi, vj)
        with _Clock(t, "sample"):
            out = sample_by_certainty(raw, 10_000, rng=0)
        t["raw_matches"], t["kept"] = len(raw), len(out)
    elif case.startswith("dinov2"):
        from graphseg.backends.registry import features

        with _Clock(t, "load"):
            fx = features.resolve("dinov2", checkpoint=files["checkpoint"], image_size=448)
        with _Clock(t, "features"):
            f = fx(vi)
        t["shape"] = list(f.shape)
    t["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return t


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="*", default=CASES, choices=CASES)
    ap.add_argument("--grid", type=int, default=8, help="automask points per side for the SAM cases (SAM: 32)")
    ap.add_argument("--cache", default=str(Path(tempfile.gettempdir()) / "graphseg-bench-models"))
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "models.json"))
    ap.add_argument("--_run", help=argparse.SUPPRESS)
    ap.add_argument("--_prepare", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    cache = Path(args.cache)
    if args._prepare:
        print(json.dumps(prepare(args._prepare, cache)))
        return 0
    if args._run:
        files = json.loads(Path(cache / f"{args._run}.json").read_text())
        print(json.dumps(measure(args._run, files, args.grid)))
        return 0
    cache.mkdir(parents=True, exist_ok=True)
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    results: dict[str, object] = {}
    load_start = os.getloadavg()[0]
    for case in args.cases:
        p = subprocess.run([sys.executable, __file__, "--_prepare", case, "--cache", str(cache)], capture_output=True, text=True, env=env)
        if p.returncode:
            results[case] = {"error": p.stderr.strip().splitlines()[-1]}
            print(f"{case}: prepare failed: {results[case]}")
            continue
        (cache / f"{case}.json").write_text(p.stdout.strip().splitlines()[-1])
        r = subprocess.run([sys.executable, __file__, "--_run", case, "--cache", str(cache), "--grid", str(args.grid)], capture_output=True, text=True, env=env)
        if r.returncode:
            results[case] = {"error": r.stderr.strip().splitlines()[-1]}
        else:
            results[case] = json.loads(r.stdout.strip().splitlines()[-1])
        print(case, json.dumps(results[case]), flush=True)
    import torch

    meta = {
        "load_average_1min_at_start": load_start,
        "machine": platform.processor() or platform.machine(),
        "cpus": os.cpu_count(),
        "torch_threads": torch.get_num_threads(),
        "load_average_1min_at_end": os.getloadavg()[0],
        "torch": torch.__version__,
        "grid": args.grid,
        "image": "640x480",
    }
    print()
    print("wall seconds (CPU seconds over all threads)")
    print(f"{'case':16s} {'load':>14s}  {'stages':64s} {'peak MB':>8s}")
    for case, r in results.items():
        if not isinstance(r, dict) or "error" in r:
            print(f"{case:16s} error: {r}")
            continue
        stages = ", ".join(f"{k[:-2]}={v:.2f} ({r.get(k[:-2] + '_cpu', float('nan')):.1f})" for k, v in r.items() if k.endswith("_s") and k != "load_s" and not k.endswith("estimate_s"))
        load = f"{r['load_s']:.2f} ({r['load_cpu']:.1f})"
        print(f"{case:16s} {load:>14s}  {stages:64s} {r['peak_rss_mb']:8.0f}")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    old = json.loads(out.read_text()) if out.exists() else {}
    old_results = old.get("results", {}) if isinstance(old, dict) else {}
    out.write_text(json.dumps({"meta": meta, "results": {**old_results, **results}}, indent=2) + "\n")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
