"""Batch tasks: which scenes, which configurations, how many views, and their resume keys.

A task is one (scene, configuration, number of views) combination. Its key is
``sha256(scene digest, configuration digest, views)``: a re-run skips every task
whose key already has a finished record, and a changed scene or configuration
gets a new key.

Examples
--------
>>> from graphseg.config import Config
>>> a = config_digest(Config.preset("rgbd"))
>>> a == config_digest(Config.preset("rgbd")), a == config_digest(Config.preset("paper"))
(True, False)
>>> graspnet_split(105), graspnet_split(170), graspnet_split(3)
('test_seen', 'test_novel', 'train')
"""

from __future__ import annotations

import glob
import hashlib
import json
import os
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from ..scene import SceneError

__all__ = [
    "Task",
    "Configuration",
    "GRASPNET_SPLITS",
    "graspnet_split",
    "expand_scenes",
    "scene_digest",
    "config_digest",
    "configurations",
    "make_tasks",
]

#: GraspNet-1Billion scene ids of each split (the paper evaluates on the test splits).
GRASPNET_SPLITS: dict[str, range] = {
    "train": range(0, 100),
    "test_seen": range(100, 130),
    "test_similar": range(130, 160),
    "test_novel": range(160, 190),
    "test": range(100, 190),
}


def graspnet_split(scene_id: int) -> str:
    """The GraspNet-1Billion split of scene ``scene_id`` (``"train"`` below 100)."""
    for name in ("train", "test_seen", "test_similar", "test_novel"):
        if scene_id in GRASPNET_SPLITS[name]:
            return name
    return "other"


@dataclass(frozen=True)
class SceneSpec:
    """A scene folder and the split label it is aggregated under."""

    path: str
    split: str


@dataclass(frozen=True)
class Configuration:
    """A named configuration of the sweep: ``label`` (a method or config-file name) and its config dict."""

    label: str
    method: str
    config: dict[str, Any]
    backends: dict[str, str | None] = field(default_factory=dict)


@dataclass(frozen=True)
class Task:
    """One unit of work, picklable and JSON-serialisable (``asdict``)."""

    key: str
    scene: str
    scene_label: str
    split: str
    method: str
    label: str
    num_views: int | None
    config: dict[str, Any]
    backends: dict[str, str | None]
    out: str

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def _graspnet_root_scenes(root: Path, split: str) -> list[SceneSpec]:
    if split not in GRASPNET_SPLITS:
        raise SceneError(f"unknown split {split!r}; choose one of {', '.join(GRASPNET_SPLITS)}", where=str(root), field="split")
    scenes_dir = root / "scenes" if (root / "scenes").is_dir() else root
    out = []
    for k in GRASPNET_SPLITS[split]:
        p = scenes_dir / f"scene_{k:04d}"
        if p.is_dir():
            out.append(SceneSpec(str(p), graspnet_split(k)))
    if not out:
        raise SceneError(f"no scene_XXXX folders of split {split} under {scenes_dir}", where=str(root), field="split")
    return out


def _ycbv_root_scenes(root: Path, videos: Sequence[str]) -> list[SceneSpec]:
    data = root / "data" if (root / "data").is_dir() else root
    out = []
    for v in videos:
        p = data / v
        if not p.is_dir():
            raise SceneError(f"no video folder {v} under {data}", where=str(root), field="videos")
        out.append(SceneSpec(str(p), "ycbv"))
    return out


def _split_of(path: Path) -> str:
    from ..io import detect_format

    fmt = detect_format(path)
    if fmt == "graspnet":
        name = path.name if path.name.startswith("scene_") else path.parent.name
        try:
            return graspnet_split(int(name.split("_")[-1]))
        except ValueError:
            return "graspnet"
    if fmt == "native":
        return path.resolve().parent.name or "native"
    return fmt


def expand_scenes(specs: Sequence[str], *, split: str | None = None, videos: Sequence[str] | None = None) -> list[SceneSpec]:
    """Scene folders from paths, glob patterns, or a dataset root with a selection.

    Parameters
    ----------
    specs : list of str
        Scene folders or glob patterns (``data/ycbv/00*``). With ``split`` each
        spec is a GraspNet-1Billion root (holding ``scenes/scene_XXXX``); with
        ``videos`` a YCB-Video root (holding ``data/VVVV`` or ``VVVV``).
    split : str, optional
        ``train``, ``test_seen``, ``test_similar``, ``test_novel`` or ``test``.
    videos : list of str, optional
        YCB-Video video ids such as ``["0048", "0049"]``.

    Returns
    -------
    list of SceneSpec
        In the order given, duplicates removed; each with its split label
        (the GraspNet split, ``ycbv``, ``bop``, or a native scene's parent folder name).

    Raises
    ------
    SceneError
        A path or pattern that matches no folder, an unknown split or video.
    """
    out: list[SceneSpec] = []
    for spec in specs:
        root = Path(spec)
        if split is not None:
            out += _graspnet_root_scenes(root, split)
            continue
        if videos:
            out += _ycbv_root_scenes(root, videos)
            continue
        matches = sorted(glob.glob(spec)) if glob.has_magic(spec) else [spec]
        dirs = [Path(m) for m in matches if Path(m).is_dir()]
        if not dirs:
            raise SceneError("no scene folder matches", where=spec, field="scenes")
        out += [SceneSpec(str(d), _split_of(d)) for d in dirs]
    seen: set[str] = set()
    unique = []
    for s in out:
        r = str(Path(s.path).resolve())
        if r not in seen:
            seen.add(r)
            unique.append(s)
    return unique


