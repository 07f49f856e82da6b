"""Signals and killed processes during a real build, run as a process (issue 9, 1-2).

Each case asserts the contract: one ``shellvox: error:`` line, the documented status
(130 SIGINT, 143 SIGTERM, 4 killed worker), no traceback, no temporary file in the output
folder, and no process of the run left once it has exited (its process group, scanned in
/proc). The signal times are random (seeded, printed on failure) within a phase of the
run: start-up (imports, loading) or slabs (workers running).
"""

from __future__ import annotations

import os
import random
import signal
import time
from pathlib import Path

import pytest
from fault_harness import assert_failed, assert_succeeded, build_argv, run, wait_for

from shellvox.testing import Command, holds_nothing, temporary_files, verified_files

STATUS = {signal.SIGINT: 130, signal.SIGTERM: 143}

#: Shell meshes made in a process of their own, beside the slab workers (the ``field``
#: shells are meshed in the main process from the voxels' scan; the other methods spawn).
SHELL_PROCESS = ("--shell-meshes", "--method", "robust")


def _signal_in_slabs(command: Command, rng: random.Random, signum: int) -> float:
    """Send `signum` at a random time once the slab workers run; return the delay."""
    wait_for(lambda: len(command.workers()) == 2, what="the slab workers")
    delay = rng.uniform(0.0, 0.4)
    time.sleep(delay)
    command.signal(signum)
    return delay


def _importing(command: Command) -> bool:
    """Return whether the run has begun its imports (numpy is mapped)."""
    try:
        return "numpy" in Path(f"/proc/{command.pid}/maps").read_text()
    except OSError:
        return False


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["INT", "TERM"])
def test_signal_during_startup(tmp_path, signum):
    # From the imports to the loading of the model. (Before the interpreter runs the
    # first line of pipeline/cli/__main__.py, ~40 ms, a signal has its default effect.)
    rng = random.Random(f"startup-{signum}")
    out = tmp_path / "out"
    command = Command(build_argv(out), tmp_path / "run")
    wait_for(lambda: _importing(command), what="the imports")
    delay = rng.uniform(0.0, 0.6)
    time.sleep(delay)
    command.signal(signum)
    result = command.finish(timeout=60)
    assert_failed(result, STATUS[signum], "interrupted", folder=out)
    assert holds_nothing(out), (delay, sorted(out.rglob("*")))


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["INT", "TERM"])
def test_signal_during_slabs(tmp_path, signum, seed):
    rng = random.Random(f"slabs-{signum}-{seed}")
    out = tmp_path / "out"
    command = Command(build_argv(out), tmp_path / "run")
    delay = _signal_in_slabs(command, rng, signum)
    result = command.finish(timeout=60)
    assert_failed(result, STATUS[signum], "interrupted", folder=out)
    assert holds_nothing(out), (delay, sorted(out.rglob("*")))


@pytest.mark.parametrize(
    ("signum", "status", "message"),
    [
        # A terminal's Ctrl-C reaches every process of the group: workers, the shell
        # process and multiprocessing's resource tracker must print nothing.
        (signal.SIGINT, 130, "interrupted"),
        # kill -TERM -PGID (a service manager stopping the job): the workers die at once,
        # the main process reports the signal, not a dead worker.
        (signal.SIGTERM, 143, "interrupted (SIGTERM)"),
    ],
    ids=["INT", "TERM"],
)
def test_signal_to_the_process_group_with_shell_process(tmp_path, signum, status, message):
    out = tmp_path / "out"
    command = Command(build_argv(out, *SHELL_PROCESS), tmp_path / "run")
    wait_for(lambda: len(command.children()) >= 4, what="workers, shell process, tracker")
    os.killpg(command.pid, signum)
    result = command.finish(timeout=60)
    assert_failed(result, status, message, folder=out)
    assert holds_nothing(out)


def test_interrupted_rebuild_leaves_no_build(tmp_path):
    # One complete build or none: the interrupted rebuild takes the old build with it,
    # but not the user's own files.
    out = tmp_path / "out"
    assert_succeeded(run(build_argv(out), tmp_path / "first"), out)
    (out / "notes.txt").write_text("mine")
    command = Command(build_argv(out, "--thickness", "0.4,0.4"), tmp_path / "second")
    _signal_in_slabs(command, random.Random("rebuild"), signal.SIGINT)
    result = command.finish(timeout=60)
    assert_failed(result, 130, "interrupted", folder=out)
    assert holds_nothing(out, extra=("notes.txt",))
    assert (out / "notes.txt").read_text() == "mine"


