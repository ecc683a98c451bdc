"""Kept for one release: ``graphseg.backends.romatch_compat`` moved to :mod:`graphseg.backends.matchers.romatch_compat`.

This module only re-exports the public names of the new one; import them from
there (patch functions there too: this module's names are the same objects,
but the backends look them up in their own module). It will be removed in the
next release.

Examples
--------
>>> from graphseg.backends.matchers import romatch_compat
>>> import_romatch is romatch_compat.import_romatch
True
"""

from .matchers.romatch_compat import import_romatch, vgg19_bn_features

__all__ = ["import_romatch", "vgg19_bn_features"]
