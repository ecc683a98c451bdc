"""2D edge addition: masks joined by dense pixel matches (criterion ``pixel_match``).

For masks ``m1`` (view i) and ``m2`` (view j), ``h(m1, m2)`` is the number of
matches of the pair ``(i, j)`` whose pixel in view i lies in ``m1`` and whose
pixel in view j lies in ``m2``. The paper's ratio is::

    r(m1, m2) = h(m1, m2) / min(area(m1), area(m2))        (normalization="area")

and an edge is added when ``r >= tau_2D``; ``tau_2D`` is either absolute or a
percentile of all non-zero ratios (default: the 78th percentile). The official
code normalised instead by the number of matched hits that fall in each mask,
``h / min(hits(m1), hits(m2))`` (``normalization="hits"``); ``"pair_hits"``
computes that ratio per view pair (a density-free overlap fraction in [0, 1]).

Examples
--------
>>> import numpy as np
>>> from graphseg.scene import Matches
>>> labels = [np.array([[0, 0, 1, 1]]), np.array([[2, 2, 3, -1]])]  # node ids, -1 = none
>>> m = {(0, 1): Matches([[0, 0], [1, 0], [2, 0]], [[0, 0], [1, 0], [1, 0]], [1, 1, 1])}
>>> ei, count, ratio = pixel_match_ratios(labels, m, 4, areas=np.array([2, 2, 2, 1]), normalization="area", consistency_percentile=None)
>>> ei.tolist(), count.tolist(), ratio.tolist()
([[0, 1], [2, 2]], [2, 1], [1.0, 0.5])
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from .coalesce import combine_keys, count_keys, group_by_key
from .criterion import Criterion
from .evidence import EdgeSet, Evidence
from .graph import CorrespondenceGraph

__all__ = ["pair_counts", "pixel_match_ratios", "pixel_match_edges", "PixelMatch", "lookup_pixels"]


def pair_counts(a: np.ndarray, b: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Count occurrences of each ``(a, b)`` pair, ``a, b`` in ``[0, n)``.

    Returns
    -------
    a_unique, b_unique, count : int64 arrays ``[P]``
        Pairs in lexicographic order.

    Notes
    -----
    A dense ``bincount`` when ``n * n`` is small, else one sort: O(M log M).

    Examples
    --------
    >>> u, v, c = pair_counts(np.array([1, 0, 1]), np.array([2, 2, 2]), 3)
    >>> u.tolist(), v.tolist(), c.tolist()
    ([0, 1], [2, 2], [1, 2])
    """
    a = np.asarray(a, np.int64)
    b = np.asarray(b, np.int64)
    if n * n < 2**62:
        keys, counts = count_keys(combine_keys([a, b], [n, n]), num_keys=n * n)
        return keys // n, keys % n, counts
    g = group_by_key(combine_keys([a, b], [n, n]))  # pragma: no cover - rank keys for astronomically many nodes
    return a[g.first], b[g.first], g.counts  # pragma: no cover


