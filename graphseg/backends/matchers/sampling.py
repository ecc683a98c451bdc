"""What every matcher ends with: keep up to ``num_matches`` matches by certainty.

``subsample_matches``
    The classical matchers (``reprojection``, ``flow``, ``sift``): the ``n``
    most certain matches, equal certainties ordered at random.
``sample_by_certainty``
    The learned matchers (``loftr``, ``roma``), RoMa's sampling: certainties
    above ``threshold`` count as 1, and matches are drawn without replacement
    with probability proportional to that weight. (RoMa's optional
    kernel-density "balanced" step is not applied.)

:class:`MatcherOptions` and :class:`ModelMatcherOptions` are the option bases
of the built-in classical and learned matchers: the run-wide ``num_matches``
and ``seed`` (filled from the config when unset), plus the checkpoint and
device of a model.

Examples
--------
>>> import numpy as np
>>> from graphseg.scene import Matches
>>> m = Matches(np.zeros((4, 2)), np.zeros((4, 2)), [0.9, 0.0, 0.01, 0.5])
>>> s = sample_by_certainty(m, 2, rng=0)
>>> len(s), bool((s.certainty > 0).all())
(2, True)
>>> len(subsample_matches(m, 3, rng=0))
3
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from ...scene import Matches

__all__ = ["subsample_matches", "sample_by_certainty", "MatcherOptions", "ModelMatcherOptions"]


def subsample_matches(m: Matches, n: int | None, *, rng: Any = None) -> Matches:
    """Keep the ``n`` most certain matches; equal certainties are ordered at random.

    Examples
    --------
    >>> m = Matches(np.zeros((5, 2)), np.zeros((5, 2)), np.ones(5))
    >>> len(subsample_matches(m, 3, rng=0))
    3
    """
    if n is None or len(m) <= n:
        return m
    gen = np.random.default_rng(rng)
    key = m.certainty.astype(np.float64) + gen.uniform(0, 1e-6, len(m))
    idx = np.argpartition(-key, n - 1)[:n]
    idx = np.sort(idx)
    return Matches(m.xy_i[idx], m.xy_j[idx], m.certainty[idx])


def sample_by_certainty(m: Matches, n: int | None, *, threshold: float = 0.05, rng: Any = None) -> Matches:
    """Draw up to ``n`` matches without replacement, weight ``min(certainty / threshold, 1)``-like as RoMa.

    Weights are ``1`` for certainty ``> threshold`` and the certainty itself
    otherwise (RoMa's ``threshold`` sampling); matches with certainty ``<= 0`` are
    never drawn. Sampling uses Gumbel top-k, which equals sequential sampling
    without replacement proportional to the weights. O(M) for M matches.

    Parameters
    ----------
    m : Matches
    n : int or None
        None keeps every match with positive certainty.
    threshold : float
    rng : seed or Generator

    Returns
    -------
    Matches
        In their original order; ``certainty`` is the model's (not the weight).

    Examples
    --------
    >>> m = Matches(np.zeros((3, 2)), np.zeros((3, 2)), [0.5, 0.6, 0.0])
    >>> sample_by_certainty(m, 5).certainty.tolist()  # the zero-certainty match is never kept
    [0.5, 0.6000000238418579]
    """
    cert = np.asarray(m.certainty, np.float64)
    pos = np.flatnonzero(cert > 0)
    if n is None or len(pos) <= n:
        idx = pos
    else:
        w = np.where(cert[pos] > threshold, 1.0, cert[pos])
        gen = np.random.default_rng(rng)
        key = np.log(w) + gen.gumbel(size=len(w))
        idx = np.sort(pos[np.argpartition(-key, n - 1)[:n]])
    return Matches(m.xy_i[idx], m.xy_j[idx], m.certainty[idx])


class MatcherOptions(BaseModel):
    """The run-wide settings every built-in matcher takes (filled from the config when unset)."""

    model_config = ConfigDict(extra="forbid")
    num_matches: int | None = Field(10_000, ge=1, description="matches kept per pair, most certain first (None: all)")
    seed: int | None = Field(0, description="breaks certainty ties at random (None: fresh entropy)")


class ModelMatcherOptions(BaseModel):
    """The settings the learned matchers share: the user's checkpoint, :func:`sample_by_certainty`'s, the device."""

    model_config = ConfigDict(extra="forbid")
    checkpoint: str | None = None
    num_matches: int | None = Field(10_000, ge=1)
    sample_threshold: float = Field(0.05, gt=0)
    seed: int | None = 0
    device: str = "cpu"
