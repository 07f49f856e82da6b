"""Checkpoints of a build, so that a killed run (SIGKILL, power loss) can be resumed.

A build that checkpoints keeps a run folder, ``DIR/.shellvox-run/``, beside its outputs:

- ``journal.json`` names the run: a key of the things the slabs depend on (the shellvox
  version, the input file's bytes, the loaded model and its colours, the thickness per
  face, the configuration except ``workers``, the printer and material plan, the grid and
  the slab height), each part a SHA-256;
- ``slab_<z_start>_<z_stop>.npz``, one chunk per finished slab
  (:mod:`shellvox.run._chunks`), each put in place atomically.

``--resume`` reads the finished slabs back and computes only the others; all slabs go
through the same writers in z order, so the files come out as an uninterrupted run's.
Resuming is refused, naming what differs, when the key is not the same. The folder is
removed once the build has committed (its manifest written), and by a run without
``--resume`` (which starts afresh). A run that fails removes it too (one complete build or
none: the contract of :mod:`shellvox.output._outdir`), except when a rerun can get past the
failure (SIGINT or SIGTERM, a slab worker killed, the Dask cluster lost, a full disk) and a
slab has finished: then the finished slabs stay for ``--resume``, and the error line says
so. What cannot clean up (SIGKILL, power loss, the kernel's OOM killer) leaves the run
folder, and ``--resume`` continues from it.
The output folder's lock (:mod:`shellvox.output._outdir`) covers it, and temporary chunk names
(``.*.partial``) are among the leftovers every run removes first.
"""

from __future__ import annotations

import contextlib
import dataclasses
import errno
import hashlib
import json
import pickle
import shutil
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from shellvox import __version__
from shellvox.atomic import write_text_atomic
from shellvox.config import BuildConfig, as_json, check_flag
from shellvox.errors import ClusterError, InputError, SlabWorkerDied, add_note, opt
from shellvox.faults import interruption, os_error
from shellvox.model import ColouredMesh
from shellvox.output import sha256
from shellvox.run._chunks import decode_chunk, encode_chunk, save_chunk
from shellvox.run._task import Rows, StackSlab
from shellvox.voxel.grid import GridSpec
from shellvox.voxel.io import STORE_LAYOUT

#: The run folder's name inside the output folder.
RUN_FOLDER = ".shellvox-run"
JOURNAL = "journal.json"


@dataclasses.dataclass(frozen=True)
class RunSettings:
    """How a build runs (not what it builds): where slabs run, checkpoints, resume.

    Parameters
    ----------
    scheduler : str, optional
        A Dask scheduler's address (``tcp://host:8786``) or ``"local"``; None: this
        machine's processes (``BuildConfig.workers``).
    resume : bool
        Continue the unfinished run in the output folder.
    checkpoint : bool or None
        Keep every finished slab in the run folder, so that a killed run can resume;
        None: when the estimate says the build takes longer than
        :data:`CHECKPOINT_AFTER_S` (compressing the chunks adds to every slab's time, so
        short builds go without).
    """

    scheduler: str | None = None
    resume: bool = False
    checkpoint: bool | None = None

    def __post_init__(self) -> None:
        """Check every value once, naming the parameter and the allowed values."""
        if self.scheduler is not None and not (
            isinstance(self.scheduler, str) and self.scheduler.strip()
        ):
            raise InputError(
                opt("scheduler"),
                f"got {self.scheduler!r}",
                "give a Dask scheduler's address (tcp://host:8786), 'local' or None",
            )
        check_flag("resume", self.resume)
        check_flag("checkpoint", self.checkpoint, optional=True)


#: Builds estimated to take longer than this (s) checkpoint by default.
CHECKPOINT_AFTER_S = 600.0


class RunFolder:
    """The chunks of one run in ``DIR/.shellvox-run`` (see the module).

    Parameters
    ----------
    path : Path
        The run folder (it exists).
    """

    def __init__(self, path: Path) -> None:
        self.path = path

    def chunk_path(self, rows: Rows) -> Path:
        """Return the chunk file of the slab of `rows`."""
        return self.path / f"slab_{rows[0]:010d}_{rows[1]:010d}.npz"

    def finished(self, ranges: Iterable[Rows]) -> set[Rows]:
        """Return those of `ranges` whose chunk is there."""
        return {rows for rows in ranges if self.chunk_path(rows).is_file()}

    def save(self, rows: Rows, done: StackSlab, send: tuple[str, ...] | None = None) -> None:
        """Checkpoint a finished slab (only the arrays `send` when it has its pages)."""
        save_chunk(self.chunk_path(rows), encode_chunk(done, send))

    def save_bytes(self, rows: Rows, data: bytes) -> None:
        """Checkpoint a slab already encoded (:func:`shellvox.run._chunks.encode_chunk`)."""
        save_chunk(self.chunk_path(rows), data)

    def load(self, rows: Rows) -> StackSlab:
        """Return a checkpointed slab (ValueError: the chunk is damaged)."""
        try:
            data = self.chunk_path(rows).read_bytes()
        except OSError as error:
            raise ValueError(f"unreadable chunk ({error})") from None
        return decode_chunk(data)

    def remove(self) -> None:
        """Remove the run folder."""
        shutil.rmtree(self.path, ignore_errors=True)


