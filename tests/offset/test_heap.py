"""Large allocations come from the heap inside ``heap_blocks`` only (read from /proc)."""

from __future__ import annotations

import json
import platform
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

pytestmark = pytest.mark.skipif(
    platform.libc_ver()[0] != "glibc" or not Path("/proc/self/maps").is_file(),
    reason="glibc's malloc and /proc/self/maps",
)

#: Above the mmap threshold the block leaves (32 MiB).
LARGE = 64 << 20

#: Run in a fresh interpreter: in a test worker, earlier tests can leave free chunks in
#: the heap large enough to serve a request outside the block (glibc looks in its bins
#: before it maps), which says nothing about the block.
PROGRAM = """
import json
from pathlib import Path
import numpy as np
from shellvox.offset.field.heap import heap_blocks

LARGE = {large}


def in_heap(array):
    address = array.ctypes.data
    for line in Path("/proc/self/maps").read_text().splitlines():
        fields = line.split()
        if fields[-1] == "[heap]":  # numpy's huge-page advice may split it in several
            low, high = (int(x, 16) for x in fields[0].split("-"))
            if low <= address < high:
                return True
    return False


{body}
"""


def _run(body: str) -> dict[str, bool]:
    """Run `body` (which prints a JSON object of booleans) in a fresh interpreter."""
    program = PROGRAM.format(large=LARGE, body=textwrap.dedent(body))
    done = subprocess.run(
        [sys.executable, "-c", program], capture_output=True, text=True, check=True, timeout=120
    )
    result: dict[str, bool] = json.loads(done.stdout)
    return result


def test_large_blocks_come_from_the_heap_inside_and_from_mmap_outside():
    where = _run(
        """
        before = np.empty(LARGE, np.uint8)
        with heap_blocks():
            inside = np.empty(LARGE, np.uint8)
            with heap_blocks():
                nested = np.empty(LARGE, np.uint8)
            after_nested = np.empty(LARGE, np.uint8)  # the outer block still holds
        after = np.empty(LARGE, np.uint8)
        print(json.dumps({name: in_heap(a) for name, a in [
            ("before", before), ("inside", inside), ("nested", nested),
            ("after_nested", after_nested), ("after", after)]}))
        """
    )
    assert not where["before"]
    assert where["inside"] and where["nested"] and where["after_nested"]
    assert not where["after"]


def test_the_settings_go_back_when_the_block_fails():
    where = _run(
        """
        try:
            with heap_blocks():
                raise RuntimeError("stop")
        except RuntimeError:
            pass
        print(json.dumps({"after": in_heap(np.empty(LARGE, np.uint8))}))
        """
    )
    assert not where["after"]
