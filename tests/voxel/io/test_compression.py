"""The deflate settings: zlib streams, read back by Python's zlib (the readers' inflater)."""

from __future__ import annotations

import subprocess
import sys
import zlib

import numpy as np
import pytest

from shellvox.voxel.io import check_level, compress, compressobj


def _inputs() -> list[bytes]:
    rng = np.random.default_rng(3)
    runs = np.repeat(rng.integers(0, 4, 300, dtype=np.uint8), rng.integers(1, 900, 300))
    noise = rng.integers(0, 256, 70_000, dtype=np.uint8)
    keys = np.tile(np.array([255, 0, 255, 255], np.uint8), 50_000)  # an RGBA slice's runs
    return [b"", b"\x00", runs.tobytes(), noise.tobytes(), keys.tobytes()]


@pytest.mark.parametrize("level", [None, 0, 1, 6, 9])
def test_streams_inflate_with_zlib(level):
    for data in _inputs():
        assert zlib.decompress(compress(data, level)) == data
        packer = compressobj(level)
        half = len(data) // 2
        stream = packer.compress(data[:half]) + packer.compress(data[half:]) + packer.flush()
        assert zlib.decompress(stream) == data


@pytest.mark.parametrize("level", [None, 6])
def test_equal_input_gives_equal_bytes_however_it_is_fed(level):
    """Reproducible builds: the stream does not depend on how the input is cut up."""
    for data in _inputs():
        whole = compress(data, level)
        for step in (1000, 65_536, 123_457):
            packer = compressobj(level)
            parts = [packer.compress(data[i : i + step]) for i in range(0, len(data), step)]
            assert b"".join(parts) + packer.flush() == whole
        assert compress(memoryview(bytearray(b"x" + data))[1:], level) == whole


_OTHER_PROCESS = """
import hashlib, sys
import numpy as np
from shellvox.voxel.io._compression import compress
junk = np.random.default_rng(int(sys.argv[1])).integers(0, 256, 3_000_000, np.uint8)
compress(junk.tobytes())
rng = np.random.default_rng(3)
runs = np.repeat(rng.integers(0, 4, 3000, dtype=np.uint8), rng.integers(1, 900, 3000))
print(hashlib.sha256(compress(runs.tobytes())).hexdigest())
"""


def test_equal_input_gives_equal_bytes_in_other_processes_after_other_work():
    """What a resumed or Dask build relies on: a worker's bytes are the writer's bytes."""
    digests = {
        subprocess.run(
            [sys.executable, "-c", _OTHER_PROCESS, str(seed)],
            capture_output=True,
            text=True,
            check=True,
        ).stdout
        for seed in (1, 2)
    }
    rng = np.random.default_rng(3)
    runs = np.repeat(rng.integers(0, 4, 3000, dtype=np.uint8), rng.integers(1, 900, 3000))
    import hashlib

    digests.add(hashlib.sha256(compress(runs.tobytes())).hexdigest() + "\n")
    assert len(digests) == 1


def test_fast_setting_packs_runs_better_than_zlib_level_1():
    for data in _inputs()[2:]:
        fast = len(compress(data))
        assert fast <= len(zlib.compress(data, 1)) * 1.02 + 16
    assert len(compress(_inputs()[4])) < len(_inputs()[4]) // 100


def test_bad_level():
    check_level(None)
    check_level(9)
    with pytest.raises(ValueError, match=r"zlib level 0\.\.9, got 12"):
        check_level(12)
