"""Options a build cannot fit, refused up front with one line and exit 2 (issue 9, 4).

Each build runs as a process under an address-space limit of 2 GB: a refusal that came
after allocating the grid (hundreds of TB here) would fail with a MemoryError (exit 4) or
be killed, not refused. The output folder must not even be created.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import pytest
from fault_harness import REPO, assert_failed, build_argv, run, wait_for

from shellvox.run import RUN_FOLDER
from shellvox.testing import Command, temporary_files

TWO_GB = 2 * 1024**3


def _cases(*cases):
    return [pytest.param(options, needles, id=" ".join(options)) for options, needles in cases]


@pytest.mark.parametrize(
    ("options", "needles"),
    _cases(
        # 2.4e7 x 1.6e7 x 6e6 voxels: one row of the grid alone is 4e14 voxels
        (["--voxel-size", "1e-6,1e-6,1e-6"], ["--voxel-size", "memory", "larger --voxel-size"]),
        # a 24 km model: past the loader's 1 km limit (without --force)
        (["--scale", "1e6"], ["1e+06 mm", "--scale", "--force"]),
        (["--slab-mb", "inf"], ["--slab-mb", "inf"]),
        (["--slab-mb", "nan"], ["--slab-mb", "nan"]),
        (["--slab-mb", "lots"], ["--slab-mb", "lots"]),
        (["--slab-mb", "0"], ["--slab-mb"]),
        # the model is 6 mm thick: 100 mm of layers leave no core
        (["--thickness", "100"], ["--thickness", "6 mm", "--force"]),
        (["--thickness", "nan"], ["--thickness"]),
        (["--voxel-size", "inf,1,1"], ["--voxel-size"]),
        (["--voxel-size", "1e300,1,1"], ["--voxel-size", "index range"]),
        (["--voxel-size", "1e-300,1e-300,1e-300"], ["--voxel-size", "index range"]),
        (["--workers", "-1"], ["--workers"]),
        (["--compression-level", "99"], ["--compression-level"]),
    ),
)
def test_refused_before_allocating(tmp_path, options, needles):
    out = tmp_path / "out"
    result = run(build_argv(out, *options), tmp_path / "run", rlimit_as=TWO_GB)
    assert_failed(result, 2, *needles)
    assert not out.exists()


@pytest.mark.parametrize(
    ("options", "needles"),
    _cases(
        # 2.4e10 mm across: past the loader's limits, 1e6 mm, and 1e9 mm with --force (at
        # printer resolution that would be 5.7e11 voxels on a side, past 2^31)
        (["--scale", "1e9"], ["--scale"]),
        (["--scale", "1e9", "--force"], ["--scale"]),
        (["--units", "inch", "--scale", "1e7"], ["--scale"]),
        # within --force's 1e9 mm, but the grid past 2^31 voxels a side: no --force for that
        (["--scale", "5e7", "--force"], ["2^31"]),
        # the scaled coordinates overflow the arithmetic (areas, distances)
        (["--scale", "1e300"], ["colour_target.obj", "--scale"]),
        (["--scale", "1e300", "--force"], ["colour_target.obj", "--scale"]),
    ),
)
def test_model_scaled_past_the_grid_range(tmp_path, options, needles):
    out = tmp_path / "out"
    result = run(build_argv(out, *options), tmp_path / "run", rlimit_as=TWO_GB)
    # a model scaled this far is also implausibly large: one warning line may say so
    assert_failed(result, 2, *needles, warns=True)
    assert not out.exists()


def test_long_build_says_what_it_will_cost_first(tmp_path):
    # --voxel-size 0.01 on the default model: 2.4e9 voxels, many minutes. The estimate
    # comes before any work; the run can then be stopped cleanly.
    out = tmp_path / "out"
    command = Command(build_argv(out, "--voxel-size", "0.01"), tmp_path / "run")
    stderr = tmp_path / "run" / "stderr.txt"
    wait_for(lambda: "shellvox: grid" in stderr.read_text(), what="the estimate line")
    line = next(x for x in stderr.read_text().splitlines() if x.startswith("shellvox: grid"))
    assert "voxels" in line and "memory" in line and "on disk" in line
    assert " min" in line or " h" in line  # minutes or hours, not seconds
    command.signal(signal.SIGINT)
    line = assert_failed(command.finish(timeout=60), 130, "interrupted")
    # A build this long checkpoints by default, and its first slabs may finish before the
    # signal: those stay for --resume, and the line says where; nothing else is left.
    kept = sorted((out / RUN_FOLDER).glob("slab_*.npz"))
    left = {path.relative_to(out).parts[0] for path in temporary_files(out)}
    if kept:
        assert f"{len(kept)} finished slab(s) are kept in {out / RUN_FOLDER}" in line, line
        assert left == {RUN_FOLDER}, left
        assert not list((out / RUN_FOLDER).glob(".*")), "a chunk half written"
    else:
        assert left == set(), left


#: A program as ``python -m shellvox.cli``, holding an object whose finaliser fails at
#: the end of the process (as a library's object left half made by the signal does).
HALF_MADE = """
import signal, sys
signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
from shellvox.cli import main
class HalfMade:
    def __del__(self):
        raise AttributeError("half made")
kept = HalfMade()
sys.argv = ["shellvox", *sys.argv[1:]]
sys.exit(main())
"""


def test_an_interrupted_run_ends_without_the_tracebacks_of_finalisers(tmp_path):
    out, err = tmp_path / "out", tmp_path / "stderr.txt"
    # no checkpoints: slabs finished before the signal would stay in out/ for --resume
    argv = build_argv(out, "--voxel-size", "0.01", "--no-checkpoint")
    with err.open("w") as stream:
        process = subprocess.Popen(
            [sys.executable, "-c", HALF_MADE, *argv],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=stream,
            env={**os.environ, "PYTHONPATH": str(REPO)}, start_new_session=True,
        )  # fmt: skip
        wait_for(lambda: "shellvox: grid" in err.read_text(), what="the estimate line")
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=60) == 130
    stderr = err.read_text()
    assert "shellvox: error: interrupted (SIGINT)" in stderr
    assert "Traceback" not in stderr and "half made" not in stderr, stderr
    # the signal may land before or after the output folder is made: nothing left in it
    assert temporary_files(out) == [] and not (out / "manifest.json").exists()
