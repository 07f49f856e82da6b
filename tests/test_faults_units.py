"""The fault machinery in-process: exit statuses, signals, child processes, output folder."""

from __future__ import annotations

import contextlib
import errno
import io
import os
import signal
import sys
import time
import zipfile

import numpy as np
import pytest

from shellvox.errors import InputError, OutputBusy, SlabWorkerDied
from shellvox.faults import (
    DeferredSignals,
    Interrupted,
    describe,
    raise_if_interrupted,
    signals_raise,
)
from shellvox.output import LOCK_NAME, OutputFolder, remove_leftovers
from shellvox.run import ChildCall, ChildDied


def _os_error(code, name="out/layers.tif"):
    return OSError(code, os.strerror(code), name)


def _wrapped(error):
    try:
        try:
            raise error
        except OSError as cause:
            raise RuntimeError("writing out/layers.tif failed") from cause
    except RuntimeError as outer:
        return outer


def _archive_closed_under_a_signal():
    """What zipfile raises when a signal lands while a member is open: the archive's
    ``with`` block closes it on the way out, and close() refuses (a real archive)."""
    archive = zipfile.ZipFile(io.BytesIO(), "w")
    member = archive.open("slab.npy", "w")
    try:
        try:
            raise Interrupted(signal.SIGTERM)
        finally:
            archive.close()
    except ValueError as error:
        member.close()
        archive.close()
        return error
    raise AssertionError("zipfile closed an archive with an open member")


@pytest.mark.parametrize(
    ("error", "status", "needle"),
    [
        (InputError("a.obj", "is empty", "export it again"), 2, "a.obj: is empty"),
        (OutputBusy("out", "another run", "wait"), 2, "another run"),
        (_os_error(errno.ENOSPC), 3, "No space left"),
        (_os_error(errno.EROFS), 3, "Read-only"),
        (_os_error(errno.EDQUOT), 3, "free some space"),
        (_wrapped(_os_error(errno.ENOSPC)), 3, "out/layers.tif"),  # from a writer thread
        (MemoryError(), 4, "out of memory"),
        (SlabWorkerDied("a slab worker process died"), 4, "slab worker"),
        (Interrupted(signal.SIGINT), 130, "SIGINT"),
        (Interrupted(signal.SIGTERM), 143, "SIGTERM"),
        (KeyboardInterrupt(), 130, "SIGINT"),
        (_archive_closed_under_a_signal(), 143, "SIGTERM"),  # the signal, not the cleanup
        (ValueError("bug\nsecond line"), 1, "--debug"),
    ],
    ids=lambda v: type(v).__name__ if isinstance(v, BaseException) else str(v),
)
def test_describe(error, status, needle):
    got, line = describe(error)
    assert got == status
    assert needle in line
    assert "\n" not in line


def _kill_self(signum):
    os.kill(os.getpid(), signum)
    time.sleep(0.05)  # the handler runs at the next bytecode


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_signal_raises_interrupted_then_handlers_are_restored(signum):
    before = signal.getsignal(signum)
    with pytest.raises(Interrupted) as caught, signals_raise():
        _kill_self(signum)
    assert caught.value.signum == signum
    assert signal.getsignal(signum) is before


def _interrupted_with_cleanup(cleaned):
    with signals_raise():
        try:
            _kill_self(signal.SIGINT)
        finally:  # the Interrupted is being handled: a second signal must not cut this
            _kill_self(signal.SIGTERM)
            cleaned.append(True)


def test_signal_during_cleanup_is_recorded_not_raised():
    cleaned = []
    with pytest.raises(Interrupted):
        _interrupted_with_cleanup(cleaned)
    assert cleaned == [True]


def _swallowed_then_checked():
    with signals_raise():
        with contextlib.suppress(BaseException):  # as trimesh does around optional imports
            _kill_self(signal.SIGTERM)
        raise_if_interrupted()


def test_swallowed_signal_is_raised_at_the_next_check():
    with pytest.raises(Interrupted) as caught:
        _swallowed_then_checked()
    assert caught.value.signum == signal.SIGTERM


class _SignalledFinaliser:
    """An object whose finaliser is cut by SIGINT (as a library's ``__del__`` in a GC pass)."""

    def __del__(self) -> None:
        os.kill(os.getpid(), signal.SIGINT)
        for _ in range(10_000):  # the handler runs here, inside the finaliser
            pass


def test_a_signal_inside_a_finaliser_is_kept_not_printed(capsys):
    hook = sys.unraisablehook
    with signals_raise():
        doomed = _SignalledFinaliser()
        del doomed  # the Interrupted raised in __del__ cannot propagate
        with pytest.raises(Interrupted) as caught:
            raise_if_interrupted()
    assert caught.value.signum == signal.SIGINT
    assert sys.unraisablehook is hook
    assert "Exception ignored" not in capsys.readouterr().err


def _deferred_then_closed(reached):
    with signals_raise():
        deferred = DeferredSignals().__enter__()
        _kill_self(signal.SIGINT)
        reached.append("after the signal")  # held back
        deferred.close()
        reached.append("after close")


def test_deferred_signal_arrives_at_close():
    # pytest's process has other threads (BLAS) that do not block the signals: the
    # deferral must hold all the same.
    reached = []
    with pytest.raises(Interrupted):
        _deferred_then_closed(reached)
    assert reached == ["after the signal"]


def _square(x):
    return x * x


def _fail(message):
    raise ValueError(message)


def _sleep(seconds):
    time.sleep(seconds)
    return seconds


def test_child_call_returns_and_reraises():
    array = np.arange(200_000.0)  # more than a pipe holds: the task is streamed
    with ChildCall(_square, array) as call:
        np.testing.assert_array_equal(call.result(), array * array)
    with ChildCall(_fail, "no shells") as call, pytest.raises(ValueError, match="no shells"):
        call.result()


def test_killed_child_fails_the_call_and_is_gone():
    with ChildCall(_sleep, 60.0) as call:
        pid = call._process.pid
        time.sleep(0.5)
        os.kill(pid, signal.SIGKILL)
        with pytest.raises(ChildDied, match="exit status -9"):
            call.result()


def _fail_with_child(seen):
    with ChildCall(_sleep, 60.0) as call:
        seen.append(call._process)
        raise KeyError("the run failed")


def test_leaving_the_block_kills_the_child():
    seen = []
    with pytest.raises(KeyError):
        _fail_with_child(seen)
    assert not seen[0].is_alive()
    assert seen[0].exitcode == -signal.SIGKILL


def test_leftovers_of_a_killed_run_are_removed(tmp_path):
    spool = tmp_path / ".vdb-spool.abc"
    spool.mkdir()
    (spool / "color.leaves").write_bytes(b"x")
    (tmp_path / ".layers.tif.x1.partial").write_bytes(b"x")
    (tmp_path / "shells").mkdir()
    (tmp_path / "shells" / ".shell_1.ply.y2.partial").write_bytes(b"x")
    (tmp_path / "notes.txt").write_text("mine")
    removed = remove_leftovers(tmp_path)
    assert len(removed) == 3
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["notes.txt", "shells"]


def test_second_holder_of_a_folder_is_refused(tmp_path):
    with OutputFolder(tmp_path) as first:
        assert (tmp_path / LOCK_NAME).read_text() == str(os.getpid())
        with pytest.raises(OutputBusy, match=f"pid {os.getpid()}"), OutputFolder(tmp_path):
            pass
        first.commit([])
    assert not (tmp_path / LOCK_NAME).exists()
