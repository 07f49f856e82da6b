"""Large blocks from the heap while Manifold works on millions of triangles.

glibc's ``malloc`` serves every request above its mmap threshold (at most 32 MiB) with a
fresh ``mmap`` and gives it back to the kernel when it is freed, so each large vector
Manifold builds and drops costs a page fault per 4 KiB page it touches. Inside
:func:`heap_blocks` large requests come from the heap instead (``M_MMAP_MAX`` 0) and what
is freed stays there for the next ones (``M_TRIM_THRESHOLD`` 2 GiB); on leaving, the heap's
free pages go back to the kernel (``malloc_trim``) and the thresholds are set to where
glibc's own sliding thresholds end after a large block is freed (mmap above 32 MiB, trim
above 64 MiB): a ``mallopt`` call stops glibc from sliding them for the rest of the process,
so its defaults cannot be restored, and forked slab workers inherit these. One layer of
spot at 100 mm (16.7 M triangles at step 0.1 mm) built and simplified by Manifold: 49 s
and 4.6 M page faults before, 37 s and 2.3 M inside (2 cores). Where the C library is not
glibc the block changes nothing.
"""

from __future__ import annotations

import contextlib
import ctypes
import platform
import threading
from collections.abc import Iterator

#: ``mallopt`` parameters (glibc's ``malloc.h``).
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD, _M_MMAP_MAX = -1, -3, -4
#: Inside the block: no mmap, trim above 2 GiB.
_HEAP_TRIM_THRESHOLD = 2**31 - 1
#: After it: glibc's default mmap count, and its sliding thresholds' end points.
_MMAP_MAX, _MMAP_THRESHOLD, _TRIM_THRESHOLD = 65536, 32 << 20, 64 << 20

_lock = threading.Lock()
_depth = 0


def _glibc() -> ctypes.CDLL | None:
    """Return the process's C library when it is glibc, else None."""
    if platform.libc_ver()[0] != "glibc":
        return None
    try:
        return ctypes.CDLL(None)
    except OSError:
        return None


_LIBC = _glibc()


@contextlib.contextmanager
def heap_blocks() -> Iterator[None]:
    """Serve large allocations from the heap within the block (nests; threads share it).

    Examples
    --------
    >>> import numpy as np
    >>> with heap_blocks():
    ...     float(np.ones(1 << 23).sum())
    8388608.0
    """
    global _depth
    if _LIBC is None:
        yield
        return
    with _lock:
        if _depth == 0:
            _LIBC.mallopt(_M_MMAP_MAX, 0)
            _LIBC.mallopt(_M_TRIM_THRESHOLD, _HEAP_TRIM_THRESHOLD)
        _depth += 1
    try:
        yield
    finally:
        with _lock:
            _depth -= 1
            if _depth == 0:
                _LIBC.malloc_trim(0)
                _LIBC.mallopt(_M_MMAP_MAX, _MMAP_MAX)
                _LIBC.mallopt(_M_MMAP_THRESHOLD, _MMAP_THRESHOLD)
                _LIBC.mallopt(_M_TRIM_THRESHOLD, _TRIM_THRESHOLD)
