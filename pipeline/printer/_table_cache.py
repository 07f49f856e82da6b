"""Solved separation tables: shipped with the package, and kept between runs.

A separation table (:mod:`shellvox.voxel.colour._model_separation`) is solved once per set
of materials and optics, which takes a while. The tables of the shipped printer profiles
ship with the package (``shellvox/printer/tables/``, made by ``scripts/make_tables.py``
and checked against a fresh solve by ``tests/printer/test_shipped_tables.py``); any other
(a user's profile, a calibrated one) is solved on first use and kept in
``$XDG_CACHE_HOME/shellvox``. Each file is named by the key of the inputs it was solved
from, so a table is only ever read for the inputs it answers. ``voxel`` itself does no
file I/O beyond its writers; an unreadable or unwritable cache only costs the solve.
"""

from __future__ import annotations

import contextlib
import os
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from shellvox.atomic import atomic_path

#: The tables shipped with the package (package data).
SHIPPED = Path(str(resources.files("shellvox.printer") / "tables"))


@dataclass(frozen=True)
class DiskTables:
    """float32 tables as ``.npy`` files in a folder, by key (written atomically).

    Parameters
    ----------
    folder : Path
        Where solved tables are kept (created on the first save).
    shipped : Path or None
        A read-only folder looked in first (the package's tables).

    Examples
    --------
    >>> import tempfile
    >>> store = DiskTables(Path(tempfile.mkdtemp()))
    >>> store.save("mixing-0", np.zeros((2, 2), np.float32))
    >>> store.load("mixing-0").shape, store.load("other")
    ((2, 2), None)
    """

    folder: Path
    shipped: Path | None = None

    @classmethod
    def default(cls) -> DiskTables:
        """Return the package's tables, then ``$XDG_CACHE_HOME/shellvox`` (``~/.cache``)."""
        root = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        return cls(Path(root) / "shellvox", SHIPPED)

    def load(self, key: str) -> NDArray[np.float32] | None:
        """Return the float32 table saved under `key`, or None (missing or unreadable)."""
        for folder in (self.shipped, self.folder):
            if folder is None:
                continue
            try:
                table: NDArray[np.float32] = np.load(folder / f"{key}.npy", allow_pickle=False)
            except (OSError, ValueError):
                continue
            if table.dtype == np.float32:
                return table
        return None

    def save(self, key: str, table: NDArray[np.float32]) -> None:
        """Save `table` under `key`; a folder that cannot be written is ignored."""
        with contextlib.suppress(OSError):
            self.folder.mkdir(parents=True, exist_ok=True)
            with atomic_path(self.folder / f"{key}.npy") as temporary, open(temporary, "wb") as f:
                np.save(f, table, allow_pickle=False)
