"""Kept for one release: ``graphseg.backends.precomputed`` was split by kind.

``PrecomputedLifter`` lives in :mod:`graphseg.backends.lifters.precomputed`,
``PrecomputedMatcher`` in :mod:`graphseg.backends.matchers.precomputed`, and
``precomputed_choice`` / ``FLAGS`` in :mod:`graphseg.backends.precomputed_folders`.
This module only re-exports them; it will be removed in the next release.

Examples
--------
>>> from graphseg.backends.lifters import precomputed
>>> PrecomputedLifter is precomputed.PrecomputedLifter
True
"""

from .lifters.precomputed import PrecomputedLifter
from .matchers.precomputed import PrecomputedMatcher
from .precomputed_folders import FLAGS, precomputed_choice

__all__ = ["PrecomputedLifter", "PrecomputedMatcher", "precomputed_choice", "FLAGS"]
