"""The GraphSeg method on in-memory arrays: background, mask composition, pairs, segment(), 3D split of objects, joining by border, per-pixel refinement, rim growing and trimming."""

from .background import BackgroundInfo, background_masks, fit_table_plane
from .grow import grow_rims
from .join import join_objects
from .masks import compose_masks
from .pairs import pose_distance, scene_scale, select_pairs
from .refine import project_to_view, refine_labels
from .segment import segment
from .split import merge_objects, split_objects
from .trim import trim_rims

__all__ = [
    "fit_table_plane",
    "background_masks",
    "BackgroundInfo",
    "compose_masks",
    "select_pairs",
    "scene_scale",
    "pose_distance",
    "segment",
    "split_objects",
    "merge_objects",
    "join_objects",
    "refine_labels",
    "project_to_view",
    "grow_rims",
    "trim_rims",
]
