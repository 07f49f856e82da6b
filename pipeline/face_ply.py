"""Write a triangle mesh with per-face values as a binary PLY (float64 coordinates).

trimesh's PLY exporter stores vertices as 32-bit floats; the thickness PLY keeps the
model's 64-bit coordinates so that its faces are exactly the faces the shells were made
from. The file is standard binary little-endian PLY 1.0: ``element vertex`` with
``double x, y, z``, ``element face`` with ``list uchar int vertex_indices`` and one
``double`` property per face value. trimesh, MeshLab and plyfile read it.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pipeline.atomic import atomic_path


def write_face_ply(
    path: str | Path,
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    face_values: Mapping[str, NDArray[np.float64]],
    *,
    comment: str = "",
) -> None:
    """Write ``path`` atomically.

    Parameters
    ----------
    path : str or Path
        Target file.
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
    face_values : mapping of str to (F,) float64
        Per-face properties, written as ``double`` in this order (names must be
        identifiers).
    comment : str, optional
        One header comment line.
    """
    n_faces = len(faces)
    for name, values in face_values.items():
        if not name.isidentifier() or np.shape(values) != (n_faces,):
            raise ValueError(
                f"face value {name!r} must be an identifier with ({n_faces},) values, "
                f"got shape {np.shape(values)}"
            )
    if n_faces and int(faces.max()) > np.iinfo(np.int32).max:
        raise ValueError(f"vertex indices must fit int32, got {int(faces.max())}")
    vertex_rows = np.ascontiguousarray(vertices, dtype="<f8")
    face_rows = np.empty(
        n_faces,
        dtype=[("n", "u1"), ("corners", "<i4", (3,))] + [(k, "<f8") for k in face_values],
    )
    face_rows["n"] = 3
    face_rows["corners"] = faces
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
    with atomic_path(path) as temporary, temporary.open("wb") as stream:
        stream.write(("\n".join(header) + "\n").encode("ascii"))
        stream.write(vertex_rows.tobytes())
        stream.write(face_rows.tobytes())
