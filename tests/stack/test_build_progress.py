"""``shellvox.build`` shows its progress where a person is watching, and only there.

By default (``progress=None``) the bars show when stderr is a terminal or in a Jupyter
kernel, as :mod:`tqdm.auto` tells them; ``progress=True`` always, ``progress=False``
never. The build is a small real one; what its bars write is read from stderr.
"""

from __future__ import annotations

import io
import os
import select
import sys
import threading
import types

import pytest

import shellvox
from shellvox.stack._progress import watched

#: A small build: the bundled model on a coarse grid, the TIFFs only, no materials.
OPTIONS = shellvox.BuildOptions(
    voxel_size_mm=(0.5, 0.5, 0.5), formats=("tiff",), materials=None, report_samples=0
)


class Terminal(io.StringIO):
    """A text stream that says it is a terminal (as stderr is in a console)."""

    def isatty(self) -> bool:
        return True


@pytest.fixture(scope="module")
def model():
    return shellvox.load_model(shellvox.data.colour_target())


def _build_stderr(model, folder, monkeypatch, *, terminal: bool, **progress) -> str:
    stream = Terminal() if terminal else io.StringIO()
    monkeypatch.setattr(sys, "stderr", stream)
    shellvox.build(model, folder, OPTIONS, **progress)
    monkeypatch.undo()
    return stream.getvalue()


def test_a_build_off_a_terminal_is_quiet_by_default(model, tmp_path, monkeypatch):
    err = _build_stderr(model, tmp_path / "out", monkeypatch, terminal=False)
    assert "voxels" not in err


def test_a_build_on_a_terminal_shows_its_progress_by_default(model, tmp_path, monkeypatch):
    err = _build_stderr(model, tmp_path / "out", monkeypatch, terminal=True)
    assert "voxels: 100%" in err


def test_progress_true_shows_it_anywhere(model, tmp_path, monkeypatch):
    err = _build_stderr(model, tmp_path / "out", monkeypatch, terminal=False, progress=True)
    assert "voxels: 100%" in err


def test_progress_false_is_silent_even_on_a_terminal(model, tmp_path, monkeypatch):
    err = _build_stderr(model, tmp_path / "out", monkeypatch, terminal=True, progress=False)
    assert "voxels" not in err


def test_a_jupyter_kernel_is_watched(monkeypatch):
    monkeypatch.setattr(sys, "stderr", io.StringIO())  # a kernel's stderr is no terminal
    assert not watched()
    monkeypatch.setitem(sys.modules, "ipykernel.zmqshell", types.ModuleType("ipykernel.zmqshell"))
    assert watched()


def test_a_pseudo_terminal_nobody_sized_shows_the_progress(model, tmp_path, monkeypatch):
    """A new pseudo-terminal reports 0 columns (as under ``script`` with no terminal); the
    bars still show there, read back from the terminal's other end."""
    master, slave = os.openpty()
    assert os.get_terminal_size(slave).columns == 0
    written = bytearray()
    done = threading.Event()

    def drain() -> None:
        while True:  # until the build is done and the terminal has nothing more to read
            if select.select([master], [], [], 0.2)[0]:
                written.extend(os.read(master, 1 << 16))
            elif done.is_set():
                return

    reader = threading.Thread(target=drain)
    reader.start()
    try:
        with open(slave, "w", closefd=False) as terminal:
            monkeypatch.setattr(sys, "stderr", terminal)
            shellvox.build(model, tmp_path / "out", OPTIONS)
            terminal.flush()
            monkeypatch.undo()
    finally:
        done.set()
        reader.join()
        os.close(slave)
        os.close(master)
    assert "voxels: 100%" in written.decode("utf-8", "replace")
