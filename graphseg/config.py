"""Configuration of a GraphSeg run: every threshold, the stages, the contractor, the seed.

A :class:`Config` is a pydantic model, so it validates on construction, rejects
unknown keys (typos fail loudly), and loads from / saves to YAML or JSON.

Examples
--------
>>> cfg = Config()
>>> cfg.stages
[['pixel_match'], ['chamfer_3d']]
>>> Config.minus().stages          # GraphSeg-minus: no 3D stage
[['pixel_match']]
>>> cfg.chamfer_3d.tau
0.0005
>>> Config.preset("rgbd").chamfer_3d.tau   # measured preset for metric RGB-D input
5e-05
"""

from __future__ import annotations

import json
from os import PathLike
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

__all__ = [
    "Config",
    "BackgroundConfig",
    "MaskConfig",
    "PairConfig",
    "PixelMatchConfig",
    "Chamfer3DConfig",
    "DinoConfig",
    "OutputConfig",
    "BackendConfig",
    "PRESETS",
    "load_yaml_text",
]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", validate_assignment=True)


class BackgroundConfig(_Model):
    """The background class: table plane (RANSAC), points below it, and far points."""

    enabled: bool = True
    plane: bool = Field(True, description="fit the table plane by RANSAC and make it background")
    plane_tolerance: float = Field(0.015, gt=0, description="metres from the plane that count as plane")
    plane_normal_angle: float | None = Field(
        0.6, gt=0, description="radians; a pixel in the plane band is background only if its surface normal is within this angle of the plane normal (keeps the bottom of objects); None = band only"
    )
    normal_step: int = Field(4, ge=1, description="pixel step of the central differences for surface normals (larger = smoother on noisy depth)")
    below_plane: bool = Field(True, description="points on the far side of the plane (from the cameras) are background")
    ransac_iterations: int = Field(256, ge=1)
    ransac_sample: int = Field(50_000, ge=100, description="points sampled for RANSAC")
    min_plane_fraction: float = Field(0.1, ge=0, le=1, description="plane needs this inlier fraction of the sample")
    max_distance: float | Literal["auto"] | None = Field(
        "auto", description="pixels farther than this from their camera are background; 'auto': auto_distance_factor x median point distance"
    )
    auto_distance_factor: float = Field(1.5, gt=0)

    @field_validator("max_distance")
    @classmethod
    def _positive_distance(cls, v: Any) -> Any:
        if isinstance(v, (int, float)) and not v > 0:
            raise ValueError(f"must be > 0, 'auto' or null (got {v})")
        return v
    max_overlap: float = Field(0.09, ge=0, le=1, description="drop masks with at least this fraction of background pixels (paper code: 9%)")


class MaskConfig(_Model):
    """Mask composition."""

    min_area: int = Field(20, ge=1, description="composed masks with fewer visible pixels are dropped")


class PairConfig(_Model):
    """Which view pairs are matched."""

    mode: Literal["auto", "pose", "all"] = Field("auto", description="'pose': close camera poses only; 'all': every pair; 'auto': 'all' up to auto_max_views views, else 'pose'")
    auto_max_views: int = Field(8, ge=2)
    max_rotation: float = Field(1.2, gt=0, description="radians")
    max_translation: float | None = Field(None, gt=0, description="metres; None: translation_scale x scene scale")
    translation_scale: float = Field(1.0, gt=0)


class PixelMatchConfig(_Model):
    """The ``pixel_match`` edge adder (2D stage)."""

    tau: float | None = Field(None, ge=0, description="absolute ratio threshold; None: percentile")
    percentile: float = Field(78.0, ge=0, le=100)
    normalization: Literal["area", "hits", "pair_hits"] = "area"
    min_matches: int = Field(3, ge=1, description="pairs sharing fewer matches get no edge and do not count toward the percentile (1 = the paper's rule)")
    consistency_percentile: float | None = Field(None, ge=0, le=100)


class Chamfer3DConfig(_Model):
    """The ``chamfer_3d`` edge adder (3D stage)."""

    tau: float = Field(5e-4, gt=0, description="m^2; the paper states 5e-4, the official code used 5e-5")
    voxel_size: float | None = Field(0.005, gt=0, description="metres; None = no downsampling")
    stride: int = Field(2, ge=1, description="pixel stride when gathering points")
    outliers: Literal["statistical", "dbscan"] | None = None
    prune: bool = True


