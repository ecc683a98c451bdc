"""Keep native libraries' banners and log lines off the user's terminal.

Some native code writes straight to file descriptors 1 and 2 (pybullet's
build banner, OpenCV's ``[ WARN:0@...]`` lines), where Python's
``sys.stdout`` redirection cannot reach it. :func:`native_silence` points both
descriptors (or the ones named) at the null device for the duration of a block.

Examples
--------
>>> with native_silence():
...     _ = os.write(1, b"not shown\\n")
>>> with native_silence(fds=(2,)):              # only stderr: libpng's error lines
...     _ = os.write(2, b"libpng error: not shown\\n")
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Iterable, Iterator

__all__ = ["native_silence"]


@contextlib.contextmanager
def native_silence(enabled: bool = True, fds: Iterable[int] = (1, 2)) -> Iterator[None]:
    """Redirect file descriptors ``fds`` (default 1 and 2) to the null device inside the block.

    Parameters
    ----------
    enabled : bool, default True
        False makes the block a no-op.
    fds : iterable of int, default (1, 2)
        The descriptors to silence; Python's own streams are flushed first.
    """
    if not enabled:
        yield
        return
    fds = tuple(fds)
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    saved = []
    try:
        null = os.open(os.devnull, os.O_WRONLY)
    except OSError:  # pragma: no cover
        yield
        return
    try:
        for fd in fds:
            try:
                saved.append((fd, os.dup(fd)))
                os.dup2(null, fd)
            except OSError:
                pass
        yield
    finally:
        for fd, copy in saved:
            os.dup2(copy, fd)
            os.close(copy)
        os.close(null)
