"""The ``graphseg`` command: parses arguments and prints; the work is :func:`graphseg.job.run_job`.

Exit codes: 0 success; 2 bad input (one line ``graphseg: error: FILE: FIELD: what
is wrong``, no traceback, nothing left behind), bad arguments included (one line
``graphseg: error: --preset: invalid choice 'robsut'; did you mean 'robust'? ...``,
no usage block); 1 internal error (one line; pass ``--debug`` for the traceback);
130 / 143 when interrupted by SIGINT / SIGTERM ("interrupted; nothing written");
141 (128 + SIGPIPE, like ``cat`` or ``yes``) when the reader of standard output
went away, as in ``graphseg info OUT | head -1``: nothing is printed on stderr,
and the output files of ``run`` are complete (they are written before anything
is printed).

Commands: ``run``, ``eval``, ``synth``, ``demo``, ``export``, ``info``, ``batch``,
``add`` (a store that grows view by view, :mod:`graphseg.store`; ``run``, ``eval``,
``export`` and ``info`` accept a store too), ``suggest`` (the next view of a store)
(``graphseg COMMAND --help`` for each).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import re
import signal
import sys
import time
import traceback
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any, NoReturn, TextIO

from .presets import (  # plain data: the CLI imports no pydantic at start
    DEFAULT_PRESET,
    PRESET_NAMES,
)

__all__ = ["main", "build_parser", "parse_backend_option", "PRESET_NAMES"]


#: Exit status when standard output was closed by its reader (128 + SIGPIPE).
EXIT_BROKEN_PIPE = 141


class BadInput(Exception):
    """A user-facing input problem (exit code 2)."""


@contextlib.contextmanager
def _jobs(args: argparse.Namespace) -> Iterator[None]:
    """The worker processes of a command (``--jobs``, else ``GRAPHSEG_JOBS``, else the cores; :mod:`graphseg.parallel`)."""
    from .parallel import ENV, job_count, jobs

    n = getattr(args, "jobs", None)
    if n is not None and n < 1:
        raise BadInput(f"--jobs: expected an integer >= 1 (got {n})")
    if n is None:
        try:
            job_count()
        except ValueError as err:
            raise BadInput(f"environment variable {ENV}: {str(err).split(': ', 1)[1]}") from None
    with jobs(n):
        yield


class Terminated(KeyboardInterrupt):
    """Raised by the SIGTERM handler so that every ``finally`` cleans up."""


def _did_you_mean(word: str, choices: Sequence[str]) -> str:
    from .graphs.criterion import did_you_mean

    return did_you_mean(word, choices)


def _argument_message(parser: argparse.ArgumentParser, message: str) -> str:
    """argparse's error ``message`` rewritten as graphseg's one line ``FIELD: what is wrong``.

    Examples
    --------
    >>> p = argparse.ArgumentParser(prog="graphseg run")
    >>> _argument_message(p, "argument --seed: invalid int value: 'abc'")
    "--seed: expected an integer (got 'abc')"
    >>> _argument_message(p, "the following arguments are required: scene, -o/--out")
    'scene, -o/--out: required by graphseg run (see graphseg run --help)'
    >>> _argument_message(p, "argument --step: not allowed with argument --views")
    '--step: not allowed with --views'
    """
    m = re.fullmatch(r"the following arguments are required: (.*)", message)
    if m:
        return f"{m.group(1)}: required by {parser.prog} (see {parser.prog} --help)"
    m = re.fullmatch(r"ambiguous option: (\S+) could match (.*)", message)
    if m:
        return f"{m.group(1)}: ambiguous option; it could be {m.group(2)}"
    m = re.fullmatch(r"argument (.+?): (.*)", message, flags=re.S)
    if not m:
        return message
    name, what = m.group(1), m.group(2)
    kinds = {"int": "an integer", "float": "a number"}
    bad = re.fullmatch(r"invalid (\w+) value: (.*)", what)
    if bad:
        what = f"expected {kinds.get(bad.group(1), bad.group(1))} (got {bad.group(2)})"
    return f"{name}: {what.replace('argument ', '')}"


class ArgumentParser(argparse.ArgumentParser):
    """argparse with graphseg's errors: one line ``graphseg: error: FIELD: what is wrong``, exit 2.

    No usage block is printed. An invalid choice, a misspelt subcommand and an
    unknown option name the closest valid one. Sub-command parsers are of this
    class too (``add_subparsers`` uses the parent's class).
    """

    def error(self, message: str) -> NoReturn:
        _error(_argument_message(self, message))
        self.exit(2)

    def _check_value(self, action: argparse.Action, value: Any) -> None:
        """An invalid choice as one line: ``--preset: invalid choice 'robsut'; did you mean 'robust'? (choose from ...)``.

        A subcommand reads ``unknown command 'rnu'; did you mean 'run'? (commands: run, ...)``
        (the hint only when one is close, :func:`difflib.get_close_matches`).
        """
        if action.choices is not None and value not in action.choices:
            choices = [str(c) for c in action.choices]
            hint = _did_you_mean(str(value), choices)
            hint = f"; {hint}" if hint else ""
            if isinstance(action, argparse._SubParsersAction):  # no "argument command:" prefix
                raise argparse.ArgumentError(None, f"unknown command {value!r}{hint} (commands: {', '.join(choices)})")
            raise argparse.ArgumentError(action, f"invalid choice {value!r}{hint} (choose from {', '.join(choices)})")

    def parse_args(self, args: Sequence[str] | None = None, namespace: Any = None) -> Any:  # type: ignore[override]
        ns, extras = self.parse_known_args(args, namespace)
        if extras:
            parser: argparse.ArgumentParser = self
            for action in self._actions:  # unknown arguments of a sub-command: name its options
                if isinstance(action, argparse._SubParsersAction) and getattr(ns, action.dest, None) in action.choices:
                    parser = action.choices[getattr(ns, action.dest)]
            option = next((e.split("=", 1)[0] for e in extras if e.startswith("-") and e != "-"), None)
            if option is not None:
                hint = _did_you_mean(option, [o for a in parser._actions for o in a.option_strings])
                parser.error(f"{option}: unknown option; " + (hint or f"see {parser.prog} --help"))
            parser.error(f"{parser.prog.split()[-1]}: unexpected argument {extras[0]!r} (see {parser.prog} --help)")
        return ns


def _views_args(p: argparse.ArgumentParser) -> None:
    g = p.add_mutually_exclusive_group()
    g.add_argument("--views", help="comma-separated view names or indices, e.g. 000001,000006 or 0,5,10 (each entry is matched against the view names first, then read as an index)")
    g.add_argument("--step", type=int, help="every N-th view")
    g.add_argument("--num-views", type=int, help="N views evenly spaced")


def _common(p: argparse.ArgumentParser, *, overwrite: bool = False) -> None:
    p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help="print the traceback of an internal error")
    p.add_argument("--quiet", action="store_true", default=argparse.SUPPRESS, help="no progress bars, no third-party banners or warnings")
    if overwrite:
        p.add_argument("--overwrite", action="store_true", help="replace an existing target that is not an earlier graphseg output of this command (never an input of the command)")


def build_parser() -> argparse.ArgumentParser:
    ap = ArgumentParser(prog="graphseg", description="Consistent object-level 3D segments from a few RGB(-D) views (GraphSeg).")
    ap.add_argument("--version", action="store_true", help="print the version and exit")
    ap.add_argument("--debug", action="store_true", help="print the traceback of an internal error")
    ap.add_argument("--quiet", action="store_true", help="no progress bars, no third-party banners or warnings")
    sub = ap.add_subparsers(dest="command")

    r = sub.add_parser("run", help="segment a scene and write the output folder")
    r.add_argument("scene", help="scene folder (native, plain images, YCB-Video, GraspNet-1B or BOP), or a store (graphseg add): its current result is written")
    r.add_argument("-o", "--out", required=True, help="output folder: must not exist, or be an earlier `graphseg run` output (else pass --overwrite)")
    r.add_argument("--config", help="YAML/JSON config file; its keys override the --preset in use")
    r.add_argument("--preset", default=DEFAULT_PRESET, choices=PRESET_NAMES, help="configuration preset (default: %(default)s; rgbd: measured for metric RGB-D; paper: the paper's thresholds; robust: rgbd with cannot-links at concave creases and jumps over 10 cm, smooth_adjacency, DBSCAN-cleaned Chamfer points and the constrained contractor; multicut: robust with greedy additive edge contraction and no colour test in smooth_adjacency); --config overrides it key by key")
    r.add_argument("--segmenter", help="segmenter name (default from the config: geometric)")
    r.add_argument("--matcher", help="matcher name (default: reprojection)")
    r.add_argument("--lifter", help="lifter name (default: rgbd when the scene has depth, sfm when it has none)")
    r.add_argument("--backend-option", action="append", default=[], metavar="NAME.KEY=VALUE", help="option KEY of backend NAME (VALUE read as a YAML scalar); repeatable; stored in config backends.options")
    r.add_argument("--masks", help="folder of precomputed masks per view (NAME.png label images or NAME.npz bool stacks); implies --segmenter precomputed")
    r.add_argument("--matches", help="folder of precomputed matches per view pair (VIEWI__VIEWJ.npz, docs/formats.md); implies --matcher precomputed-matches")
    r.add_argument("--points", help="folder of precomputed world point maps per view (VIEW.npz, docs/formats.md); implies --lifter precomputed-points")
    r.add_argument("--parts", type=int, help="parts per object for the oracle-parts segmenter (evaluation only)")
    r.add_argument("--no-3d", action="store_true", help="GraphSeg-minus: skip the 3D stage")
    r.add_argument("--method", choices=["graphseg", "graphseg-minus", "maskclustering", "sam3d"], help="method (default from the config: graphseg); maskclustering and sam3d are baselines on the same inputs")
    r.add_argument("--seed", type=int, help="random seed (>= 0)")
    r.add_argument("--jobs", type=int, help="worker processes for the views and pairs (default: GRAPHSEG_JOBS, else the cores; 1: one process); the output is the same for any count")
    _views_args(r)
    _common(r, overwrite=True)

    e = sub.add_parser("eval", help="print the metrics of an output folder against ground truth")
    e.add_argument("out", help="output folder of graphseg run, or a store (graphseg add)")
    e.add_argument("--scene", help="scene with ground truth (default: the one recorded in run.json); its view names must match")
    e.add_argument("--json", help="also write the metrics to this JSON file (a new file, or --overwrite)")
    e.add_argument("--audit", action="store_true", help="also audit the edges against the ground truth (wrong edges per stage, impure masks, min cut per merge error); with --json the audit is written under the key 'audit'")
    _common(e, overwrite=True)

    s = sub.add_parser("synth", help="render a synthetic scene with exact ground truth (needs pybullet: graphseg[sim])")
    s.add_argument("-o", "--out", required=True, help="scene folder to write: must not exist, or be an earlier `graphseg synth` output")
    s.add_argument("--seed", type=int, default=0)
    s.add_argument("--objects", type=int, default=6, help="objects dropped on the table (1..16); those that fall off are reported")
    s.add_argument("--views", type=int, default=8, help="number of views (1..360)")
    s.add_argument("--size", default="640x480", help="WIDTHxHEIGHT")
    s.add_argument("--arc", type=float, default=360.0, metavar="DEG", help="cameras on an arc of DEG degrees (a narrow wrist-camera sweep) instead of the full ring (default 360)")
    s.add_argument("--no-depth", action="store_true", help="write RGB, intrinsics and ground truth only: no depth, no poses (an RGB-only scene)")
    s.add_argument("--no-intrinsics", action="store_true", help="with --no-depth: leave out K too")
    s.add_argument("--layout", default="spread", choices=["spread", "touching", "stacked"], help="stress set: objects touching or stacked (default: spread apart)")
    _common(s, overwrite=True)

    d = sub.add_parser("demo", help="synthesise a scene, segment it, evaluate and write a report")
    d.add_argument("-o", "--out", default="graphseg-demo")
    d.add_argument("--seed", type=int, default=0)
    d.add_argument("--views", type=int, default=8, help="number of views (1..360)")
    d.add_argument("--objects", type=int, default=6, help="objects (1..16)")
    d.add_argument("--preset", default=DEFAULT_PRESET, choices=PRESET_NAMES)
    _common(d, overwrite=True)

    x = sub.add_parser("export", help="export graphs / point clouds of an output folder")
    x.add_argument("out", help="output folder of graphseg run, or a store (graphseg add)")
    x.add_argument("--stage", type=int, help="stage to export (0 = the mask graph); default: every stage for --graphml, stage 0 for --pyg")
    x.add_argument("--graphml", help="write the graph of --stage as GraphML here; without --stage, stage 0 here, stage S next to it as NAME_stageS.graphml and the objects graph (mask fragments, the steps after the last contraction, each node's object) as NAME_objects.graphml")
    x.add_argument("--pyg", help="write the graph of --stage (default 0) as a dict of torch tensors, readable with plain torch.load(path) (needs graphseg[torch])")
    x.add_argument("--ply", help="write one PLY per object into this folder")
    _common(x, overwrite=True)

    i = sub.add_parser("info", help="describe an output folder, a store or a scene")
    i.add_argument("path")
    _common(i)

    b = sub.add_parser("batch", help="run many scenes x methods x view counts (resumable; local processes or Ray)")
    b.add_argument("scenes", nargs="*", help="scene folders, glob patterns, or a dataset root with --split / --videos")
    b.add_argument("-o", "--out", help="batch output folder (new, or an earlier batch output to resume)")
    b.add_argument("--split", help="GraspNet-1Billion split of a dataset root: train, test_seen, test_similar, test_novel, test")
    b.add_argument("--videos", help="YCB-Video video ids of a dataset root, e.g. 0048,0049")
    b.add_argument("--method", help="comma-separated methods: graphseg, graphseg-minus (default graphseg unless --config is given)")
    b.add_argument("--config", action="append", help="config file swept as one more configuration (repeatable)")
    b.add_argument("--preset", default=DEFAULT_PRESET, choices=PRESET_NAMES, help="preset the methods start from")
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
    _common(b)

    a = sub.add_parser("add", help="add views to a store: a scene graph that grows view by view (created if missing)")
    a.add_argument("store", help="store folder: new, or an earlier graphseg store")
    a.add_argument("inputs", nargs="+", metavar="PHOTO_OR_SCENE", help="scene folders (every view, or --views / --step / --num-views) and image files")
    a.add_argument("--config", help="YAML/JSON config file for a new store (a store keeps the configuration it was created with)")
    a.add_argument("--preset", choices=PRESET_NAMES, help=f"configuration preset of a new store (default: {DEFAULT_PRESET})")
    a.add_argument("--segmenter", help="segmenter name (default from the store's config)")
    a.add_argument("--matcher", help="matcher name (default from the store's config)")
    a.add_argument("--lifter", help="lifter name (default: rgbd when the views have depth; a scene-level lifter such as sfm lifts every view again at each add)")
    a.add_argument("--backend-option", action="append", default=[], metavar="NAME.KEY=VALUE", help="option KEY of backend NAME, for a new store")
    a.add_argument("--seed", type=int, help="random seed of a new store (>= 0)")
    a.add_argument("--jobs", type=int, help="worker processes for the new views and pairs (default: GRAPHSEG_JOBS, else the cores; 1: one process)")
    _views_args(a)
    _common(a)

    g = sub.add_parser("suggest", help="rank candidate camera poses for the next view of a store (next-best-view)")
    g.add_argument("store", help="a store (graphseg add)")
    g.add_argument("--candidates", metavar="FILE", help="candidate cam_to_world poses: .npy [C, 4, 4] or JSON (a list of 4x4 matrices); default: sampled around the scene")
    g.add_argument("-n", type=int, default=5, metavar="K", help="print the K best candidates (default 5)")
    g.add_argument("--seed", type=int, help="random start of the sampled candidate rings")
    _common(g)
    return ap


# ----------------------------------------------------------------------------- helpers
def _parse_size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(t) for t in text.lower().split("x"))
    except ValueError as err:
        raise BadInput(f"--size: expected WIDTHxHEIGHT (got {text!r})") from err
    if w < 16 or h < 16 or w > 8192 or h > 8192:
        raise BadInput(f"--size: expected sides of 16..8192 pixels (got {w}x{h})")
    return w, h


def _selection(args: argparse.Namespace) -> dict[str, Any]:
    from .io import parse_views

    step, num = getattr(args, "step", None), getattr(args, "num_views", None)
    if step is not None and step < 1:
        raise BadInput(f"--step: expected an integer >= 1 (got {step})")
    if num is not None and num < 1:
        raise BadInput(f"--num-views: expected an integer >= 1 (got {num})")
    views = parse_views(args.views) if getattr(args, "views", None) is not None else None
    if views is not None and not views:
        raise BadInput(f"--views: expected comma-separated view names or indices (got {args.views!r})")
    return {"views": views, "step": step, "num_views": num}


def _metrics_table(metrics: dict[str, Any]) -> str:
    keys = ["iou", "f1", "chamfer", "iou_sel", "precision"]
    lines = [f"{'object':<28}" + "".join(f"{k:>10}" for k in keys)]

    def f(v: Any, k: str) -> str:
        if not isinstance(v, (int, float)):
            return f"{'-':>10}"
        return f"{v:>10.2e}" if k == "chamfer" else f"{v:>10.4f}"

    for o in metrics["objects"]:
        lines.append(f"{_printable(str(o.get('name', o['id'])))[:27]:<28}" + "".join(f(o.get(k), k) for k in keys))
    m = metrics["mean"]
    lines.append(f"{'mean':<28}" + "".join(f(m.get(k), k) for k in keys))
    lines.append(f"pixel utility: {m['pixel_utility']:.4f}" if m.get("pixel_utility") is not None else "pixel utility: -")
    counts = [metrics.get("num_pred"), metrics.get("num_gt")]
    parts = [f"{counts[0]} predicted, {counts[1]} true"] if all(isinstance(c, int) for c in counts) else []
    pq = [m.get(k) for k in ("pq", "sq", "rq")]
    if all(isinstance(v, (int, float)) for v in pq):  # absent in metrics.json files written before panoptic quality
        parts.append(f"PQ {pq[0]:.2f} (SQ {pq[1]:.2f} x RQ {pq[2]:.2f})")
    if parts:
        lines.append("objects: " + "; ".join(parts))
    return "\n".join(lines)


def _printable(text: str) -> str:
    """``text`` with control characters and unencodable characters escaped, so it prints on one line."""
    enc = getattr(sys.stdout, "encoding", None) or "utf-8"
    out = "".join(c if c.isprintable() else repr(c)[1:-1] for c in str(text))
    return out.encode(enc, errors="backslashreplace").decode(enc, errors="replace")


def _warn(text: str, args: argparse.Namespace) -> None:
    """One line on stderr (shown with --quiet too: it is about the user's result)."""
    print(_printable(f"graphseg: warning: {text}"), file=sys.stderr)


def _flag(args: argparse.Namespace, name: str) -> bool:
    return bool(getattr(args, name, False))


def _check_backend_name(name: str) -> None:
    """A ``--backend-option`` must name an installed backend (typos fail before any work)."""
    from .backends.registry import features, lifters, matchers, segmenters

    known = [n for reg in (segmenters, matchers, lifters, features) for n in reg.names()]
    if name not in known:
        raise BadInput(f"--backend-option: unknown backend {name!r}; installed backends: {', '.join(known)}")


def parse_backend_option(text: str) -> tuple[str, str, Any]:
    """``"NAME.KEY=VALUE"`` -> ``(NAME, KEY, value)``, VALUE read as a YAML scalar.

    Examples
    --------
    >>> parse_backend_option("geometric.min_area=200")
    ('geometric', 'min_area', 200)
    >>> parse_backend_option("precomputed.folder=/data/masks")
    ('precomputed', 'folder', '/data/masks')
    >>> parse_backend_option("geometric.min_area=.inf")
    Traceback (most recent call last):
    ...
    graphseg.cli.BadInput: --backend-option: geometric.min_area: expected a finite number (got .inf)
    """
    from .config import load_yaml_text

    lhs, eq, value = text.partition("=")
    name, dot, key = lhs.strip().partition(".")
    if not eq or not dot or not name or not key:
        raise BadInput(f"--backend-option: expected NAME.KEY=VALUE (got {text!r})")
    try:
        parsed = load_yaml_text(value, max_nodes=1000) if value.strip() else None
    except ValueError as err:
        raise BadInput(f"--backend-option: {name}.{key}: cannot read the value ({str(err).splitlines()[0]})") from err
    if isinstance(parsed, (dict, list)) and value.strip()[:1] not in "[{":
        parsed = value
    from .graphs.criterion import non_finite

    bad = non_finite(parsed)
    if bad is not None:
        raise BadInput(f"--backend-option: {name}.{key}: expected a finite number (got {value.strip()})")
    return name, key, parsed


def _load_config(text: str, base: Any = None) -> Any:
    """``Config.load(text, base=base)``; every problem becomes one :class:`BadInput` line naming the file."""
    import yaml
    from pydantic import ValidationError

    from .config import Config, load_error_message, validation_message

    path = Path(text)
    if not path.is_file():
        raise BadInput(f"{path}: config: file not found")
    try:
        return Config.load(path, base=base)
    except ValidationError as err:
        raise BadInput(f"{path}: {validation_message(err)}") from err
    except (yaml.YAMLError, json.JSONDecodeError, ValueError, UnicodeDecodeError, RecursionError) as err:
        raise BadInput(f"{path}: config: {load_error_message(err)}") from err


def _config(args: argparse.Namespace) -> Any:
    from .config import Config

    cfg = Config.preset(getattr(args, "preset", None) or DEFAULT_PRESET)
    if getattr(args, "config", None):
        cfg = _load_config(args.config, base=cfg)
    seed = getattr(args, "seed", None)
    if seed is not None:
        if seed < 0:
            raise BadInput(f"--seed: expected an integer >= 0 (got {seed})")
        cfg = cfg.model_copy(update={"seed": seed})
    if getattr(args, "no_3d", False):
        cfg = cfg.without_3d()
    for text in getattr(args, "backend_option", None) or []:
        name, key, value = parse_backend_option(text)
        _check_backend_name(name)
        cfg = _with_backend_options(cfg, name, **{key: value})
    if getattr(args, "method", None):
        cfg = Config.model_validate({**cfg.model_dump(), "method": args.method})  # validated: the method's stages
    if getattr(args, "masks", None):
        folder = Path(args.masks)
        if not folder.is_dir():
            raise BadInput(f"{folder}: masks: no such folder")
        if args.segmenter not in (None, "precomputed"):
            raise BadInput(f"{folder}: masks: --masks needs the precomputed segmenter (got --segmenter {args.segmenter})")
        args.segmenter = "precomputed"
        cfg = _with_backend_options(cfg, "precomputed", folder=str(folder.resolve()))
    for flag, kind in (("matches", "matcher"), ("points", "lifter")):
        if getattr(args, flag, None):
            from .backends.precomputed_folders import precomputed_choice

            name, opts = precomputed_choice(flag, getattr(args, flag), getattr(args, kind))
            setattr(args, kind, name)
            cfg = _with_backend_options(cfg, name, **opts)
    if getattr(args, "parts", None) is not None:
        if args.parts < 1:
            raise BadInput(f"--parts: expected an integer >= 1 (got {args.parts})")
        cfg = _with_backend_options(cfg, "oracle-parts", parts=args.parts)
    return cfg


def _with_backend_options(cfg: Any, backend: str, **options: Any) -> Any:
    """A copy of ``cfg`` whose ``backends.options[backend]`` gains ``options``."""
    opts = dict(cfg.backends.options)
    opts[backend] = {**opts.get(backend, {}), **options}
    return cfg.model_copy(update={"backends": cfg.backends.model_copy(update={"options": opts})})


def _dropped(result: Any) -> str:
    """``"; K fragments ... became background"`` when the minimum support dropped some, else ``""``."""
    sup = result.info.get("support") or {}
    k = int(sup.get("dropped") or 0)
    if not k:
        return ""
    return f"; {k} fragment{'s' if k > 1 else ''} below the minimum support (objects.min_views {sup.get('min_views')}, {sup.get('min_points')} points) became background"


def _print_job(job: Any, args: argparse.Namespace, t: float) -> None:
    for w in job.warnings:
        _warn(w, args)
    print(f"{job.result.num_objects} objects in {len(job.scene)} views ({time.perf_counter() - t:.1f} s){_dropped(job.result)}")
    if job.metrics:
        print(_metrics_table(job.metrics))
    print(_printable(f"output: {job.out}"))
    print(_printable(f"report: {job.out / 'report.html'}"))


# ----------------------------------------------------------------------------- commands
def cmd_run(args: argparse.Namespace) -> int:
    from .job import run_job
    from .store.commands import is_store

    if is_store(args.scene):
        return _run_store(args)
    cfg = _config(args)
    sel = _selection(args)
    inputs = [p for p in (getattr(args, "masks", None), getattr(args, "config", None)) if p]
    t = time.perf_counter()
    job = run_job(
        args.scene,
        args.out,
        cfg,
        backends={"segmenter": args.segmenter, "matcher": args.matcher, "lifter": args.lifter},
        read=sel,
        overwrite=args.overwrite,
        progress=not _flag(args, "quiet"),
        inputs=inputs,
    )
    asked, used = sel["num_views"], len(job.scene)
    if asked is not None and used < asked:  # the readers select min(asked, views) views
        _warn(f"--num-views {asked}: the scene has {used} views; using all {used}", args)
    _print_job(job, args, t)
    return 0


def _run_store(args: argparse.Namespace) -> int:
    """``graphseg run STORE -o OUT``: write the store's current result as a run output."""
    from .output import write_output
    from .store.commands import store_output

    for flag in ("config", "segmenter", "matcher", "lifter", "masks", "matches", "points", "parts", "method", "seed", "views", "step", "num_views"):
        if getattr(args, flag, None) is not None:
            raise BadInput(f"{args.scene}: --{flag.replace('_', '-')}: a store keeps its own configuration and views (add views with graphseg add)")
    if args.no_3d or args.backend_option:
        raise BadInput(f"{args.scene}: {'--no-3d' if args.no_3d else '--backend-option'}: a store keeps its own configuration (add views with graphseg add)")
    t = time.perf_counter()
    result, scene, info, metrics = store_output(args.scene)
    moved: list[tuple[Path, Path]] = []
    out = write_output(args.out, result, scene, metrics=metrics, run_info=info, inputs=[args.scene], overwrite=args.overwrite, moved=moved)
    for w in result.info.get("warnings", []):
        _warn(w, args)
    _kept(moved, args, shown=args.out, kind="run")
    print(f"{result.num_objects} objects in {len(scene)} views of store generation {info['store']['generation']} ({time.perf_counter() - t:.1f} s){_dropped(result)}")
    if metrics:
        print(_metrics_table(metrics))
    print(_printable(f"output: {out}"))
    print(_printable(f"report: {out / 'report.html'}"))
    return 0


def cmd_add(args: argparse.Namespace) -> int:
    """``graphseg add STORE PHOTO_OR_SCENE...``: the work is :func:`graphseg.store.commands.add_views`."""
    from .store.commands import add_views, is_store, report_lines

    explicit = args.config or args.preset or args.seed is not None or args.backend_option
    if is_store(args.store) and explicit:
        raise BadInput(f"{args.store}: --{'config' if args.config else 'preset' if args.preset else 'seed' if args.seed is not None else 'backend-option'}: a store keeps the configuration it was created with")
    cfg = _config(args) if not is_store(args.store) else None
    sel = _selection(args)
    _, report = add_views(args.store, args.inputs, cfg, segmenter=args.segmenter, matcher=args.matcher, lifter=args.lifter, select=sel, progress=not _flag(args, "quiet"))
    for w in report.warnings:
        _warn(w, args)
    for line in report_lines(report):
        print(_printable(line))
    return 0


def cmd_suggest(args: argparse.Namespace) -> int:
    """``graphseg suggest STORE``: the work is :func:`graphseg.store.commands.suggest_lines`."""
    from .store.commands import suggest_lines

    if args.n < 1:
        raise BadInput(f"-n: expected an integer >= 1 (got {args.n})")
    for line in suggest_lines(args.store, args.candidates, top=args.n, seed=args.seed):
        print(_printable(line))
    return 0


def _kept(moved: list[tuple[Path, Path]], args: argparse.Namespace, shown: str | None = None, kind: str | None = None) -> None:
    """One warning line per existing target that was kept as a backup instead of being deleted."""
    from .output import backup_message

    for old, new in moved:
        _warn(backup_message(old, new, shown=shown, kind=kind), args)


def _write_json_file(path: str, doc: Any, *, inputs: list[str], overwrite: bool, args: argparse.Namespace) -> None:
    from .output import atomic_file, check_target

    target = check_target(path, "export", inputs=inputs, overwrite=overwrite, folder=False)
    moved: list[tuple[Path, Path]] = []
    with atomic_file(target, moved=moved) as tmp:
        tmp.write_text(json.dumps(doc, indent=2), encoding="utf-8")
    _kept(moved, args, shown=path)


def cmd_eval(args: argparse.Namespace) -> int:
    from .job import evaluate_output
    from .output import check_target

    if args.json:
        check_target(args.json, "export", inputs=[args.out] + ([args.scene] if args.scene else []), overwrite=args.overwrite, folder=False)
    from .store.commands import is_store, store_metrics

    metrics = store_metrics(args.out, args.scene, audit=args.audit) if is_store(args.out) else evaluate_output(args.out, args.scene, audit=args.audit)
    if args.json:  # written before anything is printed, so that a closed stdout cannot stop it
        _write_json_file(args.json, metrics, inputs=[args.out] + ([args.scene] if args.scene else []), overwrite=args.overwrite, args=args)
    print(_metrics_table(metrics))
    if args.audit:
        from .audit import format_audit

        print(format_audit(metrics["audit"]))
    if args.json:
        print(_printable(f"wrote {args.json}"))
    return 0


def _synthesize(seed: int, objects: int, views: int, size: tuple[int, int], arc: float = 360.0, layout: str = "spread") -> Any:
    """A pybullet scene; raises MissingDependencyError (naming graphseg[sim]) without pybullet."""
    from .sim.pybullet_scenes import CameraRig, synthesize

    return synthesize(seed=seed, objects=objects, views=views, size=size, cameras=CameraRig(arc_deg=arc), layout=layout)


def _check_synth_args(args: argparse.Namespace) -> None:
    from .sim.pybullet_scenes import MAX_OBJECTS

    if args.seed < 0:
        raise BadInput(f"--seed: expected an integer >= 0 (got {args.seed})")
    if not 1 <= args.objects <= MAX_OBJECTS:
        raise BadInput(f"--objects: expected 1..{MAX_OBJECTS} (got {args.objects})")
    if not 1 <= args.views <= 360:
        raise BadInput(f"--views: expected 1..360 (got {args.views})")
    if not 0 < getattr(args, "arc", 360.0) <= 360:
        raise BadInput(f"--arc: expected degrees in (0, 360] (got {args.arc:g})")
    if getattr(args, "no_intrinsics", False) and not getattr(args, "no_depth", False):
        raise BadInput("--no-intrinsics: only with --no-depth")


def _fell_off(scene: Any, args: argparse.Namespace) -> None:
    from .scene import fell_off_warning

    text = fell_off_warning(scene)
    if text:
        _warn(text, args)


def cmd_synth(args: argparse.Namespace) -> int:
    from .io.scene_folder import fill_scene_folder
    from .output import atomic_folder, check_target

    size = _parse_size(args.size)
    _check_synth_args(args)
    out = check_target(args.out, "synth", overwrite=args.overwrite)
    t = time.perf_counter()
    scene = _synthesize(args.seed, args.objects, args.views, size, args.arc, args.layout)
    if args.no_depth:
        from .sim.strip import rgb_only

        scene = rgb_only(scene, keep_intrinsics=not args.no_intrinsics)
    moved: list[tuple[Path, Path]] = []
    with atomic_folder(out, "synth", moved=moved) as tmp:
        fill_scene_folder(scene, tmp)
    _kept(moved, args, shown=args.out, kind="synth")
    _fell_off(scene, args)
    print(_printable(f"wrote {args.out} ({len(scene)} views, {len(scene.objects)} objects, {time.perf_counter() - t:.1f} s)"))
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    from .config import Config
    from .io.scene_folder import fill_scene_folder
    from .job import run_job
    from .output import atomic_folder, check_target, fill_output, write_marker
    from .registry import MissingDependencyError

    _check_synth_args(args)
    out = check_target(args.out, "demo", overwrite=args.overwrite)
    t0 = time.perf_counter()
    try:
        scene = _synthesize(args.seed, args.objects, args.views, (640, 480))
        source = "pybullet"
    except MissingDependencyError:
        from .testing.scenes import demo_box_scene

        _warn('pybullet is not installed (pip install "graphseg[sim]"); the demo uses the built-in box renderer', args)
        scene = demo_box_scene(seed=args.seed, views=args.views, objects=args.objects)
        source = "boxes"
    job = run_job(scene, None, Config.preset(args.preset, seed=args.seed), progress=not _flag(args, "quiet"))
    info = {"scene": str(out / "scene"), "format": "native", "views": [v.name for v in scene.views], "source": source}
    moved: list[tuple[Path, Path]] = []
    with atomic_folder(out, "demo", moved=moved) as tmp:
        fill_scene_folder(scene, tmp / "scene")
        (tmp / "output").mkdir()
        fill_output(tmp / "output", job.result, job.scene, metrics=job.metrics, run_info=info)
        write_marker(tmp / "output", "run", manifest=True)
    for w in job.warnings:  # the scene's own warnings (objects that did not stay on the table) included
        _warn(w, args)
    _kept(moved, args, shown=args.out, kind="demo")
    print(f"demo: {len(scene)} views, {len(scene.objects)} objects ({source}); found {job.result.num_objects} objects in {time.perf_counter() - t0:.1f} s")
    if job.metrics:
        print(_metrics_table(job.metrics))
    print(_printable(f"report: {out / 'output' / 'report.html'}"))
    return 0


def cmd_export(args: argparse.Namespace) -> int:
    from .graphs import to_pyg, write_graphml
    from .output import atomic_file, atomic_folder, check_target, read_output, write_object_clouds
    from .store.commands import is_store, store_result

    if not (args.graphml or args.pyg or args.ply):
        raise BadInput(f"{args.out}: export: name at least one of --graphml, --pyg, --ply")
    result = store_result(args.out) if is_store(args.out) else read_output(args.out)[0]
    n = len(result.graphs)
    if args.stage is not None and not 0 <= args.stage < n:
        raise BadInput(f"{args.out}: --stage: expected 0..{n - 1} (got {args.stage})")
    inputs = [args.out]
    files: list[tuple[Path, Any]] = []  # (target, writer)
    if args.graphml:
        p = Path(args.graphml)
        stages = [args.stage] if args.stage is not None else list(range(n))
        for s in stages:
            target = p if (args.stage is not None or s == 0) else p.with_name(f"{p.stem}_stage{s}{p.suffix}")
            files.append((target, lambda tmp, g=result.graphs[s]: write_graphml(g, tmp)))
        if args.stage is None and result.objects_graph is not None:  # the last graph: fragments, steps, objects
            files.append((p.with_name(f"{p.stem}_objects{p.suffix}"), lambda tmp, g=result.objects_graph: write_graphml(g, tmp)))
    if args.pyg:
        from .registry import require

        torch = require("torch", "torch")
        g = result.graphs[args.stage or 0]

        def save_pyg(tmp: Path, g: Any = g) -> None:
            data = to_pyg(g)
            plain = dict(data.to_dict()) if hasattr(data, "to_dict") else dict(data)
            torch.save(plain, tmp)

        files.append((Path(args.pyg), save_pyg))
    checked = [(check_target(t, "export", inputs=inputs, overwrite=args.overwrite, folder=False), w) for t, w in files]
    if len({t for t, _ in checked}) != len(checked):
        raise BadInput(f"{args.out}: export: two exports name the same file")
    ply = check_target(args.ply, "export", inputs=inputs + [t for t, _ in checked], overwrite=args.overwrite) if args.ply else None
    moved: list[tuple[Path, Path]] = []
    for target, writer in checked:
        with atomic_file(target, moved=moved) as tmp:
            writer(tmp)
        print(_printable(f"wrote {target}"))
    _kept(moved, args)
    if ply is not None:
        moved = []
        with atomic_folder(ply, "export", moved=moved) as tmp:
            k = write_object_clouds(result, tmp)
        print(_printable(f"wrote {k} PLY files to {args.ply}"))
        _kept(moved, args, shown=args.ply, kind="export")
    return 0


def cmd_info(args: argparse.Namespace) -> int:
    from .io import detect_format, load_scene
    from .output import RESULT_FILE, read_output
    from .store.commands import info_lines, is_store

    p = Path(args.path)
    if is_store(p):
        for line in info_lines(p):
            print(_printable(line))
        return 0
    if (p / RESULT_FILE).exists():
        result, info = read_output(p)
        print(_printable(f"graphseg output: {p}"))
        print(_printable(f"  scene: {info.get('scene', '?')}"))
        print(_printable(f"  views: {len(result.view_names)} ({', '.join(result.view_names[:8])}{' ...' if len(result.view_names) > 8 else ''})"))
        print(f"  objects: {result.num_objects}")
        print(f"  masks: {len(result.mask_object)}; stages: {' -> '.join('+'.join(s) for s in result.config.stage_names())}")
        for s, g in enumerate(result.graphs):
            print(f"  stage {s}: {g.num_nodes} nodes, {g.num_edges} edges")
        og = result.objects_graph
        if og is not None:
            live = sum(1 for c in og.edge_attr.get("cut_by", []) if c == "")
            print(_printable(f"  objects graph: {og.num_nodes} fragments, {og.num_edges} edges ({live} live); steps: {' -> '.join(og.meta.get('steps', []))}"))
        refiners = result.info.get("refiners") or {}
        if refiners.get("pixels"):
            print(f"  pixel refiners moved {refiners['pixels']} pixels ({100 * refiners.get('fraction', 0):.2f}%)")
        mj = p / "metrics.json"
        if mj.is_file():
            try:
                m = json.loads(mj.read_text(encoding="utf-8"))["mean"]
                print("  mean: " + ", ".join(f"{k}={v:.4g}" for k, v in m.items() if isinstance(v, (int, float))))
            except (ValueError, KeyError, TypeError, AttributeError, RecursionError) as err:
                raise BadInput(f"{mj}: metrics.json: malformed ({type(err).__name__})") from err
        return 0
    fmt = detect_format(p)
    scene = load_scene(p, format=fmt)
    h, w = scene.views[0].shape
    print(_printable(f"scene: {p} (format {fmt})"))
    print(f"  views: {len(scene)} of {w}x{h}")
    print(f"  depth: {'yes' if scene.has_depth else 'no'}; poses: {'yes' if scene.has_poses else 'no'}; ground truth: {'yes' if scene.has_instances else 'no'}")
    if scene.objects:
        print(_printable(f"  objects: {', '.join(f'{k}={n}' for k, n in sorted(scene.objects.items()))}"))
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
    from .batch import LocalExecutor, RayExecutor, rebuild_report

    if args.report:
        s = rebuild_report(args.report)
        print(f"aggregate of {s.tasks} tasks ({s.failed} failed): {s.files['md']}")
        return s.exit_code
    if not args.scenes or not args.out:
        raise BadInput("batch: give SCENES and -o OUT (or --report OUT)")
    if args.jobs < 1:
        raise BadInput(f"--jobs: expected >= 1 (got {args.jobs})")
    for f in args.config or []:  # the same one-line messages as `graphseg run --config`, before any work
        _load_config(f)
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
    try:
        s = _run_batch(args, executor, methods)
    except KeyboardInterrupt as err:  # Terminated too
        _interrupted(f"interrupted; finished outputs are kept in {args.out} (run again to resume)")
        return 143 if isinstance(err, Terminated) else 130
    print(f"{s.tasks} tasks: {s.ok} finished ({s.skipped} already done), {s.failed} failed ({s.seconds:.1f} s)")
    for r in s.records:
        if r["status"] != "ok":
            print(_printable(f"failed: {r['scene']} ({r['label']}, views {r['num_views'] or 'all'}): {r['error']}"))
    print(f"aggregate: {s.files['md']}")
    if "png" not in s.files:
        _warn("no sparse_views.png: the plot needs matplotlib (pip install \"graphseg[plot]\")", args)
    return s.exit_code


def _run_batch(args: argparse.Namespace, executor: Any, methods: list[str] | None) -> Any:
    from .batch import run_batch

    return run_batch(
        args.scenes,
        args.out,
        methods=methods,
        config_files=args.config,
        preset=args.preset,
        num_views=_num_views_list(args.num_views),
        dataset={"split": args.split, "videos": [v.strip() for v in args.videos.split(",") if v.strip()] if args.videos else None},
        backends={"segmenter": args.segmenter, "matcher": args.matcher, "lifter": args.lifter},
        executor=executor,
        progress=not _flag(args, "quiet"),
    )


COMMANDS = {"batch": cmd_batch, "run": cmd_run, "eval": cmd_eval, "synth": cmd_synth, "demo": cmd_demo, "export": cmd_export, "info": cmd_info, "add": cmd_add, "suggest": cmd_suggest}


@contextlib.contextmanager
def _signals() -> Iterator[None]:
    """SIGTERM raises :class:`Terminated` and SIGINT KeyboardInterrupt, once: later signals are
    ignored so that the cleanup of temporary files in ``finally`` blocks is not cut short."""

    def on_term(signum: int, frame: Any) -> None:
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        raise Terminated()

    def on_int(signum: int, frame: Any) -> None:
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        raise KeyboardInterrupt()

    try:
        old = signal.signal(signal.SIGTERM, on_term), signal.signal(signal.SIGINT, on_int)
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old[0])
        signal.signal(signal.SIGINT, old[1])


@contextlib.contextmanager
def _quiet(enabled: bool) -> Iterator[None]:
    import warnings

    from .io.images import quiet_opencv

    with contextlib.suppress(Exception):
        quiet_opencv()
    if not enabled:
        yield
        return
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        yield


def _error(text: str) -> None:
    first = (text.splitlines() or [""])[0]
    print(_printable(f"graphseg: error: {first}"), file=sys.stderr)


def _interrupted(text: str = "interrupted; nothing written", stream: TextIO | None = None) -> None:
    r"""``graphseg: interrupted; ...`` on its own line: on a terminal a progress bar may have left the cursor mid-line.

    Examples
    --------
    >>> import io
    >>> class Tty(io.StringIO):
    ...     def isatty(self):
    ...         return True
    >>> tty, log = Tty(), io.StringIO()
    >>> _ = tty.write(" 50%|#####     | 4/8")          # a progress bar, cursor mid-line
    >>> _interrupted(stream=tty); _interrupted(stream=log)
    >>> tty.getvalue()
    ' 50%|#####     | 4/8\ngraphseg: interrupted; nothing written\n'
    >>> log.getvalue()
    'graphseg: interrupted; nothing written\n'
    """
    stream = sys.stderr if stream is None else stream
    try:
        tty = bool(stream.isatty())
    except (AttributeError, ValueError, OSError):
        tty = False
    print(("\n" if tty else "") + f"graphseg: {text}", file=stream)


def _reader_gone(fd: int) -> bool:
    """True when ``fd`` is a pipe or socket whose reader has gone (poll reports an error or hang-up)."""
    import select

    if not hasattr(select, "poll"):  # pragma: no cover - Windows: a broken pipe there is nearly always stdout's
        return fd == 1
    try:
        poller = select.poll()
        poller.register(fd, select.POLLOUT)
        return any(ev & (select.POLLERR | select.POLLHUP) for _, ev in poller.poll(0))
    except (OSError, ValueError):
        return False


def _stdout_closed() -> bool:
    """Whether standard output's reader went away (``graphseg info OUT | head -1``)."""
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, ValueError, OSError):  # replaced by a Python object: the error came from it
        return True
    return _reader_gone(fd)


