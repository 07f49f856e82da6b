"""The first compilation on a machine says so once, on stderr; later ones say nothing."""

from __future__ import annotations

import os
import subprocess
import sys

from shellvox.kernel_cache import NOTICE

#: A process that compiles one kernel (defined in a file of the test's, so numba may
#: cache it) after importing the API, which installs the notice.
COMPILE = """
import numpy as np
import shellvox.api
from shellvox.voxel._compiled import kernel

exec(compile("@kernel\\ndef twice(x):\\n    return 2 * x\\n", {path!r}, "exec"))
print(twice(np.arange(3.0)).sum())
"""


def _run(tmp_path) -> subprocess.CompletedProcess:
    (tmp_path / "kernels.py").touch()
    env = {**os.environ, "XDG_CACHE_HOME": str(tmp_path / "cache")}
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "numba")
    source = COMPILE.format(path=str(tmp_path / "kernels.py"))
    return subprocess.run([sys.executable, "-c", source], capture_output=True, text=True, env=env)


def test_the_notice_comes_once_per_machine(tmp_path):
    first = _run(tmp_path)
    assert first.returncode == 0, first.stderr
    assert first.stdout.strip() == "6.0"
    assert first.stderr.count(NOTICE) == 1
    again = _run(tmp_path)  # the marker is there: not said again
    assert again.returncode == 0 and NOTICE not in again.stderr
