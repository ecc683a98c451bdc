"""Kept for one release: ``graphseg.backends.da3`` moved to :mod:`graphseg.backends.lifters.da3`.

This module only re-exports the public names of the new one; import them from
there (patch functions there too: this module's names are the same objects,
but the backends look them up in their own module). It will be removed in the
next release.

Examples
--------
>>> from graphseg.backends.lifters import da3
>>> DA3Lifter is da3.DA3Lifter
True
"""

from .lifters.da3 import INSTALL, DA3Lifter, load_da3, model_size_14, resize_for_da3

__all__ = ["DA3Lifter", "load_da3", "model_size_14", "resize_for_da3", "INSTALL"]
