"""Run the ``shellvox`` command as a real process and check the failure contract.

The contract of every failure (issue 9): exactly one stderr line starting
``shellvox: error:`` (plus ``shellvox: warning:`` lines where the case warns, and the
estimate line ``shellvox: grid ...`` that ``build`` prints before it starts), the documented
exit status, no traceback, no temporary file in the output folder and no process of the
run left once the main process has exited.

The run itself (a session of its own, its process group found in ``/proc``) and the
checks of its folder are :class:`shellvox.testing.Command`,
:func:`~shellvox.testing.temporary_files` and :func:`~shellvox.testing.verified_files`;
here are the assertions of the contract and the build the tests run.
"""

from __future__ import annotations

import time
from pathlib import Path

from shellvox.testing import Command, Run, temporary_files

REPO = Path(__file__).resolve().parents[1]
MODEL = REPO / "data" / "colour_target" / "colour_target.obj"


def run(argv: list[str], workdir: Path, *, timeout: float = 120.0, **kwargs: object) -> Run:
    """Run the command to its end (see :class:`Command`)."""
    return Command(argv, workdir, **kwargs).finish(timeout)  # type: ignore[arg-type]


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
