"""Kept for one release: ``graphseg.backends.automask`` moved to :mod:`graphseg.backends.segmenters.automask`.

This module only re-exports the public names of the new one; import them from
there (patch functions there too: this module's names are the same objects,
but the backends look them up in their own module). It will be removed in the
next release.

Examples
--------
>>> from graphseg.backends.segmenters import automask
>>> generate_masks is automask.generate_masks
True
"""

from .segmenters.automask import (
    Predict,
    Proposals,
    box_iou,
    box_nms,
    crop_boxes,
    generate_masks,
    masks_to_boxes,
    point_grid,
    remove_small_regions,
    stability_score,
)

__all__ = ["Proposals", "point_grid", "stability_score", "masks_to_boxes", "box_iou", "box_nms", "remove_small_regions", "crop_boxes", "generate_masks", "Predict"]
