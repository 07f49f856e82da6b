"""The output folder of one build: temporary names, shell and thickness files, the manifest.

Every file of a build is written under a temporary name (:func:`shellvox.atomic.atomic_path`)
entered into the build's :class:`contextlib.ExitStack`: they are renamed together when the
stack closes after the last slab, and removed if anything fails first. Then
:meth:`BuildFolder.commit` removes the older build's outputs, records the size and SHA-256
of every file (:meth:`shellvox.output._outdir.OutputFolder.commit`) and writes ``manifest.json``
last, so a folder with a manifest always holds one complete build.
"""

from __future__ import annotations

import contextlib
import json
import time
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from shellvox.atomic import atomic_path, write_text_atomic
from shellvox.model import ColouredMesh
from shellvox.offset.shells import Shell
from shellvox.output._outdir import OutputFolder
from shellvox.output._ply import write_thickness_ply
from shellvox.output._proof import PROOF_FILE, write_proof_ply
from shellvox.output._shells import save_shells
from shellvox.thickness import FaceThickness
from shellvox.voxel.colour import SoftProof


class BuildFolder:
    """Files of a build in progress, under temporary names until the stack closes.

    Parameters
    ----------
    folder : OutputFolder
        The locked output folder.
    stack : contextlib.ExitStack
        Renames the files when it closes normally, removes them when it unwinds an error.
    started : float
        When the build started (:func:`time.perf_counter`), for the manifest's total time.
    """

    def __init__(self, folder: OutputFolder, stack: contextlib.ExitStack, started: float) -> None:
        self.folder = folder
        self.stack = stack
        self.started = started
        self.path = folder.path
        #: Every file of the build, by its final name.
        self.written: list[Path] = []

    def temporary(self, name: str) -> Path:
        """Return the temporary path of the file ``name`` (relative to the folder)."""
        self.written.append(self.path / name)
        return self.stack.enter_context(atomic_path(self.path / name))

    def add(self, paths: Iterable[Path]) -> None:
        """Record files a writer has put in place itself (the PNG slices)."""
        self.written.extend(paths)

    def write_shells(self, shells: Sequence[Shell]) -> list[Shell]:
        """Write ``shells/shell_<k>.ply`` as given; return the shells as read back.

        The shells come ready for their files
        (:func:`shellvox.offset.reference.for_file.shell_for_file`).
        """
        folder = self.path / "shells"
        folder.mkdir(exist_ok=True)
        # unwound after the files' own removal: an interrupted build leaves no empty folder
        self.stack.callback(_remove_if_empty, folder)
        files = save_shells(folder, shells, stack=self.stack)
        self.written.extend(file.path for file in files)
        return [file.shell for file in files]

    def write_thickness(self, mesh: ColouredMesh, faces: FaceThickness) -> None:
        """Write ``thickness.ply``: the model with its per-face thickness."""
        write_thickness_ply(self.path / "thickness.ply", mesh, faces)
        self.written.append(self.path / "thickness.ply")

    def write_proof(self, proof: SoftProof) -> dict[str, Any]:
        """Write ``proof.ply`` (the soft proof); return the manifest's record of it."""
        write_proof_ply(self.path / PROOF_FILE, proof)
        self.written.append(self.path / PROOF_FILE)
        return {"file": PROOF_FILE, **proof.record()}

    def commit(self, manifest: dict[str, Any]) -> dict[str, Any]:
        """Add ``files`` to `manifest`, write ``manifest.json`` last and return it as written.

        Call once the stack has closed (every file renamed into place). The manifest's
        ``seconds["total"]`` is the time since `started`, the files' checksums included.
        """
        manifest["files"] = self.folder.commit(self.written)
        manifest["seconds"]["total"] = time.perf_counter() - self.started
        text = json.dumps(manifest, indent=2)
        write_text_atomic(self.path / "manifest.json", text)
        written: dict[str, Any] = json.loads(text)
        return written


def _remove_if_empty(folder: Path) -> None:
    """Remove `folder` if nothing is in it (a build's files renamed into it stay)."""
    with contextlib.suppress(OSError):
        folder.rmdir()
