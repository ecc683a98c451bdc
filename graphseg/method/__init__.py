"""The GraphSeg method on in-memory arrays: background, mask composition, segment(), and the graph operations after the last contraction (minimum support, 3D split, joins, snap; the pixel refiners: per-pixel refinement, rim growing and trimming). The view pairs are chosen by :func:`graphseg.geometry.select_pairs`."""

from .background import BackgroundInfo, background_masks, fit_table_plane
from .grow import grow_rims
from .join import join_objects
from .masks import compose_masks
from .refine import project_to_view, refine_labels
from .segment import segment
from .split import merge_objects, split_objects
from .trim import trim_rims

__all__ = [
    "fit_table_plane",
    "background_masks",
    "BackgroundInfo",
    "compose_masks",
    "segment",
    "split_objects",
    "merge_objects",
    "join_objects",
    "refine_labels",
    "project_to_view",
    "grow_rims",
    "trim_rims",
]
