"""Solved lookup tables kept between runs, in ``$XDG_CACHE_HOME/shellvox``.

:class:`DiskTables` is the store :func:`shellvox.voxel.colour._separation.mixing_separation` reads
its solved mixing table from and writes it to (about two seconds to solve); ``voxel``
itself does no file I/O beyond its writers. An unreadable or unwritable cache only
costs the solve.
"""

from __future__ import annotations

import contextlib
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from shellvox.atomic import atomic_path


@dataclass(frozen=True)
class DiskTables:
    """float32 tables as ``.npy`` files in a folder, by key (written atomically).

    Parameters
    ----------
    folder : Path
        Where the tables are kept (created on the first save).

    Examples
    --------
    >>> import tempfile
    >>> store = DiskTables(Path(tempfile.mkdtemp()))
    >>> store.save("mixing-0", np.zeros((2, 2), np.float32))
    >>> store.load("mixing-0").shape, store.load("other")
    ((2, 2), None)
    """

    folder: Path

    @classmethod
    def default(cls) -> DiskTables:
        """Return the store in ``$XDG_CACHE_HOME/shellvox`` (``~/.cache/shellvox``)."""
        root = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        return cls(Path(root) / "shellvox")

    def load(self, key: str) -> NDArray[np.float32] | None:
        """Return the float32 table saved under `key`, or None (missing or unreadable)."""
        try:
            table: NDArray[np.float32] = np.load(self.folder / f"{key}.npy", allow_pickle=False)
        except (OSError, ValueError):
            return None
        return table if table.dtype == np.float32 else None

    def save(self, key: str, table: NDArray[np.float32]) -> None:
        """Save `table` under `key`; a folder that cannot be written is ignored."""
        with contextlib.suppress(OSError):
            self.folder.mkdir(parents=True, exist_ok=True)
            with atomic_path(self.folder / f"{key}.npy") as temporary, open(temporary, "wb") as f:
                np.save(f, table, allow_pickle=False)
