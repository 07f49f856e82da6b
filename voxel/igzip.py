"""The deflate streams of every file shellvox writes, at one place: the fast setting.

A *level* throughout shellvox is ``None`` for the fast setting, or zlib's level 1..9
(``--compression-level``) for smaller files at zlib's speed; 0 stores the bytes. The
fast setting is zlib's level 1 (Python's zlib, which releases the GIL).

ISA-L's igzip (python-isal) was tried as the fast setting (stop 19): 3 to 9 times zlib
level 1's speed on voxel pages and 8 to 26 % smaller (``benchmarks/bench_compress.py``).
With it, a Dask build whose worker was killed mid-build differed from the one-process
build in 3 of 7 runs on a loaded machine: ``volume.vdb``'s material grid had equal values
and topology but leaf streams of other lengths. With zlib every such run was byte-equal.
The mechanism was not found (ISA-L gave equal bytes for equal input in every isolated
test: after other data, in threads, inside larger buffers), so zlib stays until it is.
"""

from __future__ import annotations

import zlib
from typing import Protocol

#: zlib's level of the fast setting.
FAST_LEVEL = 1


class Compressor(Protocol):
    """What :func:`compressobj` returns (zlib's compressor objects)."""

    def compress(self, data: bytes | memoryview, /) -> bytes:
        """Return the stream's next bytes for ``data``."""
        ...

    def flush(self) -> bytes:
        """Return the stream's last bytes."""
        ...


def compress(data: bytes | memoryview, level: int | None = None) -> bytes:
    """Return ``data`` as one zlib stream at ``level`` (None: the fast setting)."""
    return zlib.compress(data, FAST_LEVEL if level is None else level)


def compressobj(level: int | None = None) -> Compressor:
    """Return a streaming compressor of one zlib stream (None: the fast setting)."""
    return zlib.compressobj(FAST_LEVEL if level is None else level)


def check_level(level: int | None, name: str = "level") -> None:
    """Raise ValueError unless ``level`` is None or a zlib level 0..9."""
    if level is not None and not 0 <= level <= 9:
        raise ValueError(f"{name} must be None (fast) or a zlib level 0..9, got {level}")
