"""Run the ``shellvox`` command as a real process and check the failure contract.

The contract of every failure (issue 9): exactly one stderr line starting
``shellvox: error:`` (plus ``shellvox: warning:`` lines where the case warns, and the
estimate line ``shellvox: grid ...`` that ``build`` prints before it starts), the documented
exit status, no traceback, no temporary file in the output folder and no process of the
run left once the main process has exited.

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

REPO = Path(__file__).resolve().parents[1]
MODEL = REPO / "data" / "colour_target" / "colour_target.obj"

#: Names shellvox gives its temporary files; no shellvox output starts with a dot.
TEMPORARY_HINTS = (".partial", ".vdb-spool", ".staging", ".shellvox.lock")


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
    """A finished (or hung) run of the command."""

    argv: list[str]
    pid: int
    status: int | None  # None: it did not exit in time (it was killed afterwards)
    stdout: str
    stderr: str
    seconds: float
    left: list[Proc] = field(default_factory=list)  # processes of the run alive after it
    tmpdir: Path | None = None  # the run's TMPDIR

    @property
    def error_lines(self) -> list[str]:
        return [line for line in self.stderr.splitlines() if line.startswith("shellvox: error:")]


class Command:
    """A ``python -m shellvox.cli ...`` process in its own session, output to files.

    Output goes to files, not pipes: an orphaned child holding a pipe would block a reader.
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
        self.tmpdir = workdir / "tmpdir"  # TMPDIR of the run: must be empty afterwards
        self.tmpdir.mkdir(exist_ok=True)
        self._out = open(workdir / "stdout.txt", "w+b")  # noqa: SIM115
        self._err = open(workdir / "stderr.txt", "w+b")  # noqa: SIM115
        environment = dict(os.environ if env is None else env)
        environment.update(PYTHONPATH=str(REPO), TMPDIR=str(self.tmpdir), COLUMNS="200")
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
        reported with ``status=None``.
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
        if status is None or left:  # leave nothing running behind the tests
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


def run(argv: list[str], workdir: Path, *, timeout: float = 120.0, **kwargs: object) -> Run:
    """Run the command to its end (see :class:`Command`)."""
    return Command(argv, workdir, **kwargs).finish(timeout)  # type: ignore[arg-type]


def temporary_files(folder: Path) -> list[Path]:
    """Return what a run left in `folder` (recursively) that is not a shellvox output."""
    if not folder.exists():
        return []
    return sorted(
        path
        for path in folder.rglob("*")
        if path.name.startswith(".") or any(hint in path.name for hint in TEMPORARY_HINTS)
    )


def assert_failed(
    result: Run,
    status: int,
    *needles: str,
    folder: Path | None = None,
    warns: bool = False,
) -> str:
    """Assert the failure contract; return the error line.

    Parameters
    ----------
    result : Run
    status : int
        The documented exit status.
    needles : str
        Text the error line must hold.
    folder : Path, optional
        The output folder: it must hold no temporary file.
    warns : bool
        ``shellvox: warning:`` lines are allowed.
    """
    context = f"argv {result.argv}\nstatus {result.status}\nstderr:\n{result.stderr}"
    assert result.status is not None, f"hung (killed after the timeout)\n{context}"
    assert "Traceback" not in result.stderr, context
    assert result.status == status, context
    assert len(result.error_lines) == 1, context
    for line in result.stderr.splitlines():
        allowed = line.startswith(("shellvox: error: ", "shellvox: grid "))
        allowed = allowed or (warns and line.startswith("shellvox: warning: "))
        assert allowed, f"unexpected stderr line {line!r}\n{context}"
    for needle in needles:
        assert needle in result.error_lines[0], context
    assert_clean(result, folder)
    return result.error_lines[0]


def assert_clean(result: Run, folder: Path | None) -> None:
    """Assert no process of the run is left and no temporary file in `folder` or TMPDIR."""
    assert not result.left, f"processes left: {result.left}\nstderr:\n{result.stderr}"
    if folder is not None:
        assert temporary_files(folder) == [], f"left in {folder}\nstderr:\n{result.stderr}"
    if result.tmpdir is not None:
        assert list(result.tmpdir.iterdir()) == [], f"left in TMPDIR\nstderr:\n{result.stderr}"


def assert_succeeded(result: Run, folder: Path | None = None, *, warns: bool = False) -> None:
    """Assert a run ended with status 0, nothing on stderr but the estimate (and warnings
    if `warns`), nothing left behind."""
    context = f"argv {result.argv}\nstatus {result.status}\nstderr:\n{result.stderr}"
    assert result.status == 0, context
    for line in result.stderr.splitlines():
        allowed = line.startswith("shellvox: grid ")
        allowed = allowed or (warns and line.startswith("shellvox: warning: "))
        assert allowed, f"unexpected stderr line {line!r}\n{context}"
    assert_clean(result, folder)


#: A build of the default model that takes a few seconds: 71 x 171 x 251 voxels in slabs
#: of 6 rows on 2 workers, without the shell meshes (their process takes ~20 s).
FAST = (
    "--voxel-size", "0.1,0.1,0.1", "--workers", "2", "--slab-mb", "16",
    "--no-shell-meshes", "--no-progress",
)  # fmt: skip


def build_argv(out: Path, *extra: str, fast: bool = True) -> list[str]:
    """Return the arguments of a build of the default model into `out`."""
    return ["build", str(MODEL), "-o", str(out), *(FAST if fast else ()), *extra]


def wait_for(condition: object, timeout: float = 60.0, what: str = "condition") -> None:
    """Poll ``condition()`` every 10 ms until it is true; fail after `timeout` s."""
    deadline = time.monotonic() + timeout
    while not condition():  # type: ignore[operator]
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.01)


def verified_files(folder: Path, extra: tuple[str, ...] = ()) -> dict[str, object]:
    """Check a finished build against its manifest, independently of shellvox; return it.

    Every file in `folder` (but `extra`, files of the user's) is ``manifest.json`` or listed
    in it, every listed file is there with the recorded size and SHA-256 (recomputed here
    with hashlib), and the TIFF stacks read back with tifffile at the grid's shape.
    """
    import hashlib
    import json

    import tifffile

    manifest = json.loads((folder / "manifest.json").read_text())
    present = {str(p.relative_to(folder)) for p in folder.rglob("*") if not p.is_dir()}
    assert present == {"manifest.json", *manifest["files"], *extra}, present
    for name, record in manifest["files"].items():
        data = (folder / name).read_bytes()
        assert len(data) == record["bytes"], name
        assert hashlib.sha256(data).hexdigest() == record["sha256"], name
    n_z, n_y, n_x = manifest["grid"]["shape_zyx"]
    for name in ("layers.tif", "colour.tif"):
        with tifffile.TiffFile(folder / name) as tif:
            assert len(tif.pages) == n_z
            assert tif.pages[0].shape[:2] == (n_y, n_x)
    return manifest  # type: ignore[no-any-return]


def holds_nothing(folder: Path, extra: tuple[str, ...] = ()) -> bool:
    """Return whether `folder` is absent or holds only `extra` (no build, no temporary)."""
    if not folder.exists():
        return True
    return {str(p.relative_to(folder)) for p in folder.rglob("*")} == set(extra)
