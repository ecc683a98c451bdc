"""The edge array at every boundary: :func:`as_edge_index` and :class:`GraphValidationError`.

The lowest module of :mod:`graphseg.graphs`: the graph, the contractors and
the coalescing step all check edge arrays here, so it imports nothing of
graphseg. Both names are public in :mod:`graphseg.graphs.graph`, their
documented home.

Examples
--------
>>> as_edge_index([[0, 1], [1, 2]], 3).tolist()
[[0, 1], [1, 2]]
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["GraphValidationError", "as_edge_index"]


class GraphValidationError(ValueError):
    """Raised by :meth:`CorrespondenceGraph.validate` and boundary checks."""


# documented (and pickled) as graphseg.graphs.graph.GraphValidationError, where it was defined
# first (numpy's set_module habit): tracebacks and saved errors keep naming that public path
GraphValidationError.__module__ = "graphseg.graphs.graph"


def as_edge_index(edge_index: Any, num_nodes: int | None = None) -> np.ndarray:
    """Validate and convert ``edge_index`` to a contiguous int64 ``[2, E]`` array.

    Parameters
    ----------
    edge_index : array_like
        Integer array of shape ``[2, E]``.
    num_nodes : int, optional
        When given, every index must lie in ``[0, num_nodes)``.

    Returns
    -------
    numpy.ndarray
        int64 array of shape ``[2, E]``.

    Raises
    ------
    GraphValidationError
        On a wrong shape, a non-integer dtype or an index out of range.

    Examples
    --------
    >>> as_edge_index([[0, 1], [1, 2]]).dtype
    dtype('int64')
    >>> as_edge_index(np.zeros((3, 10), dtype=int))
    Traceback (most recent call last):
    ...
    graphseg.graphs.graph.GraphValidationError: expected edge_index of shape [2, E] (got [3, 10])
    """
    arr = np.asarray(edge_index)
    if arr.size == 0 and arr.ndim <= 2:
        arr = arr.reshape(2, 0) if arr.ndim != 2 or arr.shape[0] in (0, 2) else arr
    if arr.ndim != 2 or arr.shape[0] != 2:
        raise GraphValidationError(
            f"expected edge_index of shape [2, E] (got {list(arr.shape)})"
        )
    if arr.size and not np.issubdtype(arr.dtype, np.integer):
        if np.issubdtype(arr.dtype, np.floating) and np.all(np.mod(arr, 1) == 0):
            pass
        else:
            raise GraphValidationError(f"expected edge_index of an integer dtype (got {arr.dtype})")
    arr = np.ascontiguousarray(arr, dtype=np.int64)
    if num_nodes is not None and arr.size:
        lo, hi = int(arr.min()), int(arr.max())
        if lo < 0 or hi >= num_nodes:
            bad = lo if lo < 0 else hi
            raise GraphValidationError(
                f"expected edge_index entries in [0, num_nodes={num_nodes}) (got {bad})"
            )
    return arr