class DinoConfig(_Model):
    """The ``dino`` feature-similarity edge adder (optional)."""

    threshold: float = Field(0.8, ge=-1, le=1)
    cross_view_only: bool = False


class OutputConfig(_Model):
    """What the result keeps."""

    voxel_size: float | None = Field(0.003, gt=0, description="object clouds are voxel-downsampled to this size (metres)")
    stride: int = Field(2, ge=1, description="pixel stride when gathering the object clouds")


class BackendConfig(_Model):
    """Backends used by the pipeline (names from the registries)."""

    segmenter: str = "geometric"
    matcher: str = "reprojection"
    lifter: str = "rgbd"
    num_matches: int | None = Field(10_000, ge=1, description="matches kept per pair, most certain first")
    options: dict[str, dict[str, Any]] = Field(default_factory=dict, description="constructor options by backend name")


#: Named configurations for :meth:`Config.preset`.
PRESETS: dict[str, dict[str, Any]] = {
    "paper": {},
    "rgbd": {
        "pixel_match": {"normalization": "pair_hits", "tau": 0.3, "min_matches": 5},
        "chamfer_3d": {"tau": 5e-5},
        "background": {"max_overlap": 0.5},
    },
}


class Config(_Model):
    """Everything a GraphSeg run needs besides its inputs.

    ``stages`` lists, per stage, the edge adders that run before that stage's
    contraction. Built-in adders take their options from the sections below;
    other (plugin) adders from ``adder_options[name]``.
    """

    background: BackgroundConfig = Field(default_factory=BackgroundConfig)
    masks: MaskConfig = Field(default_factory=MaskConfig)
    pairs: PairConfig = Field(default_factory=PairConfig)
    pixel_match: PixelMatchConfig = Field(default_factory=PixelMatchConfig)
    chamfer_3d: Chamfer3DConfig = Field(default_factory=Chamfer3DConfig)
    dino: DinoConfig = Field(default_factory=DinoConfig)
    output: OutputConfig = Field(default_factory=OutputConfig)
    backends: BackendConfig = Field(default_factory=BackendConfig)
    stages: list[list[str]] = Field(default_factory=lambda: [["pixel_match"], ["chamfer_3d"]])
    contractor: str = "star"
    seed: int | None = Field(0, ge=0, description="random seed (None: fresh entropy)")
    adder_options: dict[str, dict[str, Any]] = Field(default_factory=dict)

    @field_validator("stages")
    @classmethod
    def _stages_not_empty(cls, v: list[list[str]]) -> list[list[str]]:
        if not v or any(not s for s in v):
            raise ValueError("stages must be a non-empty list of non-empty adder lists")
        return v

    @classmethod
    def preset(cls, name: str, **kwargs: Any) -> Config:
        """A named configuration (see :data:`PRESETS`), with overrides.

        ``"paper"`` is ``Config()``: the paper's thresholds. ``"rgbd"`` is
        chosen by measurement for metric RGB-D input (``docs/results.md``): the
        per-pair overlap fraction (``pair_hits``) >= 0.3 for 2D edges, the
        official code's tau_3D = 5e-5 m^2, and masks dropped only when at least
        half of them is background (background pixels are cleared from every
        mask anyway).
        """
        if name not in PRESETS:
            raise ValueError(f"unknown preset {name!r}; choose one of {', '.join(PRESETS)}")
        merged: dict[str, Any] = {}
        for src in (PRESETS[name], kwargs):
            for key, val in src.items():
                if isinstance(val, dict) and isinstance(merged.get(key), dict):
                    merged[key] = {**merged[key], **val}
                else:
                    merged[key] = val
        return cls(**merged)

    @classmethod
    def minus(cls, **kwargs: Any) -> Config:
        """GraphSeg-minus, the paper's ablation: the 2D stage only."""
        return cls(**kwargs).without_3d()

    def without_3d(self) -> Config:
        """A copy with every ``chamfer_3d`` adder removed (stages left empty are dropped)."""
        stages = [[a for a in s if a != "chamfer_3d"] for s in self.stages]
        return self.model_copy(update={"stages": [s for s in stages if s] or [["pixel_match"]]})

    def options_for(self, adder: str) -> dict[str, Any]:
        """Constructor options of the named edge adder."""
        builtin = {"pixel_match": self.pixel_match, "chamfer_3d": self.chamfer_3d, "dino": self.dino, "dino_similarity": self.dino}
        if adder in builtin:
            return builtin[adder].model_dump()
        return dict(self.adder_options.get(adder, {}))

    # ------------------------------------------------------------------ files
    def to_dict(self) -> dict[str, Any]:
        return self.model_dump(mode="json")

    def save(self, path: str | PathLike[str]) -> None:
        """Write YAML (``.yaml``/``.yml``) or JSON (anything else)."""
        p = Path(path)
        if p.suffix.lower() in (".yaml", ".yml"):
            import yaml

            p.write_text(yaml.safe_dump(self.to_dict(), sort_keys=False))
        else:
            p.write_text(json.dumps(self.to_dict(), indent=2))

    @classmethod
    def load(cls, path: str | PathLike[str], *, base: Config | None = None) -> Config:
        r"""Read YAML or JSON written by :meth:`save`.

        A partial file overrides ``base`` (default ``Config()``, the paper's
        values): nested sections are merged key by key, lists are replaced.
        YAML alias expansion is bounded (:func:`load_yaml_text`), and files
        over 1 MiB are refused.

        Raises
        ------
        ValueError
            For malformed files (``yaml.YAMLError`` and ``json.JSONDecodeError``
            are ValueErrors too); pydantic's ValidationError for bad values.

        Examples
        --------
        >>> import tempfile
        >>> with tempfile.TemporaryDirectory() as d:
        ...     p = Path(d) / "c.yaml"
        ...     _ = p.write_text("seed: 3\n")
        ...     Config.load(p, base=Config.preset("rgbd")).chamfer_3d.tau
        5e-05
        """
        p = Path(path)
        if p.stat().st_size > 2**20:
            raise ValueError("larger than 1 MiB; not a config file")
        text = p.read_text(encoding="utf-8")
        if p.suffix.lower() in (".yaml", ".yml"):
            data = load_yaml_text(text)
            data = {} if data is None else data
        else:
            data = json.loads(text)
        if not isinstance(data, dict):
            raise ValueError("expected a mapping at the top level")
        if base is not None:
            data = _deep_merge(base.to_dict(), data)
        return cls.model_validate(data)


