"""The deflate settings: zlib streams, read back by zlib (the readers' inflater)."""

from __future__ import annotations

import zlib

import numpy as np
import pytest

from voxel.igzip import check_level, compress, compressobj


def _inputs() -> list[bytes]:
    rng = np.random.default_rng(3)
    runs = np.repeat(rng.integers(0, 4, 300, dtype=np.uint8), rng.integers(1, 900, 300))
    noise = rng.integers(0, 256, 70_000, dtype=np.uint8)
    keys = np.tile(np.array([255, 0, 255, 255], np.uint8), 50_000)  # an RGBA slice's runs
    return [b"", b"\x00", runs.tobytes(), noise.tobytes(), keys.tobytes()]


@pytest.mark.parametrize("level", [None, 0, 1, 6])
def test_streams_inflate_with_zlib(level):
    for data in _inputs():
        assert zlib.decompress(compress(data, level)) == data
        packer = compressobj(level)
        half = len(data) // 2
        stream = packer.compress(data[:half]) + packer.compress(data[half:]) + packer.flush()
        assert zlib.decompress(stream) == data


def test_zlib_levels_are_zlibs_own_bytes():
    """Reproducible builds: every setting writes zlib's own bytes, the fast one level 1's."""
    for data in _inputs():
        assert compress(data, 6) == zlib.compress(data, 6)
        assert compress(data) == zlib.compress(data, 1)
        packer = compressobj()
        assert packer.compress(data) + packer.flush() == zlib.compress(data, 1)


def test_fast_setting_packs_runs():
    data = _inputs()[4]
    assert len(compress(data)) < len(data) // 100


def test_bad_level():
    check_level(None)
    check_level(9)
    with pytest.raises(ValueError, match=r"zlib level 0\.\.9, got 12"):
        check_level(12)
