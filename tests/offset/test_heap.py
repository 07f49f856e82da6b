"""Large allocations come from the heap inside ``heap_blocks`` only (read from /proc)."""

from __future__ import annotations

import platform
from pathlib import Path

import numpy as np
import pytest

from shellvox.offset.field.heap import heap_blocks

pytestmark = pytest.mark.skipif(
    platform.libc_ver()[0] != "glibc" or not Path("/proc/self/maps").is_file(),
    reason="glibc's malloc and /proc/self/maps",
)

#: Above the mmap threshold the block leaves (32 MiB).
LARGE = 64 << 20


def _in_heap(array: np.ndarray) -> bool:
    """Whether the array's data lies in the process's ``[heap]`` (the kernel's mappings)."""
    address = array.ctypes.data
    for line in Path("/proc/self/maps").read_text().splitlines():
        fields = line.split()
        if fields[-1] == "[heap]":  # numpy's huge-page advice may split it in several
            low, high = (int(x, 16) for x in fields[0].split("-"))
            if low <= address < high:
                return True
    return False


def test_large_blocks_come_from_the_heap_inside_and_from_mmap_outside():
    before = np.empty(LARGE, np.uint8)
    with heap_blocks():
        inside = np.empty(LARGE, np.uint8)
        with heap_blocks():
            nested = np.empty(LARGE, np.uint8)
        after_nested = np.empty(LARGE, np.uint8)  # the outer block still holds
    after = np.empty(LARGE, np.uint8)
    assert not _in_heap(before)
    assert _in_heap(inside) and _in_heap(nested) and _in_heap(after_nested)
    assert not _in_heap(after)


def test_the_settings_go_back_when_the_block_fails():
    with pytest.raises(RuntimeError), heap_blocks():
        raise RuntimeError("stop")
    assert not _in_heap(np.empty(LARGE, np.uint8))
