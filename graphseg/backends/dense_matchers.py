"""Kept for one release: ``graphseg.backends.dense_matchers`` moved to :mod:`graphseg.backends.matchers`.

``LoFTRMatcher`` lives in :mod:`graphseg.backends.matchers.loftr`,
``RoMaMatcher`` in :mod:`graphseg.backends.matchers.roma` and
``sample_by_certainty`` in :mod:`graphseg.backends.matchers.sampling`. This
module only re-exports them; it will be removed in the next release.

Examples
--------
>>> from graphseg.backends.matchers import roma
>>> RoMaMatcher is roma.RoMaMatcher
True
"""

from .matchers.loftr import LoFTRMatcher
from .matchers.roma import RoMaMatcher
from .matchers.sampling import sample_by_certainty

__all__ = ["sample_by_certainty", "LoFTRMatcher", "RoMaMatcher"]