def run_key(
    mesh: ColouredMesh,
    config: BuildConfig,
    grid: GridSpec,
    rows: int,
    thickness: np.ndarray[Any, np.dtype[np.float64]],
    extra: Any = None,
    *,
    model: str | None = None,
) -> dict[str, str]:
    """Return the parts of a run's key, each a SHA-256 of what the slabs depend on.

    Parameters
    ----------
    mesh : ColouredMesh
        The loaded model (its arrays and colour source; its file's bytes too).
    config : BuildConfig
        The configuration; ``workers`` does not change the slabs and is left out.
    grid : GridSpec
    rows : int
        Slab height.
    thickness : (K, F) float64, mm
    extra : object, optional
        More that the slabs depend on (the printer profile and material plan), pickled.
    model : str, optional
        The model's digest when `mesh` alone does not give it (a tray: its models'
        :func:`model_key` and places); default ``model_key(mesh)``.
    """

    def digest(*parts: bytes) -> str:
        hasher = hashlib.sha256()
        for part in parts:
            hasher.update(hashlib.sha256(part).digest())
        return hasher.hexdigest()

    source = Path(mesh.source) if mesh.source else None
    settings = as_json(config)
    settings.pop("workers", None)
    return {
        "tool": f"shellvox {__version__}",
        "input": sha256(source) if source is not None and source.is_file() else "",
        "model": model if model is not None else model_key(mesh),
        "thickness": digest(np.ascontiguousarray(thickness, np.float64).tobytes()),
        "config": digest(json.dumps(settings, sort_keys=True).encode()),
        "printer": digest(pickle.dumps(extra)),
        "grid": digest(str((grid.shape_zyx, grid.origin_mm, grid.voxel_mm, rows)).encode()),
        "store": digest(STORE_LAYOUT.encode()),
    }


def model_key(mesh: ColouredMesh) -> str:
    """Return a SHA-256 of a model's vertices, faces and colour source (its arrays)."""
    colour = mesh.surface_colour()
    hasher = hashlib.sha256()
    for part in (
        np.ascontiguousarray(mesh.vertices).tobytes(),
        np.ascontiguousarray(mesh.faces).tobytes(),
        *(
            np.ascontiguousarray(getattr(colour, f.name)).tobytes()
            for f in dataclasses.fields(colour)
        ),
    ):
        hasher.update(hashlib.sha256(part).digest())
    return hasher.hexdigest()


_NAMES = {
    "tool": "the shellvox version",
    "input": "the input file",
    "model": "the loaded model or its colours (loader options, textures)",
    "thickness": "the thickness per face",
    "config": "the build options",
    "printer": "the printer profile or material options",
    "grid": f"the grid or {opt('slab_mb')}",
}


def check_resumable(out_dir: Path, key: dict[str, str]) -> bool:
    """Whether ``--resume`` continues an unfinished run in `out_dir` (False: none there).

    Called before the output folder is locked (and again once it is): a refused resume
    leaves the folder untouched.

    Raises
    ------
    InputError
        `out_dir` holds a finished build, or an unfinished run of another `key`.
    """
    journal = Path(out_dir) / RUN_FOLDER / JOURNAL
    if journal.is_file():
        _check_key(journal, key)
        return True
    if (Path(out_dir) / "manifest.json").is_file():
        raise InputError(
            opt("resume"),
            f"{out_dir} holds a finished build (manifest.json) and nothing to resume",
            f"rerun without {opt('resume')} to build it again",
        )
    return False


@contextlib.contextmanager
def checkpoints(
    out_dir: Path, key: dict[str, str], settings: RunSettings
) -> Iterator[RunFolder | None]:
    """Open the run folder of a build (the caller holds the output folder's lock).

    Yields None when the build does not checkpoint. Without ``settings.resume`` an
    earlier run's folder is removed and a new one started; with it, the earlier run's
    key must equal `key`. The folder is removed when the block ends (after the build
    has committed, or failed), except after a failure a rerun can get past (signals, a slab
    worker killed, a lost cluster, a full disk) when it holds a chunk.
    """
    path = Path(out_dir) / RUN_FOLDER
    if not (settings.checkpoint or settings.resume):
        shutil.rmtree(path, ignore_errors=True)  # a plain run starts afresh
        yield None
        return
    fresh = not (settings.resume and check_resumable(out_dir, key))  # refused: untouched
    run = RunFolder(path)
    try:  # a signal while the folder is made removes it like any other
        if fresh:
            shutil.rmtree(path, ignore_errors=True)
            path.mkdir()
            write_text_atomic(path / JOURNAL, json.dumps({"key": key}, indent=2))
        yield run
    except BaseException as error:
        n_chunks = sum(1 for _ in path.glob("slab_*.npz"))
        if n_chunks == 0 or not _resumable_failure(error):
            run.remove()
            raise
        add_note(
            error,
            f"{n_chunks} finished slab(s) are kept in {path}; the same run with "
            f"{opt('resume')} continues from them",
        )
        raise
    run.remove()


def _resumable_failure(error: BaseException) -> bool:
    """Whether a run that failed this way is worth resuming (its chunks are kept).

    A signal (Ctrl-C, a batch system's SIGTERM at its time limit), a worker killed (for
    lack of memory), a lost cluster or a full disk: running again can finish the build.
    A bad input or a bug would fail again the same way.
    """
    if interruption(error) is not None or isinstance(error, SlabWorkerDied | ClusterError):
        return True
    cause = os_error(error)
    return cause is not None and cause.errno in (errno.ENOSPC, errno.EDQUOT)


def _check_key(journal: Path, key: dict[str, str]) -> None:
    """Refuse to resume a run whose key differs, naming what changed."""
    try:
        earlier = json.loads(journal.read_text(encoding="utf-8"))["key"]
    except (OSError, ValueError, KeyError, TypeError):
        earlier = {}
    if not isinstance(earlier, dict):
        earlier = {}
    changed = [_NAMES.get(part, part) for part in key if earlier.get(part) != key[part]]
    if changed:
        raise InputError(
            opt("resume"),
            f"the unfinished build in {journal.parent.parent} was made with other inputs: "
            f"{', '.join(changed)} differ",
            f"rerun with the same model and options, or without {opt('resume')} to start afresh",
        )
