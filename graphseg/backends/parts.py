"""Kept for one release: ``graphseg.backends.parts`` moved to :mod:`graphseg.backends.segmenters.oracle_parts`.

This module only re-exports the public names of the new one; import them from
there (patch functions there too: this module's names are the same objects,
but the backends look them up in their own module). It will be removed in the
next release.

Examples
--------
>>> from graphseg.backends.segmenters import oracle_parts
>>> split_mask is oracle_parts.split_mask
True
"""

from .segmenters.oracle_parts import split_mask

__all__ = ["split_mask"]
