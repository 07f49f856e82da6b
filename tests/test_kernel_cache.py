"""The first compilation into a kernel cache says so once, on stderr; a warm cache says nothing.

Each case runs a fresh process with its own ``NUMBA_CACHE_DIR``: the cache that is used,
not a marker elsewhere (``~/.cache``, another environment's), decides.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numba

from shellvox import __version__
from shellvox.kernel_cache import NOTICE

#: A process that runs one of shellvox's kernels after importing the API, which installs
#: the notice: value 0's second voxel is at 2, value 1's first at 1.
SHELLVOX_KERNEL = """
import numpy as np
import shellvox.api
from shellvox.voxel.sampler import _positions

starts = np.array([0, 1] + [2] * 255, dtype=np.int64)
ranks = np.array([1, 0], dtype=np.int64)
print(_positions(np.array([0, 1, 0, 1], dtype=np.uint8), ranks, starts).tolist())
"""

#: A process that compiles a numba function of its own (not shellvox's) with the API loaded.
OWN_FUNCTION = """
import numba
import shellvox.api

print(numba.njit(lambda x: 2 * x)(3))
"""


def _run(source: str, numba_cache: Path, home: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "XDG_CACHE_HOME": str(home), "NUMBA_CACHE_DIR": str(numba_cache)}
    return subprocess.run([sys.executable, "-c", source], capture_output=True, text=True, env=env)


def _old_marker(home: Path) -> None:
    """Make the marker an earlier shellvox (or another environment) left in ~/.cache."""
    python = f"{sys.version_info.major}{sys.version_info.minor}"
    old = home / "shellvox" / f"kernels-{__version__}-numba{numba.__version__}-py{python}"
    old.parent.mkdir(parents=True)
    old.touch()


def test_an_empty_cache_is_said_once_and_a_warm_one_not(tmp_path):
    home = tmp_path / "home-cache"
    _old_marker(home)  # another environment's marker: not this cache's
    first = _run(SHELLVOX_KERNEL, tmp_path / "numba", home)
    assert first.returncode == 0, first.stderr
    assert first.stdout.strip() == "[2, 1]"
    assert first.stderr.count(NOTICE) == 1
    assert list((tmp_path / "numba").rglob("*.nbi"))  # compiled into this cache
    warm = _run(SHELLVOX_KERNEL, tmp_path / "numba", home)  # loaded from it: nothing said
    assert warm.returncode == 0 and warm.stdout.strip() == "[2, 1]"
    assert NOTICE not in warm.stderr
    other = _run(SHELLVOX_KERNEL, tmp_path / "numba-2", home)  # another, empty cache
    assert other.returncode == 0 and other.stderr.count(NOTICE) == 1


def test_a_callers_own_numba_function_is_not_said(tmp_path):
    own = _run(OWN_FUNCTION, tmp_path / "numba", tmp_path / "home-cache")
    assert own.returncode == 0, own.stderr
    assert own.stdout.strip() == "6" and NOTICE not in own.stderr
