"""Kept for one release: ``graphseg.backends.dust3r`` moved to :mod:`graphseg.backends.lifters.dust3r`.

This module only re-exports the public names of the new one; import them from
there (patch functions there too: this module's names are the same objects,
but the backends look them up in their own module). It will be removed in the
next release.

Examples
--------
>>> from graphseg.backends.lifters import dust3r
>>> DUSt3RLifter is dust3r.DUSt3RLifter
True
"""

from .lifters.dust3r import (
    ROLES,
    DUSt3RLifter,
    InputGeometry,
    input_geometry,
    model_size,
    preprocess,
    uncrop,
)

__all__ = ["DUSt3RLifter", "ROLES", "InputGeometry", "input_geometry", "model_size", "preprocess", "uncrop"]
