"""zlib streams at the fast setting: Intel's ISA-L (``igzip``) through python-isal.

Every file shellvox writes stores deflate data (TIFF compression 8, PNG's IDAT, OpenVDB's
``io::zipToStream``), and at printer resolution the compression of those bytes cost as
much as computing the voxels. ISA-L's level 1 compresses voxel pages 5 to 10 times faster
than zlib's level 1 and to smaller streams (a 1.7 MB RGBA printer slice: 0.7 ms and 17 kB
against 3.3 ms and 18 kB; a colour page: 0.5 ms and 12 kB against 2.9 ms and 16 kB;
``benchmarks/bench_compress.py``). Its output is an ordinary zlib stream (RFC 1950), so
every reader inflates it with zlib; it releases the GIL, so writer threads run in
parallel.

A *level* throughout shellvox is ``None`` for this fast setting, or zlib's level 1..9
(``--compression-level``) for smaller files at zlib's speed; 0 stores the bytes.
"""

from __future__ import annotations

import zlib
from typing import Protocol

from isal import isal_zlib

#: ISA-L's level of the fast setting (its levels are 0..3; 1 is its default).
FAST_LEVEL = 1


class Compressor(Protocol):
    """What :func:`compressobj` returns (zlib's and ISA-L's compressor objects)."""

    def compress(self, data: bytes | memoryview, /) -> bytes:
        """Return the stream's next bytes for ``data``."""
        ...

    def flush(self) -> bytes:
        """Return the stream's last bytes."""
        ...


def compress(data: bytes | memoryview, level: int | None = None) -> bytes:
    """Return ``data`` as one zlib stream: ISA-L when ``level`` is None, else zlib's level."""
    if level is None:
        return isal_zlib.compress(data, FAST_LEVEL)
    return zlib.compress(data, level)


def compressobj(level: int | None = None) -> Compressor:
    """Return a streaming compressor of one zlib stream (ISA-L when ``level`` is None)."""
    if level is None:
        packer: Compressor = isal_zlib.compressobj(FAST_LEVEL)
        return packer
    return zlib.compressobj(level)


def check_level(level: int | None, name: str = "level") -> None:
    """Raise ValueError unless ``level`` is None or a zlib level 0..9."""
    if level is not None and not 0 <= level <= 9:
        raise ValueError(f"{name} must be None (fast, ISA-L) or a zlib level 0..9, got {level}")