def _deep_merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for k, v in over.items():
        out[k] = _deep_merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def load_yaml_text(text: str, *, max_nodes: int = 100_000) -> Any:
    r"""``yaml.safe_load`` with alias expansion bounded to ``max_nodes`` nodes.

    The document is composed first (linear in the text); its size with every
    alias expanded is counted (memoised, so a "billion laughs" file costs
    O(distinct nodes)) and refused above ``max_nodes`` before any object is built.

    Examples
    --------
    >>> load_yaml_text("a: &x [1, 2]\nb: *x")
    {'a': [1, 2], 'b': [1, 2]}
    >>> bomb = "a: &a [0,0,0,0,0,0,0,0,0]\n" + "".join(
    ...     f"{chr(98 + i)}: &{chr(98 + i)} [*{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}]\n"
    ...     for i in range(8))
    >>> load_yaml_text(bomb)
    Traceback (most recent call last):
    ...
    ValueError: YAML aliases expand to more than 100000 nodes
    """
    import yaml

    node = yaml.compose(text, Loader=yaml.SafeLoader)
    if node is None:
        return None
    sizes: dict[int, int] = {}

    def size(n: Any, depth: int = 0) -> int:
        if id(n) in sizes:
            return sizes[id(n)]
        if depth > 200:
            raise ValueError("YAML nesting deeper than 200 levels")
        sizes[id(n)] = 1  # guards against recursive aliases
        total = 1
        if isinstance(n, yaml.SequenceNode):
            total += sum(size(c, depth + 1) for c in n.value)
        elif isinstance(n, yaml.MappingNode):
            total += sum(size(k, depth + 1) + size(v, depth + 1) for k, v in n.value)
        if total > max_nodes:
            raise ValueError(f"YAML aliases expand to more than {max_nodes} nodes")
        sizes[id(n)] = total
        return total

    size(node)
    return yaml.SafeLoader(text).get_single_data()
