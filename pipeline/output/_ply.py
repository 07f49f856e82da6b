"""shellvox's one PLY writer: a triangle mesh, float64 coordinates, values per face.

trimesh's PLY exporter stores vertices as 32-bit floats; these files keep 64-bit
coordinates, so the thickness PLY's faces are exactly the faces the shells were made
from and the shell files hold the shells to the bit. The file is standard binary
little-endian PLY 1.0: ``element vertex`` with ``double x, y, z``, ``element face`` with
``list uchar int vertex_indices`` and one ``double`` property per face value. trimesh,
MeshLab and plyfile read it.

:func:`read_face_ply` reads that layout back (the viewer's depth view);
:func:`write_thickness_ply` writes ``thickness.ply`` atomically.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from shellvox.atomic import atomic_path
from shellvox.model import ColouredMesh
from shellvox.thickness import FaceThickness


def write_ply(
    path: str | Path,
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    face_values: Mapping[str, NDArray[np.float64]] | None = None,
    *,
    comment: str = "",
) -> None:
    """Write a triangle mesh, and values per face, to `path` (as it is: not atomically).

    Parameters
    ----------
    path : str or Path
        Target file (e.g. a temporary name from :func:`shellvox.atomic.atomic_path`).
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
        Indices below ``2**31`` (stored as ``int``).
    face_values : mapping of str to (F,) float64, optional
        Per-face properties, written as ``double`` in this order (names must be
        identifiers).
    comment : str, optional
        One header comment line.
    """
    face_values = face_values or {}
    vertex_rows = np.ascontiguousarray(vertices, dtype="<f8")
    f = np.asarray(faces, dtype=np.int64)
    if vertex_rows.ndim != 2 or vertex_rows.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3:
        raise ValueError(
            "vertices and faces must have shape (V, 3) and (F, 3), got "
            f"{vertex_rows.shape} and {f.shape}"
        )
    if f.size and (f.min() < 0 or f.max() >= min(len(vertex_rows), 2**31)):
        raise ValueError(
            f"faces must index [0, {len(vertex_rows)}), got range [{f.min()}, {f.max()}]"
        )
    n_faces = len(f)
    for name, values in face_values.items():
        if not name.isidentifier() or np.shape(values) != (n_faces,):
            raise ValueError(
                f"face value {name!r} must be an identifier with ({n_faces},) values, "
                f"got shape {np.shape(values)}"
            )
    face_rows = np.empty(
        n_faces,
        dtype=[("n", "u1"), ("corners", "<i4", (3,))] + [(k, "<f8") for k in face_values],
    )
    face_rows["n"] = 3
    face_rows["corners"] = f
    for name, values in face_values.items():
        face_rows[name] = values
    header = ["ply", "format binary_little_endian 1.0"]
    if comment:
        header.append("comment " + comment.replace("\n", " "))
    header += [
        f"element vertex {len(vertex_rows)}",
        "property double x",
        "property double y",
        "property double z",
        f"element face {n_faces}",
        "property list uchar int vertex_indices",
        *(f"property double {name}" for name in face_values),
        "end_header",
    ]
    with open(path, "wb") as stream:
        stream.write(("\n".join(header) + "\n").encode("ascii"))
        stream.write(vertex_rows.tobytes())
        stream.write(face_rows.tobytes())


class FacePly(NamedTuple):
    """A mesh with per-face values, as :func:`write_ply` writes it.

    Attributes
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
    values : dict of str to (F,) float64
        The per-face properties, in file order.
    """

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    values: dict[str, NDArray[np.float64]]


def read_face_ply(path: str | Path) -> FacePly:
    """Read a PLY written by :func:`write_ply` (that layout only, as written).

    Raises
    ------
    ValueError
        The file is not that layout, or is shorter than its header says.
    """
    data = Path(path).read_bytes()
    end = data.find(b"end_header\n")
    if not data.startswith(b"ply\n") or end < 0:
        raise ValueError(f"{path}: not a PLY file (no complete header)")
    lines = [line.strip() for line in data[:end].decode("ascii", "replace").splitlines()]
    lines = [line for line in lines[1:] if line and not line.startswith("comment")]
    counts: dict[str, int] = {}
    names: list[str] = []
    layout = []
    element = ""
    for line in lines:
        words = line.split()
        if words[0] == "element" and len(words) == 3 and words[2].isdigit():
            element = words[1]
            counts[element] = int(words[2])
            layout.append(f"element {element}")
        elif element == "face" and words[:2] == ["property", "double"] and len(words) == 3:
            names.append(words[2])
        else:
            layout.append(line)
    expected = [
        "format binary_little_endian 1.0",
        "element vertex",
        "property double x",
        "property double y",
        "property double z",
        "element face",
        "property list uchar int vertex_indices",
    ]
    if layout != expected or set(counts) != {"vertex", "face"}:
        raise ValueError(f"{path}: not shellvox's per-face PLY layout ({'; '.join(layout)})")
    row = np.dtype([("n", "u1"), ("corners", "<i4", (3,))] + [(k, "<f8") for k in names])
    start = end + len(b"end_header\n")
    n_v, n_f = counts["vertex"], counts["face"]
    if len(data) < start + 24 * n_v + row.itemsize * n_f:
        raise ValueError(f"{path}: shorter than its header says (truncated?)")
    vertices = np.frombuffer(data, dtype="<f8", count=3 * n_v, offset=start).reshape(n_v, 3)
    rows = np.frombuffer(data, dtype=row, count=n_f, offset=start + 24 * n_v)
    faces = rows["corners"].astype(np.int64)
    if np.any(rows["n"] != 3) or (n_f and (faces.min() < 0 or faces.max() >= n_v)):
        raise ValueError(f"{path}: faces that are not triangles of its vertices")
    values = {name: rows[name].astype(np.float64) for name in names}
    return FacePly(vertices.astype(np.float64), faces, values)


def write_thickness_ply(path: Path, mesh: ColouredMesh, faces: FaceThickness) -> None:
    """Write the model with per-face ``thickness`` (colour layer) and the rule's inputs.

    Face properties (double): ``thickness`` (colour layer, mm), ``thickness_1`` ..
    ``thickness_K`` (every layer, mm), ``lightness`` (``L*``), ``chroma`` (``C*``),
    ``alpha``, ``colour_spread`` (p90 CIEDE2000), ``normal_z``, ``mean_curvature``
    (1/mm), ``rule_thickness`` (the rule's own colour layer, before the limits, mm); with
    the optical rule also ``settled`` (1 or 0), ``deep_L``, ``deep_a``, ``deep_b`` (the
    mix infinitely deep, CIELAB D50) and ``share_<role>`` (the separation's shares).
    """
    values = {"thickness": faces.colour_layer_mm}
    values.update({f"thickness_{k + 1}": row for k, row in enumerate(faces.thickness_mm)})
    values.update(
        lightness=faces.colour.lightness,
        chroma=faces.colour.chroma,
        alpha=faces.colour.alpha,
        colour_spread=faces.colour.spread_de00,
        normal_z=faces.normal_z,
        mean_curvature=faces.mean_curvature,
        rule_thickness=faces.rule_mm,
    )
    if faces.optical is not None:
        optical = faces.optical
        values["settled"] = optical.settled.astype(np.float64)
        for axis, name in enumerate(("deep_L", "deep_a", "deep_b")):
            values[name] = optical.deep_lab[:, axis]
        for column, role in enumerate(optical.roles):
            values[f"share_{role}"] = optical.shares[:, column]
    with atomic_path(path) as temporary:
        write_ply(
            temporary,
            mesh.vertices,
            mesh.faces,
            values,
            comment=f"shellvox thickness of {mesh.source}",
        )
