"""The one error type for bad input: it names the file, the problem and the fix."""

from __future__ import annotations

from pathlib import Path


class InputError(ValueError):
    """Bad user input, reported as one line naming the file, the problem and the fix.

    The CLI prints ``str(error)`` on stderr and exits with status 2.

    Parameters
    ----------
    path : str or Path or None
        The file (or option) the problem is about.
    problem : str
        What is wrong, with the values seen.
    fix : str
        What the user can do about it.
    """

    def __init__(self, path: str | Path | None, problem: str, fix: str) -> None:
        self.path = None if path is None else str(path)
        self.problem = problem
        self.fix = fix
        super().__init__(str(self))

    def __str__(self) -> str:
        where = f"{self.path}: " if self.path else ""
        return f"{where}{self.problem}; {self.fix}".replace("\n", " ")


class ShellvoxWarning(UserWarning):
    """Something was changed or assumed on the user's behalf (printed by the CLI)."""


class SlabWorkerDied(RuntimeError):
    """A slab worker process ended without returning its slab (e.g. out of memory)."""


class ClusterError(InputError):
    """The Dask scheduler cannot be reached, was lost, or has no workers."""


class OutputBusy(InputError):
    """Another shellvox run holds the output folder (reported like bad input, exit 2)."""


class ResourceError(InputError):
    """The run would not fit the machine (memory, disk, index range); ``--force`` overrides."""


class FdmError(InputError):
    """An FDM project that cannot be made as asked: filaments, colours, depth or slicer."""
