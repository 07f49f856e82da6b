"""The ``shellvox`` command as a real process, and the processes it leaves (Linux).

A run is started in a session of its own, so its process group is its pid: every process
it forks or spawns (slab workers, the shell process, multiprocessing's resource tracker)
stays in that group, even once orphaned and adopted by init. Processes are found by
scanning ``/proc/*/stat`` (no psutil).
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path


@dataclass
class Proc:
    """A process seen in ``/proc``: pid, parent, process group, state, command line."""

    pid: int
    ppid: int
    pgid: int
    state: str
    cmdline: str


def processes() -> list[Proc]:
    """Return every live (not zombie) process of the machine."""
    found = []
    for entry in os.scandir("/proc"):
        if not entry.name.isdigit():
            continue
        try:
            with open(f"/proc/{entry.name}/stat", encoding="ascii", errors="replace") as stream:
                stat = stream.read()
            with open(f"/proc/{entry.name}/cmdline", "rb") as stream:
                cmdline = stream.read().replace(b"\0", b" ").decode(errors="replace").strip()
        except OSError:  # gone meanwhile
            continue
        # "pid (comm) state ppid pgrp ...": comm may hold spaces and parentheses
        fields = stat[stat.rindex(")") + 2 :].split()
        if fields[0] in ("Z", "X"):
            continue
        found.append(Proc(int(entry.name), int(fields[1]), int(fields[2]), fields[0], cmdline))
    return found


def group(pgid: int) -> list[Proc]:
    """Return the live processes of a process group."""
    return [p for p in processes() if p.pgid == pgid]


@dataclass
class Run:
    """A finished (or hung) run of the command.

    Attributes
    ----------
    argv : list of str
        The command's arguments (after ``shellvox``).
    pid : int
        Its main process (and process group).
    status : int or None
        The exit status; None: it did not exit in time (it was killed afterwards).
    stdout, stderr : str
    seconds : float
        From the start to the main process's exit (or the timeout).
    left : list of Proc
        The processes of the run alive after it (killed since).
    tmpdir : Path or None
        The run's ``TMPDIR``.
    """

    argv: list[str]
    pid: int
    status: int | None
    stdout: str
    stderr: str
    seconds: float
    left: list[Proc] = field(default_factory=list)
    tmpdir: Path | None = None

    @property
    def error_lines(self) -> list[str]:
        """The lines of stderr that start ``shellvox: error:``."""
        return [line for line in self.stderr.splitlines() if line.startswith("shellvox: error:")]


class Command:
    """A ``python -m shellvox.cli ...`` process in its own session, output to files.

    Output goes to ``stdout.txt`` and ``stderr.txt`` in `workdir`, not pipes: an orphaned
    child holding a pipe would block a reader. The run's ``TMPDIR`` is ``workdir/tmpdir``
    (it must be empty afterwards), its working folder `workdir`.

    Parameters
    ----------
    argv : list
        The command's arguments (after ``shellvox``).
    workdir : Path
    rlimit_as : int, optional
        The address-space limit of the process, bytes.
    env : dict, optional
        Its environment (default: this process's), ``TMPDIR`` and ``COLUMNS`` set and
        ``PYTHONWARNINGS`` removed.
    """

    def __init__(
        self,
        argv: list[str],
        workdir: Path,
        *,
        rlimit_as: int | None = None,
        env: dict[str, str] | None = None,
    ) -> None:
        self.argv = [str(a) for a in argv]
        workdir.mkdir(parents=True, exist_ok=True)
        self.tmpdir = workdir / "tmpdir"
        self.tmpdir.mkdir(exist_ok=True)
        self._out = open(workdir / "stdout.txt", "w+b")  # noqa: SIM115
        self._err = open(workdir / "stderr.txt", "w+b")  # noqa: SIM115
        environment = dict(os.environ if env is None else env)
        environment.update(TMPDIR=str(self.tmpdir), COLUMNS="200")
        environment.pop("PYTHONWARNINGS", None)

        def limit() -> None:  # in the child, before exec
            if rlimit_as is not None:
                import resource

                resource.setrlimit(resource.RLIMIT_AS, (rlimit_as, rlimit_as))

        self.started = time.monotonic()
        self.popen = subprocess.Popen(
            [sys.executable, "-m", "shellvox.cli", *self.argv],
            stdin=subprocess.DEVNULL,
            stdout=self._out,
            stderr=self._err,
            cwd=workdir,
            env=environment,
            start_new_session=True,
            preexec_fn=limit if rlimit_as is not None else None,
        )
        self.pid = self.popen.pid

    def children(self) -> list[Proc]:
        """Return the live processes of the run other than the main one."""
        return [p for p in group(self.pid) if p.pid != self.pid]

    def workers(self) -> list[Proc]:
        """Return the forked slab workers: children with the main process's command line."""
        main = next((p for p in processes() if p.pid == self.pid), None)
        if main is None:
            return []
        return [p for p in self.children() if p.ppid == self.pid and p.cmdline == main.cmdline]

    def signal(self, signum: int) -> None:
        """Send `signum` to the main process only (as ``kill -SIG PID`` would)."""
        os.kill(self.pid, signum)

    def finish(self, timeout: float = 120.0, grace: float = 2.0) -> Run:
        """Wait for the main process, then up to `grace` s for its group to vanish.

        A run that does not exit within `timeout` s is killed (with its group) and
        reported with ``status=None``; processes left after `grace` are reported in
        :attr:`Run.left`, then killed.
        """
        try:
            status: int | None = self.popen.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            status = None
        seconds = time.monotonic() - self.started
        deadline = time.monotonic() + grace
        left = group(self.pid)
        while left and time.monotonic() < deadline:
            time.sleep(0.05)
            left = group(self.pid)
        if status is None or left:  # leave nothing running behind
            for proc in left:
                with contextlib.suppress(ProcessLookupError):
                    os.kill(proc.pid, signal.SIGKILL)
            self.popen.kill()
            self.popen.wait()
        for stream in (self._out, self._err):
            stream.flush()
        self._out.seek(0)
        self._err.seek(0)
        run = Run(
            self.argv,
            self.pid,
            status,
            self._out.read().decode(errors="replace"),
            self._err.read().decode(errors="replace"),
            seconds,
            left,
            self.tmpdir,
        )
        self._out.close()
        self._err.close()
        return run
