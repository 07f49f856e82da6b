"""An output folder holds one complete run or none.

:class:`OutputFolder` is the transaction around a run that writes into a folder:

* **Lock.** An exclusive ``flock`` on ``DIR/.shellvox.lock`` (non-blocking): a second run
  into the same folder is refused at once (:class:`shellvox.errors.OutputBusy`) instead of
  mixing its files with the first one's.
* **Leftovers.** Holding the lock, the run removes what an earlier run that was killed
  (SIGKILL, power loss) left behind: temporary files (``.NAME.*.partial``) and spool
  folders (``.vdb-spool.*``). No other run can own them while the lock is held.
* **No stale "complete" marker.** ``manifest.json`` (or the command's report) goes first:
  from then until the new run commits, the folder holds no complete run.
* **Failure.** A run that fails or is interrupted leaves no complete-looking file and
  removes the old run's outputs too: the folder then holds no run.
* **Replace as a whole.** :meth:`OutputFolder.commit` removes the outputs of the old run
  that the new run did not write (listed in the old manifest, or matching the file names
  this command writes) and returns the size and SHA-256 of every file written, for the
  new manifest, which is written last.

Files that do not look like shellvox outputs are never touched.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import fnmatch
import hashlib
import json
import os
import shutil
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from shellvox.errors import InputError, OutputBusy, opt
from shellvox.faults import DeferredSignals

LOCK_NAME = ".shellvox.lock"

#: Names (relative, ``fnmatch`` patterns) of what ``build`` and ``inspect`` write.
BUILD_OUTPUTS = (
    "manifest.json",
    "layers.tif",
    "colour.tif",
    "materials.tif",
    "volume.vdb",
    "job.gcvf",
    "thickness.ply",
    "proof.ply",
    "thickness.png",
    "report.json",
    "shells/shell_*.ply",
    "preview/*.png",
    "slices/*",
    "stack.ome.zarr/*",
    "stack.ome.zarr/**/*",
)

#: Names of what ``shells`` writes.
SHELL_OUTPUTS = ("report.json", "shell_*.ply", "thickness.ply")

#: Temporary names any shellvox run may leave when killed.
TEMPORARY = (".*.partial", ".vdb-spool.*", ".staging.*")


class OutputFolder:
    """Lock a folder, clear an earlier run's leftovers and replace its outputs as a whole.

    Parameters
    ----------
    path : Path
        The output folder (created with its parents).
    outputs : sequence of str
        ``fnmatch`` patterns, relative to `path`, of the files this command writes.
    marker : str
        The file whose presence says the folder holds a complete run (removed on entry).

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> with OutputFolder(folder, ("a.txt", "manifest.json")) as out:
    ...     _ = (folder / "a.txt").write_text("x")
    ...     sorted(out.commit([folder / "a.txt"]))
    ['a.txt']
    """

    def __init__(
        self, path: Path, outputs: Iterable[str] = BUILD_OUTPUTS, marker: str = "manifest.json"
    ) -> None:
        self.path = Path(path)
        self.outputs = tuple(outputs)
        self.marker = marker
        self._lock: int | None = None
        self._old_files: list[str] = []

    def __enter__(self) -> OutputFolder:
        if self.path.exists() and not self.path.is_dir():
            raise InputError(
                self.path, "exists and is not a folder", f"choose another {opt('out')}"
            )
        self.path.mkdir(parents=True, exist_ok=True)
        try:
            # the lock file is made and its removal registered as one; a signal that arrived
            # meanwhile raises as the block closes, and the lock goes with it
            with DeferredSignals():
                self._lock = _acquire(self.path / LOCK_NAME)
            self._old_files = _listed_files(self.path / self.marker)
            remove_leftovers(self.path)
            (self.path / self.marker).unlink(missing_ok=True)
        except BaseException:
            self._release()
            raise
        return self

    def __exit__(self, kind: type[BaseException] | None, *_: object) -> None:
        try:
            if kind is not None:  # one complete run or none: the old outputs go too
                remove_leftovers(self.path)
                self.commit([])
        finally:
            self._release()

    def commit(self, written: Iterable[Path]) -> dict[str, dict[str, Any]]:
        """Remove the old run's outputs not in `written`; return the new files' records.

        Parameters
        ----------
        written : iterable of Path
            Every file of the new run, already in place (not the marker itself).

        Returns
        -------
        dict
            ``{relative path: {"bytes": int, "sha256": str}}``, sorted by path.
        """
        keep = {Path(p).resolve() for p in written}
        old = self._old_outputs()
        for path in old:
            if path.resolve() not in keep and path.name != self.marker:
                path.unlink(missing_ok=True)
        # the folders the old outputs were in (shells/, preview/, the OME-Zarr store's
        # nested ones), deepest first
        root = self.path.resolve()
        folders = {f for p in old for f in p.resolve().parents if root in f.parents}
        for folder in sorted(folders, key=lambda p: len(p.parts), reverse=True):
            if root in folder.parents:
                with contextlib.suppress(OSError):
                    folder.rmdir()  # only when empty
        return {
            str(path.relative_to(self.path)): {"bytes": path.stat().st_size, "sha256": sha256(path)}
            for path in sorted(Path(p) for p in written)
        }

    def _candidates(self) -> list[Path]:
        found: list[Path] = []
        for pattern in self.outputs:
            found.extend(p for p in self.path.glob(pattern) if p.is_file() or p.is_symlink())
        return found

    def _old_outputs(self) -> list[Path]:
        listed = []
        for name in self._old_files:
            path = (self.path / name).resolve()
            if self.path.resolve() in path.parents and any(
                fnmatch.fnmatch(name, pattern) for pattern in self.outputs
            ):
                listed.append(path)
        return listed + self._candidates()

    def _release(self) -> None:
        if self._lock is not None:
            with DeferredSignals():  # not cut between the removal and the release
                with contextlib.suppress(OSError):
                    os.unlink(self.path / LOCK_NAME)  # still held: no one else can own it
                os.close(self._lock)
                self._lock = None


def _acquire(lock_path: Path) -> int:
    """Return a descriptor holding an exclusive lock on `lock_path`, or raise OutputBusy."""
    for _ in range(10):
        fd = os.open(lock_path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as error:
            owner = os.pread(fd, 64, 0).decode("ascii", "replace").strip() or "?"
            os.close(fd)
            if error.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                raise OutputBusy(
                    lock_path.parent,
                    f"another shellvox run (pid {owner}) is writing to this folder",
                    f"wait for it to finish or choose another {opt('out')}",
                ) from None
            raise
        try:
            same = os.fstat(fd).st_ino == os.stat(lock_path).st_ino
        except FileNotFoundError:
            same = False
        if same:  # not a lock file its last holder had already removed
            os.ftruncate(fd, 0)
            os.pwrite(fd, str(os.getpid()).encode(), 0)
            return fd
        os.close(fd)
    raise OutputBusy(lock_path.parent, "could not lock the folder", "try again")


def remove_leftovers(folder: Path) -> list[Path]:
    """Remove temporary files and spool folders of earlier runs (the caller holds the lock).

    Looks in `folder` and its direct subfolders. Returns what was removed.
    """

    def temporary(entry: Path) -> bool:
        return any(fnmatch.fnmatch(entry.name, pattern) for pattern in TEMPORARY)

    removed = []
    # (not into the temporary folders themselves: they go as a whole, from `folder`)
    subfolders = [p for p in folder.iterdir() if p.is_dir() and not p.is_symlink()]
    for place in [folder, *(p for p in subfolders if not temporary(p))]:
        for entry in list(place.iterdir()):
            if not temporary(entry):
                continue
            if entry.is_dir() and not entry.is_symlink():
                shutil.rmtree(entry, ignore_errors=True)
            else:
                entry.unlink(missing_ok=True)
            removed.append(entry)
    return removed


def _listed_files(manifest: Path) -> list[str]:
    """Return the files an old manifest lists (none when it is missing or unreadable)."""
    try:
        data = json.loads(manifest.read_text(encoding="utf-8"))
        files = data.get("files", {}) if isinstance(data, dict) else {}
        return [str(name) for name in files] if isinstance(files, dict) else []
    except (OSError, ValueError):
        return []


def sha256(path: Path) -> str:
    """Return the hex SHA-256 of a file, read in blocks."""
    with open(path, "rb") as stream:
        return hashlib.file_digest(stream, "sha256").hexdigest()
