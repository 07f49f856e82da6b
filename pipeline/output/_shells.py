"""Shell meshes as files: written as float64 PLY, read back and checked.

The shells come ready for their files (:func:`shellvox.offset.reference.for_file.shell_for_file`:
cleaned and jittered, by the caller); here each is written as it is given, with ``property double
x/y/z`` (trimesh's PLY export would round to float32), read back with trimesh, and checked on what
was read (:func:`shellvox.offset.quality.measures.mesh_checks`, after merging coincident vertices),
so what is reported is what the file holds.
"""

from __future__ import annotations

import contextlib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import trimesh

from shellvox import __version__
from shellvox.atomic import atomic_path
from shellvox.errors import warn
from shellvox.offset.quality.measures import mesh_checks
from shellvox.offset.shells import Shell
from shellvox.output._ply import write_ply


@dataclass(frozen=True)
class WrittenShell:
    """A shell as written to and read back from its file.

    Attributes
    ----------
    shell : Shell
        Vertices ``(n, 3) float64`` mm and faces ``(m, 3) int64`` as read back.
    path : Path
        Where the file is (or will be, once its temporary name is renamed).
    cleaning : dict
        What made the shell ready for the file, as given
        (:attr:`shellvox.offset.reference.for_file.ShellForFile.cleaning`; empty when not given).
    checks : dict
        :func:`shellvox.offset.quality.measures.mesh_checks` of the mesh read back.
    as_given : bool
        The file read back holds exactly the vertices and faces given.
    """

    shell: Shell
    path: Path
    cleaning: dict[str, Any]
    checks: dict[str, Any]
    as_given: bool = False


def save_shells(
    out_dir: Path,
    shells: Sequence[Shell],
    *,
    cleaning: Sequence[dict[str, Any]] | None = None,
    stack: contextlib.ExitStack | None = None,
    crossing_free: bool = False,
) -> list[WrittenShell]:
    """Write every shell to ``out_dir/shell_<layer>.ply``, each file atomically.

    Parameters
    ----------
    out_dir : Path
        Existing folder.
    shells : sequence of Shell
        Ready for their files (:func:`shellvox.offset.reference.for_file.shell_for_file`).
    cleaning : sequence of dict, optional
        What made each shell ready, for :attr:`WrittenShell.cleaning`.
    stack : contextlib.ExitStack, optional
        Holds the files under their temporary names until it closes (a build renames all
        its files together); without it each file is renamed once written.
    crossing_free : bool, optional
        The shells as given, all together, were tested and no two of their triangles
        cross (:attr:`shellvox.output.MethodShells.crossing_free`): a file that reads
        back exactly as given counts no crossing pair again.

    Returns
    -------
    list of WrittenShell
    """
    records = cleaning if cleaning is not None else [{}] * len(shells)
    written = []
    for shell, record in zip(shells, records, strict=True):
        target = Path(out_dir) / f"shell_{shell.layer}.ply"
        with contextlib.ExitStack() as own:
            temporary = (stack or own).enter_context(atomic_path(target))
            written.append(
                write_shell(
                    temporary, shell, target=target, cleaning=record, crossing_free=crossing_free
                )
            )
    return written


def write_shell(
    path: Path,
    shell: Shell,
    *,
    target: Path | None = None,
    cleaning: dict[str, Any] | None = None,
    crossing_free: bool = False,
) -> WrittenShell:
    """Write `shell` to `path` as float64 PLY, read it back and check it.

    Parameters
    ----------
    path : Path
        File to write (e.g. a temporary name from :func:`shellvox.atomic.atomic_path`).
    shell : Shell
        Written as given (ready for the file:
        :func:`shellvox.offset.reference.for_file.shell_for_file`).
    target : Path, optional
        The name the file will have, for :attr:`WrittenShell.path` and messages.
    cleaning : dict, optional
        What made `shell` ready, kept as :attr:`WrittenShell.cleaning`.
    crossing_free : bool, optional
        `shell` was tested to have no crossing triangle pairs (see :func:`save_shells`).

    Returns
    -------
    WrittenShell

    Warns
    -----
    ShellvoxWarning
        When the file read back is not closed, not oriented, has zero-area faces or
        crossing triangles.
    """
    name = Path(target if target is not None else path)
    write_ply(
        path,
        shell.vertices,
        shell.faces,
        comment=f"shellvox {__version__} offset shell, layer {shell.layer}",
    )
    vertices, faces = read_ply(path)
    as_given = np.array_equal(vertices, shell.vertices) and np.array_equal(faces, shell.faces)
    checks = mesh_checks(vertices, faces, crossing_pairs=0 if crossing_free and as_given else None)
    problems = [
        text
        for text, bad in (
            ("not closed", not checks["closed"]),
            ("not consistently oriented", not checks["oriented"]),
            (f"{checks['zero_area_faces']} zero-area faces", checks["zero_area_faces"]),
            (
                f"{checks['self_intersections']} crossing triangle pairs",
                checks["self_intersections"],
            ),
        )
        if bad
    ]
    if problems:
        warn(
            f"{name}: the shell mesh is {', '.join(problems)}; it is written as computed, "
            "but a slicer may reject it (the voxel layers do not depend on it)",
        )
    return WrittenShell(
        shell=Shell(vertices=vertices, faces=faces, layer=shell.layer, depth_mm=shell.depth_mm),
        path=name,
        cleaning=dict(cleaning or {}),
        checks=checks,
        as_given=as_given,
    )


def read_ply(path: Path) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """Read a PLY mesh with trimesh, as written (no merging, no reordering).

    Returns
    -------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
    """
    header = ply_header(path)
    if header[-1] != "end_header":
        raise ValueError(f"{path}: not a complete PLY header")
    if "element face 0" in header:  # a layer that fills the part: trimesh reads no mesh
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
    mesh = trimesh.load(str(path), file_type="ply", process=False, force="mesh")
    if not isinstance(mesh, trimesh.Trimesh):
        raise ValueError(f"{path}: read as {type(mesh).__name__}, not a triangle mesh")
    vertices = np.asarray(mesh.vertices, dtype=np.float64).reshape(-1, 3)
    faces = np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3)
    return vertices, faces


def ply_header(path: Path) -> list[str]:
    """Return the header lines of a PLY file, up to and including ``end_header``."""
    lines: list[str] = []
    with open(path, "rb") as stream:
        for raw in stream:
            line = raw.decode("ascii", errors="replace").strip()
            lines.append(line)
            if line == "end_header" or len(lines) > 200:
                break
    return lines
