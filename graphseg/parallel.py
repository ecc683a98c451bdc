"""Views and pairs on several processes: the worker count and :func:`parallel_map`.

A run segments its views and matches its pairs one by one, each on its own:
the results do not depend on the order or on the process that computed
them. :func:`parallel_map` spreads such work over ``job_count()`` processes
(forked, so the backend and the views are not copied until a worker touches
them) and returns the results in order, so a run on two cores writes the same
bytes as a run on one. Only backends that declare ``parallel = True`` (the
weight-free classical ones) run this way; a model backend stays in the
calling process.

The count, first found wins: :func:`jobs` (``graphseg run --jobs N``), the
``GRAPHSEG_JOBS`` environment variable, the cores this process may use. ``1``
turns it off.

Examples
--------
>>> with jobs(1):
...     job_count()
1
>>> parallel_map(abs, [-2, 3, -4])
[2, 3, 4]
"""

from __future__ import annotations

import multiprocessing
import os
import threading
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Any

__all__ = ["job_count", "jobs", "parallel_map", "backend_map", "ENV"]

#: The environment variable that sets the worker count (``1``: one process).
ENV = "GRAPHSEG_JOBS"

_JOBS: ContextVar[int | None] = ContextVar("graphseg_jobs", default=None)
_WORK: tuple[Callable[[Any], Any], Sequence[Any]] | None = None  # what forked workers read
_BUSY = threading.Lock()  # one parallel_map at a time; another thread's runs in its own thread


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def job_count() -> int:
    """The number of worker processes: :func:`jobs`, else ``GRAPHSEG_JOBS``, else the usable cores.

    Raises
    ------
    ValueError
        For a ``GRAPHSEG_JOBS`` that is not an integer >= 1 (the message names it).
    """
    n = _JOBS.get()
    if n is not None:
        return n
    raw = os.environ.get(ENV, "").strip()
    if not raw:
        return _cores()
    try:
        n = int(raw)
    except ValueError:
        n = 0
    if n < 1:
        raise ValueError(f"{ENV}: expected an integer >= 1 (got {raw!r})")
    return n


@contextmanager
def jobs(n: int | None) -> Iterator[None]:
    """Run the block with ``n`` worker processes (None: the default of :func:`job_count`).

    Raises
    ------
    ValueError
        For ``n < 1``.
    """
    if n is not None and int(n) < 1:
        raise ValueError(f"jobs: expected an integer >= 1 (got {n})")
    token = _JOBS.set(None if n is None else int(n))
    try:
        yield
    finally:
        _JOBS.reset(token)


@contextmanager
def _one_thread_each() -> Iterator[None]:
    """OpenCV's and BLAS's thread pools at one thread while workers are forked, then as they were.

    The workers share the cores already; their libraries' own pools would
    oversubscribe them. Set here, in the parent, before the fork: a forked
    child inherits the setting, and changing a pool inside a forked child can
    hang (its threads were not copied).
    """
    limits = None
    try:
        from threadpoolctl import threadpool_limits

        limits = threadpool_limits(1)
    except ImportError:  # not installed: the BLAS pool keeps its size
        pass
    try:
        import cv2

        before = cv2.getNumThreads()
        cv2.setNumThreads(1)
    except ImportError:
        cv2 = None
    try:
        yield
    finally:
        if cv2 is not None:
            cv2.setNumThreads(before)
        if limits is not None:
            limits.restore_original_limits()


def _here(fn: Callable[[Any], Any], items: Sequence[Any], wrap: Callable[[Iterator[Any]], Any] | None) -> list[Any]:
    """``fn`` over ``items`` in this process, the results through ``wrap``."""
    return list((wrap or (lambda it: it))(fn(x) for x in items))


def _call(i: int) -> Any:
    assert _WORK is not None
    fn, items = _WORK
    return fn(items[i])


def backend_map(backend: Any, fn: Callable[[Any], Any], items: Sequence[Any], *, wrap: Callable[[Iterator[Any]], Any] | None = None) -> list[Any]:
    """:func:`parallel_map` when ``backend`` declares ``parallel = True`` (a classical segmenter or matcher), else ``fn`` over ``items`` here.

    >>> backend_map(abs, abs, [-1, 2])  # a plain function declares nothing: this process
    [1, 2]
    """
    if getattr(backend, "parallel", False):
        return parallel_map(fn, items, wrap=wrap)
    return _here(fn, items, wrap)


def parallel_map(fn: Callable[[Any], Any], items: Sequence[Any], *, wrap: Callable[[Iterator[Any]], Any] | None = None) -> list[Any]:
    """``[fn(x) for x in items]``, on :func:`job_count` forked processes when there are several items.

    Parameters
    ----------
    fn : callable
        Called once per item; its results are pickled back. It must not depend
        on what another call did.
    items : sequence
    wrap : callable, optional, keyword-only
        Wraps the iterator of results as they arrive, in order (a progress bar).

    Returns
    -------
    list
        The results in the order of ``items``, the same as one process gives.

    Notes
    -----
    Forked workers inherit ``fn`` and ``items``; only the index goes to a
    worker and the result comes back. Without ``fork`` (not Linux), with one
    job or one item, in a daemon process, or while another thread's map
    runs, everything runs here.
    """
    global _WORK
    n = min(job_count(), len(items))
    if n <= 1 or "fork" not in multiprocessing.get_all_start_methods() or multiprocessing.current_process().daemon:
        return _here(fn, items, wrap)  # a daemon process (a pool's worker) may not start processes
    if _WORK is not None or not _BUSY.acquire(blocking=False):  # inside a worker's call, or another thread's map: here
        return _here(fn, items, wrap)
    _WORK = (fn, items)
    try:
        with _one_thread_each(), ProcessPoolExecutor(n, mp_context=multiprocessing.get_context("fork")) as ex:
            return list((wrap or (lambda it: it))(ex.map(_call, range(len(items)))))
    finally:
        _WORK = None
        _BUSY.release()
