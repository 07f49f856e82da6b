"""The deflate streams of every file shellvox writes, at one place: the fast setting.

A *level* throughout shellvox is ``None`` for the fast setting, or zlib's level 1..9
(``--compression-level``) for smaller files at a slower speed; 0 stores the bytes. Every
stream is an ordinary zlib stream that any inflater reads.

The fast setting is zlib-ng's level 2 (python-zlib-ng, which releases the GIL as Python's
zlib does): on a build's own pages faster than zlib's level 1 and smaller (measured: the
documentation's performance page, ``bench_compress``). The given levels are Python's zlib.

Equal builds must be byte-equal (resume, Dask, the VDB content id), so equal input must
give equal bytes whatever the encoder compressed before and however the input is fed to
a :func:`compressobj`; ``tests/voxel/io/test_compression.py`` checks both, across processes.
That rules out zlib-ng's levels 1 (its quick strategy; also some 40 % larger than zlib's
level 1), 5 and 6: their streams changed with where the input was cut in 90, 88 and 90
of 90 random cuttings of 30 inputs; levels 2, 3, 4, 7 and 9 never did. It also rules out
ISA-L's igzip, as fast: a Dask build whose worker was killed mid-build wrote other
``volume.vdb`` leaf bytes (equal values) in 3 of 7 loaded runs.
"""

from __future__ import annotations

import zlib
from typing import Protocol

from zlib_ng import zlib_ng

#: zlib-ng's level of the fast setting.
FAST_LEVEL = 2


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
    if level is None:
        return zlib_ng.compress(data, FAST_LEVEL)
    return zlib.compress(data, level)


def compressobj(level: int | None = None) -> Compressor:
    """Return a streaming compressor of one zlib stream (None: the fast setting)."""
    if level is None:
        return zlib_ng.compressobj(FAST_LEVEL)
    return zlib.compressobj(level)


def check_level(level: int | None, name: str = "level") -> None:
    """Raise ValueError unless ``level`` is None or a zlib level 0..9."""
    if level is not None and not 0 <= level <= 9:
        raise ValueError(f"{name} must be None (fast) or a zlib level 0..9, got {level}")