def _quiet_exit_after_broken_pipe() -> int:
    """Point the closed standard streams at the null device so that nothing more fails, even at interpreter exit.

    Python flushes ``sys.stdout`` at exit; without this, the buffered rest of the
    output would raise BrokenPipeError again there ("Exception ignored ...").
    """
    for stream in (sys.stdout, sys.stderr):
        try:
            fd = stream.fileno()
        except (AttributeError, ValueError, OSError):
            continue
        if fd == 1 or _reader_gone(fd):
            try:
                null = os.open(os.devnull, os.O_WRONLY)
                os.dup2(null, fd)
                os.close(null)
            except OSError:  # pragma: no cover
                pass
    return EXIT_BROKEN_PIPE


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script; returns the exit code.

    When the reader of standard output goes away (``graphseg info OUT | head -1``)
    the command stops printing and exits with :data:`EXIT_BROKEN_PIPE` (141),
    silently: a closed pipe is not an input error.
    """
    try:
        code = _main(argv)  # handles a broken pipe inside a command
    except BrokenPipeError:  # printing the version or the help: standard output's
        return _quiet_exit_after_broken_pipe()
    try:
        sys.stdout.flush()  # here, not at interpreter exit, so that a closed pipe is handled
    except BrokenPipeError:
        _quiet_exit_after_broken_pipe()
        return code or EXIT_BROKEN_PIPE  # an error's own status wins
    return code


def _main(argv: list[str] | None) -> int:
    from pydantic import ValidationError

    from .graphs import GraphValidationError
    from .registry import MissingDependencyError, PluginNotFoundError
    from .scene import SceneError

    ap = build_parser()
    try:
        args = ap.parse_args(argv)
    except SystemExit as done:  # --help (0) or an argument error, already printed as one line (2)
        return done.code if isinstance(done.code, int) else 2
    if args.version:
        from . import __version__

        print(__version__)
        return 0
    if not args.command:
        ap.print_help()
        return 2
    try:
        with _signals(), _quiet(_flag(args, "quiet")), _jobs(args):
            return COMMANDS[args.command](args)
    except (SceneError, BadInput, PluginNotFoundError, MissingDependencyError, GraphValidationError) as err:
        _error(str(err))
        return 2
    except ValidationError as err:
        from .config import validation_message

        source = getattr(args, "config", None)
        _error(f"{source if isinstance(source, str) else 'config'}: {validation_message(err)}")
        return 2
    except Terminated:
        _interrupted()
        return 143
    except KeyboardInterrupt:
        _interrupted()
        return 130
    except MemoryError:
        if _flag(args, "debug"):
            traceback.print_exc()
        _error("out of memory; select fewer views (--num-views / --step) or smaller images")
        return 1
    except BrokenPipeError as err:
        if _stdout_closed():
            return _quiet_exit_after_broken_pipe()
        return _internal_error(err, args)
    except OSError as err:
        name = str(err.filename or getattr(args, "out", None) or "path")
        what = "not found" if isinstance(err, FileNotFoundError) else (err.strerror or str(err))
        from .output import _TMP

        if _TMP in name:  # failed while writing: name the target, not the temporary
            _error(f"{getattr(args, 'out', None) or name}: output: cannot write ({what}); nothing written")
        else:
            _error(f"{name}: path: {what}")
        return 2
    except Exception as err:
        return _internal_error(err, args)


def _internal_error(err: BaseException, args: argparse.Namespace) -> int:
    if _flag(args, "debug"):
        traceback.print_exc()
    text = (str(err).splitlines() or [""])[0]
    print(_printable(f"graphseg: internal error: {type(err).__name__}: {text} (run again with --debug for the traceback)"), file=sys.stderr)
    return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