def test_sigkill_of_the_main_process(tmp_path):
    out = tmp_path / "out"
    command = Command(build_argv(out, *SHELL_PROCESS), tmp_path / "run")
    wait_for(lambda: len(command.children()) >= 4, what="workers, shell process, tracker")
    # once every temporary is there: partial TIFFs and VDB, the VDB spool folder, the lock
    wait_for(lambda: len(temporary_files(out)) >= 5, what="the build's temporary files")
    _signal_in_slabs(command, random.Random("kill"), signal.SIGKILL)
    result = command.finish(timeout=60, grace=1.0)
    assert result.status == -signal.SIGKILL
    assert result.left == [], "workers outlived the main process by more than a second"
    left = {p.name.split(".")[1] for p in temporary_files(out)}
    assert {"vdb-spool", "layers", "shellvox"} <= left, "the kill came too late"
    # The next build into the folder removes the leftovers and succeeds.
    (out / "notes.txt").write_text("mine")
    again = run(build_argv(out), tmp_path / "next")
    assert_succeeded(again, out)
    verified_files(out, extra=("notes.txt",))


def test_killed_slab_worker(tmp_path):
    out = tmp_path / "out"
    command = Command(build_argv(out), tmp_path / "run")
    wait_for(lambda: len(command.workers()) == 2, what="the slab workers")
    os.kill(command.workers()[0].pid, signal.SIGKILL)
    result = command.finish(timeout=60)
    assert_failed(result, 4, "slab worker", folder=out)
    assert holds_nothing(out)


def test_killed_shell_process_warns_and_keeps_the_voxels(tmp_path):
    # The shell meshes are computed beside the voxels; when their process dies the build
    # must not hang: it ends with the voxel stack, without shells/, and one warning.
    out = tmp_path / "out"
    command = Command(build_argv(out, *SHELL_PROCESS), tmp_path / "run")

    def shell_process():
        workers = {p.pid for p in command.workers()}
        return [
            p
            for p in command.children()
            if p.ppid == command.pid and p.pid not in workers and "spawn_main" in p.cmdline
        ]

    wait_for(lambda: len(shell_process()) == 1, what="the shell process")
    os.kill(shell_process()[0].pid, signal.SIGKILL)
    result = command.finish(timeout=120)
    assert_succeeded(result, out, warns=True)
    warnings = [line for line in result.stderr.splitlines() if "warning" in line]
    assert len(warnings) == 1 and "shell meshes failed" in warnings[0], result.stderr
    manifest = verified_files(out)
    assert not any(name.startswith("shells/") for name in manifest["files"])


@pytest.mark.slow
@pytest.mark.parametrize("trial", range(6))
def test_random_signals_with_shell_meshes(tmp_path, trial):
    # Any time from start to the end of the robust shells (~30 s): the build may also finish first.
    rng = random.Random(f"random-{trial}")
    signum = rng.choice([signal.SIGINT, signal.SIGTERM, signal.SIGKILL])
    delay = rng.uniform(0.05, 20.0)
    out = tmp_path / "out"
    command = Command(build_argv(out, *SHELL_PROCESS), tmp_path / "run")
    time.sleep(delay)
    command.signal(signum)
    # A shell process spawned just before a SIGKILL arms its death signal only once it has
    # imported the project (seconds on a loaded machine), then finds its parent gone and
    # exits: give it that long before counting it as left behind.
    result = command.finish(timeout=60, grace=15.0)
    context = f"{signal.Signals(signum).name} after {delay:.2f} s"
    if signum == signal.SIGKILL:
        assert result.status == -signal.SIGKILL, context
        assert result.left == [], context
    elif result.status == 0:  # the build finished before the signal came
        assert_succeeded(result, out)
        verified_files(out)
    else:
        assert_failed(result, STATUS[signum], "interrupted", folder=out)
        assert holds_nothing(out), context
    assert_succeeded(run(build_argv(out), tmp_path / "next"), out)
    verified_files(out)