def scene_digest(path: str | os.PathLike[str]) -> str:
    """A digest of a scene folder: every file's relative path, size and modification time.

    Cheap (no file is read): a GraspNet scene of 256 views is digested in
    milliseconds. Editing, adding or removing any file changes it.
    """
    root = Path(path)
    h = hashlib.sha256()
    for dirpath, dirnames, filenames in os.walk(root):
        dirnames.sort()
        for name in sorted(filenames):
            p = Path(dirpath) / name
            try:
                st = p.stat()
            except OSError:
                continue
            h.update(f"{p.relative_to(root).as_posix()}\0{st.st_size}\0{st.st_mtime_ns}\n".encode("utf-8", "surrogateescape"))
    return h.hexdigest()[:16]


def config_digest(config: Any) -> str:
    """A digest of a :class:`~graphseg.config.Config` (or its dict): canonical JSON, sorted keys."""
    data = config.to_dict() if hasattr(config, "to_dict") else config
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=str).encode()).hexdigest()[:16]


def configurations(
    methods: Sequence[str] | None = None,
    config_files: Sequence[str] | None = None,
    *,
    preset: str | None = None,
    backends: dict[str, str | None] | None = None,
) -> list[Configuration]:
    """The configurations of a sweep: one per method and one per config file.

    ``methods`` are applied to the ``preset`` (default
    ``Config()``): ``graphseg`` (as is) and
    ``graphseg-minus`` (the 3D stage removed); other names are set as the
    config's ``method`` when the installed Config has that field (baselines).
    Config files are loaded as given; their label is the file stem.
    """
    from ..config import Config

    out: list[Configuration] = []
    backends = {k: v for k, v in (backends or {}).items() if v is not None}  # unset = the config's own
    base = Config() if preset is None else Config.preset(preset)
    from typing import get_args

    known = get_args(Config.model_fields["method"].annotation) if "method" in Config.model_fields else ("graphseg", "graphseg-minus")
    for m in methods or ([] if config_files else ["graphseg"]):
        if m not in known:
            raise SceneError(f"unknown method {m!r}; choose one of {', '.join(known)}", where="--method", field="method")
        cfg = base.without_3d() if m == "graphseg-minus" else base
        if "method" in Config.model_fields:
            cfg = Config.model_validate({**cfg.to_dict(), "method": m})
        out.append(Configuration(m, m, cfg.to_dict(), dict(backends)))
    for f in config_files or []:
        p = Path(f)
        if not p.is_file():
            raise SceneError("config file not found", where=str(p), field="config")
        cfg = Config.load(p)
        out.append(Configuration(p.stem, p.stem, cfg.to_dict(), dict(backends or {})))
    labels = [c.label for c in out]
    if len(set(labels)) != len(labels):
        raise SceneError(f"configuration names must be unique (got {labels})", where="--config", field="config")
    return out


def _safe(name: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in name).strip(".") or "x"


def make_tasks(
    scenes: Sequence[SceneSpec],
    configs: Sequence[Configuration],
    num_views: Sequence[int | None],
    out: str | os.PathLike[str],
) -> list[Task]:
    """Every (scene, configuration, views) combination, with its output folder and key.

    Output folders are ``OUT/runs/SCENE/LABEL/views-N`` (``views-all`` for all
    views); two scenes with the same folder name get a digest suffix.
    """
    root = Path(out)
    names: dict[str, int] = {}
    for s in scenes:
        stem = _safe(Path(s.path).name)
        names[stem] = names.get(stem, 0) + 1
    digests = [config_digest(c.config) for c in configs]  # once per configuration, not per scene
    tasks = []
    for s in scenes:
        sd = scene_digest(s.path)
        label = _safe(Path(s.path).name)
        if names[label] > 1:
            label = f"{label}-{hashlib.sha256(str(Path(s.path).resolve()).encode()).hexdigest()[:6]}"
        for c, cd in zip(configs, digests):
            for n in num_views:
                views = "all" if n is None else str(int(n))
                key = hashlib.sha256(f"{sd}|{cd}|{json.dumps(c.backends, sort_keys=True)}|{views}".encode()).hexdigest()[:20]
                dest = root / "runs" / label / _safe(c.label) / f"views-{views}"
                tasks.append(Task(key, str(Path(s.path).resolve()), label, s.split, c.method, c.label, n, c.config, c.backends, str(dest)))
    return tasks
