"""The background step's settings, below :mod:`graphseg.config` so the backends can read them.

:class:`BackgroundConfig` is the ``background`` section of a
:class:`graphseg.config.Config` (which re-exports it); the geometric
segmenter finds the table plane with the same settings
(:data:`graphseg.backends.segmenters.geometric.SEGMENTER_PLANE`). It depends on
pydantic only, so :mod:`graphseg.backends` may import it.

Examples
--------
>>> BackgroundConfig(plane_tolerance=0.01).plane_tolerance
0.01
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

__all__ = ["BackgroundConfig", "SectionModel"]


class SectionModel(BaseModel):
    """Base of every configuration section: unknown keys are errors, assignments are validated."""

    # allow_inf_nan=False: a threshold of .inf or .nan is an error, not a silently disabled rule
    model_config = ConfigDict(extra="forbid", validate_assignment=True, allow_inf_nan=False)


class BackgroundConfig(SectionModel):
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
    beyond_table: bool = Field(
        True, description="points whose foot on the plane lies outside the table's outline (convex hull of the plane points, see table_margin) are background"
    )
    table_margin: float = Field(0.05, ge=0, description="the table outline grows by this fraction of its size (scale-free)")

    @field_validator("max_distance")
    @classmethod
    def _positive_distance(cls, v: Any) -> Any:
        if isinstance(v, (int, float)) and not v > 0:
            raise ValueError(f"must be > 0, 'auto' or null (got {v})")
        return v
    max_overlap: float = Field(0.5, ge=0, le=1, description="drop masks with at least this fraction of background pixels (the paper's code: 9%, the paper preset)")