def lookup_pixels(image: np.ndarray, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Values of ``image`` at rounded pixel coordinates ``xy`` ``[M, 2]`` as (x, y).

    Returns ``(values, inside)``; values outside the image are taken at the
    clipped position and flagged False in ``inside``.
    """
    h, w = image.shape[:2]
    x = np.rint(xy[:, 0]).astype(np.int64)
    y = np.rint(xy[:, 1]).astype(np.int64)
    inside = (x >= 0) & (x < w) & (y >= 0) & (y < h)
    return image[np.clip(y, 0, h - 1), np.clip(x, 0, w - 1)], inside


def _consistent(matches: Any, points_i: np.ndarray, points_j: np.ndarray, percentile: float) -> np.ndarray:
    """Keep matches whose two 3D points (each read at its own image's pixel) agree."""
    pi, ok_i = lookup_pixels(points_i, matches.xy_i)
    pj, ok_j = lookup_pixels(points_j, matches.xy_j)
    d = np.linalg.norm(pi.astype(np.float64) - pj, axis=1)
    ok = ok_i & ok_j & np.isfinite(d)
    if not ok.any():
        return ok
    return ok & (d <= np.percentile(d[ok], percentile))


def pixel_match_ratios(
    node_labels: Sequence[np.ndarray],
    matches: Mapping[tuple[int, int], Any],
    num_nodes: int,
    *,
    areas: np.ndarray,
    normalization: str,
    points: Sequence[np.ndarray | None] | None = None,
    consistency_percentile: float | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Match counts and normalised ratios for every node pair that shares a match.

    Parameters
    ----------
    node_labels : list of int ``[H, W]``
        Pixel -> node (-1 = none), per view.
    matches : mapping ``(i, j) -> Matches``
    num_nodes : int
    areas : int ``[N]``
        Pixel area of each node (for ``normalization="area"``).
    normalization : {"area", "hits", "pair_hits"}
        ``"area"``: the paper's ``h / min(area)``, match counts summed over
        view pairs. ``"hits"``: the official code's ``h / min(hits)``, where
        ``hits(m)`` counts the matches (of all view pairs) that land in ``m``
        with a node on the other side too. ``"pair_hits"``: per view pair,
        ``h / min(out(m1), out(m2))`` where ``out(m)`` counts every match of
        the pair that starts in ``m``, wherever it lands (another mask, the
        background, a hole): the fraction of the smaller mask's matches that
        land in the other mask, independent of the match density and the
        number of pairs. A node pair seen in several view pairs keeps its
        largest ratio.
    points : list of ``[H, W, 3]``, optional
        World points, needed by ``consistency_percentile``.
    consistency_percentile : float or None
        Drop matches whose two 3D points are farther apart than this percentile
        of the pair's distances (None: keep all). Each point is read at its own
        image's pixel.

    The option defaults live in :class:`PixelMatch.Options`; here every option
    is a required keyword.

    Returns
    -------
    edge_index : int64 ``[2, P]`` with ``u < v``
    count : int64 ``[P]``
    ratio : float64 ``[P]``

    Notes
    -----
    Vectorised: per view pair one lookup of the match pixels; all pairs' counts
    in one :func:`pair_counts`. O(total matches + P log P); no loop over matches.
    """
    if normalization not in ("area", "hits", "pair_hits"):
        raise ValueError(f"unknown normalization {normalization!r}; choose 'area', 'hits' or 'pair_hits'")
    us, vs, hit_ratio = [], [], []
    for (i, j), m in matches.items():
        if len(m) == 0:
            continue
        keep = np.ones(len(m), bool)
        if consistency_percentile is not None:
            pi, pj = (None, None) if points is None else (points[i], points[j])
            if pi is None or pj is None:
                raise ValueError("consistency_percentile needs world points for both views")
            keep = _consistent(m, pi, pj, consistency_percentile)
        a, in_a = lookup_pixels(node_labels[i], m.xy_i)
        b, in_b = lookup_pixels(node_labels[j], m.xy_j)
        ok = keep & in_a & in_b & (a >= 0) & (b >= 0) & (a != b)
        if normalization == "pair_hits":
            # every match of this pair that starts (ends) in a node counts for it, wherever it lands
            base = keep & in_a & in_b
            out_a = np.bincount(a[base & (a >= 0)], minlength=num_nodes)
            out_b = np.bincount(b[base & (b >= 0)], minlength=num_nodes)
        a, b = a[ok].astype(np.int64), b[ok].astype(np.int64)
        us.append(a)
        vs.append(b)
        if normalization == "pair_hits":
            pu, pv, pc = pair_counts(np.minimum(a, b), np.maximum(a, b), max(num_nodes, 1))
            hits = out_a + out_b  # a node lies in one view, so one of the two terms is 0
            hit_ratio.append((pu, pv, pc / np.maximum(np.minimum(hits[pu], hits[pv]), 1)))
    if not us or not sum(x.size for x in us):
        z = np.zeros(0, np.int64)
        return np.zeros((2, 0), np.int64), z, np.zeros(0)
    a = np.concatenate(us)
    b = np.concatenate(vs)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    u, v, count = pair_counts(lo, hi, max(num_nodes, 1))
    if normalization == "area":
        ratio = count / np.maximum(np.minimum(areas[u], areas[v]).astype(np.float64), 1.0)
    elif normalization == "hits":  # hits accumulated over all view pairs, as the official code
        hits = np.bincount(a, minlength=num_nodes) + np.bincount(b, minlength=num_nodes)
        ratio = count / np.maximum(np.minimum(hits[u], hits[v]), 1).astype(np.float64)
    else:  # pair_hits: a node pair seen in several view pairs keeps its best per-pair ratio
        ratio = np.zeros(u.size)
        key = u * num_nodes + v
        for pu, pv, r in hit_ratio:
            pos = np.searchsorted(key, pu * num_nodes + pv)
            np.maximum.at(ratio, pos, r)
    return np.stack([u, v]), count, ratio


def pixel_match_edges(
    node_labels: Sequence[np.ndarray],
    matches: Mapping[tuple[int, int], Any],
    num_nodes: int,
    *,
    areas: np.ndarray,
    tau: float | None,
    percentile: float,
    min_matches: int,
    normalization: str,
    points: Sequence[np.ndarray | None] | None = None,
    consistency_percentile: float | None,
) -> EdgeSet:
    """Edges where the match ratio reaches ``tau`` (or the ``percentile`` of all ratios).

    Parameters
    ----------
    tau : float or None
        Absolute threshold; when None, ``np.percentile(ratios, percentile)``.
    percentile : float
        Used when ``tau`` is None; the paper's value is 78.
    min_matches : int
        Pairs sharing fewer matches are ignored: they get no edge and do not
        count toward the percentile. Stray matches touch many mask pairs once
        or twice; without this, those pairs outnumber the real ones and drag
        the percentile threshold down into the noise (1 = the paper's rule).
    Other parameters are those of :func:`pixel_match_ratios`. Every option is
    a required keyword: the defaults live in :class:`PixelMatch.Options`
    (``pixel_match_edges(..., **PixelMatch.Options().model_dump())``).

    Returns
    -------
    EdgeSet
        Columns ``criterion`` ("pixel_match"), ``weight`` (= ratio), ``count``,
        ``ratio``; ``info["tau"]`` is the threshold used.
    """
    ei, count, ratio = pixel_match_ratios(
        node_labels,
        matches,
        num_nodes,
        areas=areas,
        normalization=normalization,
        points=points,
        consistency_percentile=consistency_percentile,
    )
    eligible = count >= min_matches
    if tau is None:
        tau_used = float(np.percentile(ratio[eligible], percentile)) if eligible.any() else np.inf
    else:
        tau_used = float(tau)
    keep = eligible & (ratio >= tau_used)
    n = int(keep.sum())
    return EdgeSet(
        ei[:, keep],
        {
            "criterion": np.full(n, "pixel_match"),
            "weight": ratio[keep],
            "count": count[keep],
            "ratio": ratio[keep],
        },
        info={"tau": tau_used, "candidates": int(ratio.size), "eligible": int(eligible.sum())},
    )


class PixelMatch(Criterion):
    """The ``pixel_match`` criterion: a thin class around :func:`pixel_match_edges`.

    Options are those of :func:`pixel_match_edges` (see :class:`PixelMatch.Options`).
    Node areas come from the graph's ``area`` column.

    Examples
    --------
    >>> from graphseg.scene import Matches
    >>> g = CorrespondenceGraph.from_masks([np.array([[1, 1]]), np.array([[1, 1]])])
    >>> ev = Evidence.for_graph(g, matches={(0, 1): Matches([[0, 0]], [[1, 0]], [1.0])})
    >>> PixelMatch(PixelMatch.Options(tau=0.5, min_matches=1))(g, ev).edge_index.tolist()
    [[0], [1]]
    """

    class Options(BaseModel):
        """Options of ``pixel_match``."""

        model_config = ConfigDict(extra="forbid")
        tau: float | None = Field(None, ge=0, description="absolute ratio threshold; None: percentile")
        percentile: float = Field(78.0, ge=0, le=100)
        normalization: Literal["area", "hits", "pair_hits"] = "area"
        min_matches: int = Field(3, ge=1, description="pairs sharing fewer matches get no edge and do not count toward the percentile (1 = the paper's rule)")
        consistency_percentile: float | None = Field(None, ge=0, le=100)

    name = "pixel_match"
    requires = frozenset({"matches", "points"})  # points: for consistency_percentile
    reduce = {"weight": "max", "count": "sum", "ratio": "max"}
    tags = {"dimension": "2d"}
    options: PixelMatch.Options

    def __call__(self, graph: CorrespondenceGraph, evidence: Evidence) -> EdgeSet:
        o = self.options
        if o.consistency_percentile is not None and evidence.points is None:
            raise ValueError("pixel_match with consistency_percentile needs world points (Evidence.points)")
        return pixel_match_edges(
            evidence.node_labels,
            evidence.matches,
            graph.num_nodes,
            areas=np.asarray(graph.node_attr["area"]),
            tau=o.tau,
            percentile=o.percentile,
            min_matches=o.min_matches,
            normalization=o.normalization,
            points=evidence.points,
            consistency_percentile=o.consistency_percentile,
        )
