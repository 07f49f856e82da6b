"""Shell meshes as files: cleaned, written as float64 PLY, read back and checked.

A shell (:func:`offset.offset_shells`) is exact in float64 but carries clusters of
vertices and slivers far below a micrometre; written in float32 (trimesh's PLY export)
they become zero-area faces and coincident vertices. Its flat regions are also exactly
coplanar, which a triangle test without a coplanarity tolerance (MeshLab's) reads as
crossings at random. Here every shell is cleaned (:func:`offset.clean.clean_offset_shell`),
the vertices of coplanar triangle pairs moved by a tiny random amount
(:func:`offset.jitter.jitter_vertices`, 1e-8 of the extent), written with
``property double x/y/z``, read back with trimesh, and checked on what was read
(:func:`offset.quality.mesh_checks`, after merging coincident vertices), so what is
reported is what the file holds.
"""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import trimesh

from offset.clean import clean_offset_shell
from offset.jitter import jitter_vertices
from offset.quality import mesh_checks
from offset.shells import Shell
from pipeline import __version__
from pipeline.atomic import atomic_path
from pipeline.errors import ShellvoxWarning

#: The PLY header lines of the vertex coordinates.
DOUBLE_XYZ = ("property double x", "property double y", "property double z")


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
        ``tol_mm``, ``collapsed_vertices``, ``flipped_edges``, ``max_move_mm``,
        ``short_edges_left``, ``thin_faces_left`` (see :class:`offset.clean.CleanedMesh`),
        then ``jitter_mm``, ``jitter_moved_vertices``, ``jitter_kept_vertices`` and
        ``coplanar_pairs_left`` (see :class:`offset.jitter.JitteredMesh`); a vertex moved
        at most ``max_move_mm + jitter_mm`` in all.
    checks : dict
        :func:`offset.quality.mesh_checks` of the mesh read back.
    """

    shell: Shell
    path: Path
    cleaning: dict[str, Any]
    checks: dict[str, Any]


def save_shells(
    out_dir: Path, shells: Sequence[Shell], *, stack: contextlib.ExitStack | None = None
) -> list[WrittenShell]:
    """Write every shell to ``out_dir/shell_<layer>.ply``, each file atomically.

    Parameters
    ----------
    out_dir : Path
        Existing folder.
    shells : sequence of Shell
    stack : contextlib.ExitStack, optional
        Holds the files under their temporary names until it closes (a build renames all
        its files together); without it each file is renamed once written.

    Returns
    -------
    list of WrittenShell
    """
    written = []
    for shell in shells:
        target = Path(out_dir) / f"shell_{shell.layer}.ply"
        with contextlib.ExitStack() as own:
            temporary = (stack or own).enter_context(atomic_path(target))
            written.append(write_shell(temporary, shell, target=target))
    return written


def write_shell(path: Path, shell: Shell, *, target: Path | None = None) -> WrittenShell:
    """Clean `shell`, write it to `path` as float64 PLY, read it back and check it.

    Parameters
    ----------
    path : Path
        File to write (e.g. a temporary name from :func:`pipeline.atomic.atomic_path`).
    shell : Shell
    target : Path, optional
        The name the file will have, for :attr:`WrittenShell.path` and messages.

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
    cleaned_shell, cleaned = clean_offset_shell(shell)
    jittered = jitter_vertices(cleaned_shell.vertices, cleaned_shell.faces)
    write_ply(
        path,
        jittered.vertices,
        cleaned_shell.faces,
        comment=f"shellvox {__version__} offset shell, layer {shell.layer}",
    )
    vertices, faces = read_ply(path)
    checks = mesh_checks(vertices, faces)
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
        warnings.warn(
            f"{name}: the shell mesh is {', '.join(problems)}; it is written as computed, "
            "but a slicer may reject it (the voxel layers do not depend on it)",
            ShellvoxWarning,
            stacklevel=2,
        )
    return WrittenShell(
        shell=Shell(vertices=vertices, faces=faces, layer=shell.layer, depth_mm=shell.depth_mm),
        path=name,
        cleaning={
            "tol_mm": cleaned.tol_mm,
            "collapsed_vertices": cleaned.n_collapsed,
            "flipped_edges": cleaned.n_flipped,
            "max_move_mm": cleaned.max_move_mm,
            "short_edges_left": cleaned.short_edges,
            "thin_faces_left": cleaned.thin_faces,
            "jitter_mm": jittered.amplitude_mm,
            "jitter_moved_vertices": jittered.n_moved,
            "jitter_kept_vertices": jittered.n_kept,
            "coplanar_pairs_left": jittered.coplanar_pairs,
        },
        checks=checks,
    )


def write_ply(
    path: Path,
    vertices: npt.NDArray[np.float64],
    faces: npt.NDArray[np.int64],
    *,
    comment: str = "",
) -> None:
    """Write a triangle mesh as binary little-endian PLY with float64 coordinates.

    Parameters
    ----------
    path : Path
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
        Indices below ``2**31`` (stored as ``int``).
    comment : str, optional
        One header comment line.
    """
    v = np.ascontiguousarray(vertices, dtype="<f8")
    f = np.asarray(faces, dtype=np.int64)
    if v.ndim != 2 or v.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3:
        raise ValueError(
            f"vertices and faces must have shape (V, 3) and (F, 3), got {v.shape} and {f.shape}"
        )
    if f.size and (f.min() < 0 or f.max() >= min(len(v), 2**31)):
        raise ValueError(f"faces must index [0, {len(v)}), got range [{f.min()}, {f.max()}]")
    header = "\n".join(
        [
            "ply",
            "format binary_little_endian 1.0",
            *([f"comment {comment}"] if comment else []),
            f"element vertex {len(v)}",
            *DOUBLE_XYZ,
            f"element face {len(f)}",
            "property list uchar int vertex_indices",
            "end_header",
            "",
        ]
    )
    rows = np.empty(len(f), dtype=[("n", "u1"), ("index", "<i4", (3,))])
    rows["n"] = 3
    rows["index"] = f
    with open(path, "wb") as stream:
        stream.write(header.encode("ascii"))
        stream.write(v.tobytes())
        stream.write(rows.tobytes())


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
