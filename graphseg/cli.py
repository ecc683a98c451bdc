"""The ``graphseg`` command.

Exit codes: 0 success; 2 bad input (one line naming the file and the field, no
traceback, no output folder left behind); 1 internal error.

Commands: ``run``, ``eval``, ``synth``, ``demo``, ``export``, ``info``
(``graphseg COMMAND --help`` for each).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import traceback
from pathlib import Path
from typing import Any

__all__ = ["main", "build_parser"]


class BadInput(Exception):
    """A user-facing input problem (exit code 2)."""


def _views_args(p: argparse.ArgumentParser) -> None:
    g = p.add_mutually_exclusive_group()
    g.add_argument("--views", help="comma-separated view indices or names, e.g. 0,5,10")
    g.add_argument("--step", type=int, help="every N-th view")
    g.add_argument("--num-views", type=int, help="N views evenly spaced")


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="graphseg", description="Consistent object-level 3D segments from a few RGB(-D) views (GraphSeg).")
    ap.add_argument("--version", action="store_true", help="print the version and exit")
    sub = ap.add_subparsers(dest="command")

    r = sub.add_parser("run", help="segment a scene and write the output folder")
    r.add_argument("scene", help="scene folder (native, plain images, YCB-Video, GraspNet-1B or BOP)")
    r.add_argument("-o", "--out", required=True, help="output folder (replaced if it exists)")
    r.add_argument("--config", help="YAML/JSON config file (overrides --preset)")
    r.add_argument("--preset", default="rgbd", choices=["rgbd", "paper"], help="configuration preset when no --config is given (default: rgbd, measured for metric RGB-D; paper: the paper's thresholds)")
    r.add_argument("--segmenter", help="segmenter name (default from the config: geometric)")
    r.add_argument("--matcher", help="matcher name (default: reprojection)")
    r.add_argument("--lifter", help="lifter name (default: rgbd when the scene has no point maps)")
    r.add_argument("--masks", help="folder of precomputed masks per view (NAME.png label images or NAME.npz bool stacks); implies --segmenter precomputed")
    r.add_argument("--parts", type=int, help="parts per object for the oracle-parts segmenter (evaluation only)")
    r.add_argument("--no-3d", action="store_true", help="GraphSeg-minus: skip the 3D stage")
    r.add_argument("--seed", type=int, help="random seed")
    r.add_argument("--quiet", action="store_true", help="no progress bars")
    _views_args(r)

    e = sub.add_parser("eval", help="print the metrics of an output folder against ground truth")
    e.add_argument("out", help="output folder of graphseg run")
    e.add_argument("--scene", help="scene with ground truth (default: the one recorded in run.json)")
    e.add_argument("--json", help="also write the metrics to this JSON file")

    s = sub.add_parser("synth", help="render a synthetic scene with exact ground truth (needs pybullet: graphseg[sim])")
    s.add_argument("-o", "--out", required=True)
    s.add_argument("--seed", type=int, default=0)
    s.add_argument("--objects", type=int, default=6)
    s.add_argument("--views", type=int, default=8)
    s.add_argument("--size", default="640x480", help="WIDTHxHEIGHT")

    d = sub.add_parser("demo", help="synthesise a scene, segment it, evaluate and write a report")
    d.add_argument("-o", "--out", default="graphseg-demo")
    d.add_argument("--seed", type=int, default=0)
    d.add_argument("--views", type=int, default=8)
    d.add_argument("--objects", type=int, default=6)
    d.add_argument("--preset", default="rgbd", choices=["rgbd", "paper"])
    d.add_argument("--quiet", action="store_true")

    x = sub.add_parser("export", help="export graphs / point clouds of an output folder")
    x.add_argument("out")
    x.add_argument("--graphml", help="write the 2D graph as GraphML here (the 3D graph goes next to it as *_3d.graphml)")
    x.add_argument("--pyg", help="write the 2D graph as a torch file of PyG tensors (needs graphseg[torch])")
    x.add_argument("--ply", help="write one PLY per object into this folder")

    i = sub.add_parser("info", help="describe an output folder or a scene")
    i.add_argument("path")

    b = sub.add_parser("batch", help="run many scenes x methods x view counts (resumable; local processes or Ray)")
    b.add_argument("scenes", nargs="*", help="scene folders, glob patterns, or a dataset root with --split / --videos")
    b.add_argument("-o", "--out", help="batch output folder (new, or an earlier batch output to resume)")
    b.add_argument("--split", help="GraspNet-1Billion split of a dataset root: train, test_seen, test_similar, test_novel, test")
    b.add_argument("--videos", help="YCB-Video video ids of a dataset root, e.g. 0048,0049")
    b.add_argument("--method", help="comma-separated methods: graphseg, graphseg-minus (default graphseg unless --config is given)")
    b.add_argument("--config", action="append", help="config file swept as one more configuration (repeatable)")
    b.add_argument("--preset", default="rgbd", choices=["rgbd", "paper"], help="preset the methods start from")
    b.add_argument("--num-views", default="all", help="comma-separated view counts, e.g. 3,5,10 ('all' = every view)")
    b.add_argument("--segmenter", help="segmenter name")
    b.add_argument("--matcher", help="matcher name")
    b.add_argument("--lifter", help="lifter name")
    b.add_argument("--jobs", type=int, default=1, help="local worker processes (default 1)")
    b.add_argument("--ray", action="store_true", help="run the tasks on Ray (pip install \"graphseg[ray]\")")
    b.add_argument("--ray-address", help="existing Ray cluster: auto or ray://host:port (default: start a local Ray)")
    b.add_argument("--ray-cpus", type=float, default=1.0, help="CPUs per Ray task")
    b.add_argument("--ray-gpus", default="auto", help="GPUs per Ray task (auto: 1 for model backends when the cluster has GPUs)")
    b.add_argument("--retries", type=int, default=2, help="Ray retries of a task whose worker died")
    b.add_argument("--report", metavar="OUT", help="only rebuild the aggregate of an existing batch folder")
    b.add_argument("--quiet", action="store_true", help="no progress bar")
    return ap


# ----------------------------------------------------------------------------- helpers
def _parse_size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(t) for t in text.lower().split("x"))
    except ValueError as err:
        raise BadInput(f"--size: expected WIDTHxHEIGHT (got {text!r})") from err
    if w < 16 or h < 16:
        raise BadInput(f"--size: too small ({w}x{h})")
    return w, h


def _selection(args: argparse.Namespace) -> dict[str, Any]:
    from .io import parse_views

    return {
        "views": parse_views(args.views) if getattr(args, "views", None) else None,
        "step": getattr(args, "step", None),
        "num_views": getattr(args, "num_views", None),
    }


def _metrics_table(metrics: dict[str, Any]) -> str:
    keys = ["iou", "f1", "chamfer", "iou_sel", "precision"]
    lines = [f"{'object':<28}" + "".join(f"{k:>10}" for k in keys)]

    def f(v: Any, k: str) -> str:
        if not isinstance(v, (int, float)):
            return f"{'-':>10}"
        return f"{v:>10.2e}" if k == "chamfer" else f"{v:>10.4f}"

    for o in metrics["objects"]:
        lines.append(f"{str(o.get('name', o['id']))[:27]:<28}" + "".join(f(o.get(k), k) for k in keys))
    m = metrics["mean"]
    lines.append(f"{'mean':<28}" + "".join(f(m.get(k), k) for k in keys))
    lines.append(f"pixel utility: {m['pixel_utility']:.4f}" if m.get("pixel_utility") is not None else "pixel utility: -")
    return "\n".join(lines)


def _evaluate(result: Any, scene: Any) -> dict[str, Any] | None:
    from .metrics import evaluate

    if not scene.has_instances or not scene.has_points:
        return None
    return evaluate(result.labels, [v.instances for v in scene.views], [v.points for v in scene.views], names=scene.objects)


def _run_scene(scene: Any, cfg: Any, out: Path, *, segmenter: Any, matcher: Any, lifter: Any, progress: bool, run_info: dict[str, Any]) -> tuple[Any, dict[str, Any] | None, Path]:
    from .output import write_output
    from .pipeline import lift, run

    scene = lift(scene, lifter, cfg)  # lifted once: run() reuses it and the metrics need its points
    result = run(scene, cfg, segmenter=segmenter, matcher=matcher, progress=progress)
    metrics = _evaluate(result, scene)
    try:
        path = write_output(out, result, scene, metrics=metrics, run_info=run_info)
    except OSError as err:
        raise BadInput(f"{out}: output: cannot write ({err.strerror or err})") from err
    return result, metrics, path


def _check_output_target(out: Path) -> None:
    parent = out.resolve().parent
    probe = parent
    while not probe.exists():
        probe = probe.parent
    if not probe.is_dir():
        raise BadInput(f"{out}: output: the parent path {probe} is not a folder")
    if out.exists() and not out.is_dir():
        raise BadInput(f"{out}: output: exists and is not a folder")


def _config(args: argparse.Namespace) -> Any:
    from .config import Config

    cfg = Config.preset(getattr(args, "preset", None) or "rgbd")
    if getattr(args, "config", None):
        import yaml
        from pydantic import ValidationError

        path = Path(args.config)
        if not path.is_file():
            raise BadInput(f"{path}: config: file not found")
        try:
            cfg = Config.load(path)
        except ValidationError as err:
            first = err.errors()[0]
            raise BadInput(f"{path}: {'.'.join(str(x) for x in first['loc'])}: {first['msg']}") from err
        except (yaml.YAMLError, json.JSONDecodeError, ValueError) as err:
            raise BadInput(f"{path}: config: {str(err).splitlines()[0]}") from err
    if getattr(args, "seed", None) is not None:
        cfg = cfg.model_copy(update={"seed": args.seed})
    if getattr(args, "no_3d", False):
        cfg = cfg.without_3d()
    if getattr(args, "masks", None):
        folder = Path(args.masks)
        if not folder.is_dir():
            raise BadInput(f"{folder}: masks: no such folder")
        if args.segmenter not in (None, "precomputed"):
            raise BadInput(f"{folder}: masks: --masks needs the precomputed segmenter (got --segmenter {args.segmenter})")
        args.segmenter = "precomputed"
        cfg = _with_backend_options(cfg, "precomputed", folder=str(folder.resolve()))
    if getattr(args, "parts", None) is not None:
        cfg = _with_backend_options(cfg, "oracle-parts", parts=args.parts)
    return cfg


def _with_backend_options(cfg: Any, backend: str, **options: Any) -> Any:
    """A copy of ``cfg`` whose ``backends.options[backend]`` gains ``options``."""
    opts = dict(cfg.backends.options)
    opts[backend] = {**opts.get(backend, {}), **options}
    return cfg.model_copy(update={"backends": cfg.backends.model_copy(update={"options": opts})})


# ----------------------------------------------------------------------------- commands
def cmd_run(args: argparse.Namespace) -> int:
    from .io import detect_format, load_scene

    out = Path(args.out)
    cfg = _config(args)
    fmt = detect_format(args.scene)
    scene = load_scene(args.scene, format=fmt, **_selection(args))
    _check_output_target(out)
    t = time.perf_counter()
    info = {"scene": str(Path(args.scene).resolve()), "format": fmt, "views": [v.name for v in scene.views]}
    result, metrics, path = _run_scene(scene, cfg, out, segmenter=args.segmenter, matcher=args.matcher, lifter=args.lifter, progress=not args.quiet, run_info=info)
    print(f"{result.num_objects} objects in {len(scene)} views ({time.perf_counter() - t:.1f} s)")
    if metrics:
        print(_metrics_table(metrics))
    print(f"output: {path}")
    print(f"report: {path / 'report.html'}")
    return 0


def cmd_eval(args: argparse.Namespace) -> int:
    from .io import load_scene
    from .output import read_output
    from .pipeline import lift

    result, info = read_output(args.out)
    scene_path = args.scene or info.get("scene")
    if not scene_path:
        raise BadInput(f"{args.out}: scene: run.json names no scene; pass --scene")
    scene = load_scene(scene_path, format=info.get("format") if not args.scene else None, views=result.view_names)
    if [v.name for v in scene.views] != result.view_names:
        raise BadInput(f"{scene_path}: views: the scene's views differ from the result's")
    if not scene.has_instances:
        raise BadInput(f"{scene_path}: instances: the scene has no ground truth")
    scene = lift(scene, None, result.config)
    metrics = _evaluate(result, scene)
    assert metrics is not None
    print(_metrics_table(metrics))
    if args.json:
        Path(args.json).write_text(json.dumps(metrics, indent=2))
        print(f"wrote {args.json}")
    return 0


def _synthesize(seed: int, objects: int, views: int, size: tuple[int, int]) -> Any:
    """A pybullet scene; raises MissingDependencyError (naming graphseg[sim]) without pybullet."""
    from .sim.pybullet_scenes import synthesize

    return synthesize(seed=seed, objects=objects, views=views, size=size)


def cmd_synth(args: argparse.Namespace) -> int:
    from .io import write_scene_folder

    size = _parse_size(args.size)
    out = Path(args.out)
    _check_output_target(out)
    t = time.perf_counter()
    scene = _synthesize(args.seed, args.objects, args.views, size)
    try:
        write_scene_folder(scene, out, overwrite=True)
    except OSError as err:
        raise BadInput(f"{out}: output: cannot write ({err.strerror or err})") from err
    print(f"wrote {out} ({len(scene)} views, {len(scene.objects)} objects, {time.perf_counter() - t:.1f} s)")
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    import warnings

    from .config import Config
    from .io import write_scene_folder
    from .registry import MissingDependencyError

    out = Path(args.out)
    _check_output_target(out)
    t0 = time.perf_counter()
    try:
        scene = _synthesize(args.seed, args.objects, args.views, (640, 480))
        source = "pybullet"
    except MissingDependencyError:
        from .testing.scenes import demo_box_scene

        warnings.warn("pybullet is not installed (pip install \"graphseg[sim]\"); the demo uses the built-in box renderer", stacklevel=1)
        scene = demo_box_scene(seed=args.seed, views=args.views, objects=args.objects)
        source = "boxes"
    out.mkdir(parents=True, exist_ok=True)
    write_scene_folder(scene, out / "scene", overwrite=True)
    info = {"scene": str((out / "scene").resolve()), "format": "native", "views": [v.name for v in scene.views], "source": source}
    result, metrics, path = _run_scene(scene, Config.preset(args.preset, seed=args.seed), out / "output", segmenter=None, matcher=None, lifter=None, progress=not args.quiet, run_info=info)
    print(f"demo: {len(scene)} views, {len(scene.objects)} objects ({source}); found {result.num_objects} objects in {time.perf_counter() - t0:.1f} s")
    if metrics:
        print(_metrics_table(metrics))
    print(f"report: {path / 'report.html'}")
    return 0


def cmd_export(args: argparse.Namespace) -> int:
    from .graphs import to_pyg, write_graphml
    from .output import read_output, write_object_clouds

    result, _ = read_output(args.out)
    if not (args.graphml or args.pyg or args.ply):
        raise BadInput(f"{args.out}: export: name at least one of --graphml, --pyg, --ply")
    if args.graphml:
        write_graphml(result.graph_2d, args.graphml)
        print(f"wrote {args.graphml}")
        if result.graph_3d is not None:
            p = Path(args.graphml)
            p3 = p.with_name(p.stem + "_3d" + p.suffix)
            write_graphml(result.graph_3d, p3)
            print(f"wrote {p3}")
    if args.pyg:
        import torch

        torch.save(to_pyg(result.graph_2d), args.pyg)
        print(f"wrote {args.pyg}")
    if args.ply:
        n = write_object_clouds(result, args.ply)
        print(f"wrote {n} PLY files to {args.ply}")
    return 0


def cmd_info(args: argparse.Namespace) -> int:
    from .io import detect_format, load_scene
    from .output import RESULT_FILE, read_output

    p = Path(args.path)
    if (p / RESULT_FILE).exists():
        result, info = read_output(p)
        print(f"graphseg output: {p}")
        print(f"  scene: {info.get('scene', '?')}")
        print(f"  views: {len(result.view_names)} ({', '.join(result.view_names[:8])}{' ...' if len(result.view_names) > 8 else ''})")
        print(f"  objects: {result.num_objects}")
        print(f"  masks: {len(result.mask_object)}; stages: {' -> '.join('+'.join(s) for s in result.config.stages)}")
        for s, g in enumerate(result.graphs):
            print(f"  stage {s}: {g.num_nodes} nodes, {g.num_edges} edges")
        if (p / "metrics.json").exists():
            m = json.loads((p / "metrics.json").read_text())["mean"]
            print("  mean: " + ", ".join(f"{k}={v:.4f}" for k, v in m.items() if isinstance(v, (int, float))))
        return 0
    fmt = detect_format(p)
    scene = load_scene(p, format=fmt)
    h, w = scene.views[0].shape
    print(f"scene: {p} (format {fmt})")
    print(f"  views: {len(scene)} of {w}x{h}")
    print(f"  depth: {'yes' if scene.has_depth else 'no'}; poses: {'yes' if scene.has_poses else 'no'}; ground truth: {'yes' if scene.has_instances else 'no'}")
    if scene.objects:
        print(f"  objects: {', '.join(f'{k}={n}' for k, n in sorted(scene.objects.items()))}")
    return 0


def _num_views_list(text: str) -> list[int | None]:
    out: list[int | None] = []
    for part in text.split(","):
        part = part.strip().lower()
        if part == "all":
            out.append(None)
        elif part.isdigit() and int(part) >= 1:
            out.append(int(part))
        else:
            raise BadInput(f"--num-views: expected view counts >= 1 or 'all' (got {part!r})")
    return out


def cmd_batch(args: argparse.Namespace) -> int:
    from .batch import LocalExecutor, RayExecutor, rebuild_report, run_batch

    if args.report:
        s = rebuild_report(args.report)
        print(f"aggregate of {s.tasks} tasks ({s.failed} failed): {s.files['md']}")
        return s.exit_code
    if not args.scenes or not args.out:
        raise BadInput("batch: give SCENES and -o OUT (or --report OUT)")
    if args.jobs < 1:
        raise BadInput(f"--jobs: expected >= 1 (got {args.jobs})")
    gpus: float | str = args.ray_gpus
    if gpus != "auto":
        try:
            gpus = float(gpus)
        except ValueError as err:
            raise BadInput(f"--ray-gpus: expected a number or auto (got {args.ray_gpus!r})") from err
    executor: Any = LocalExecutor(args.jobs)
    if args.ray or args.ray_address:
        executor = RayExecutor(args.ray_address, num_cpus=args.jobs if args.jobs > 1 else None, cpus_per_task=args.ray_cpus, gpus_per_task=gpus, max_retries=args.retries)
    methods = [m.strip() for m in args.method.split(",") if m.strip()] if args.method else None
    s = run_batch(
        args.scenes,
        args.out,
        methods=methods,
        config_files=args.config,
        preset=args.preset,
        num_views=_num_views_list(args.num_views),
        split=args.split,
        videos=[v.strip() for v in args.videos.split(",") if v.strip()] if args.videos else None,
        backends={"segmenter": args.segmenter, "matcher": args.matcher, "lifter": args.lifter},
        executor=executor,
        progress=not args.quiet,
    )
    print(f"{s.tasks} tasks: {s.ok} finished ({s.skipped} already done), {s.failed} failed ({s.seconds:.1f} s)")
    for r in s.records:
        if r["status"] != "ok":
            print(f"failed: {r['scene']} ({r['label']}, views {r['num_views'] or 'all'}): {r['error']}")
    print(f"aggregate: {s.files['md']}")
    return s.exit_code


COMMANDS = {"batch": cmd_batch, "run": cmd_run, "eval": cmd_eval, "synth": cmd_synth, "demo": cmd_demo, "export": cmd_export, "info": cmd_info}


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script; returns the exit code."""
    from pydantic import ValidationError

    from .graphs import GraphValidationError
    from .registry import MissingDependencyError, PluginNotFoundError
    from .scene import SceneError

    ap = build_parser()
    args = ap.parse_args(argv)
    if args.version:
        from . import __version__

        print(__version__)
        return 0
    if not args.command:
        ap.print_help()
        return 2
    try:
        return COMMANDS[args.command](args)
    except (SceneError, BadInput, PluginNotFoundError, MissingDependencyError, GraphValidationError) as err:
        print(f"graphseg: error: {err}".splitlines()[0], file=sys.stderr)
        return 2
    except ValidationError as err:
        first = err.errors()[0]
        loc = ".".join(str(x) for x in first["loc"])
        print(f"graphseg: error: {getattr(args, 'config', None) or 'config'}: {loc}: {first['msg']}", file=sys.stderr)
        return 2
    except FileNotFoundError as err:
        print(f"graphseg: error: {err.filename}: path: not found", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130
    except Exception:
        traceback.print_exc()
        print("graphseg: internal error (see the traceback above)", file=sys.stderr)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
