"""Parts of a model joined into one :class:`shellvox.model._mesh.ColouredMesh`.

Every loader reads a file into parts (objects, primitives, face sets) with their own
vertices and a colour source each; :func:`stack_parts` joins their geometry and
:func:`corner_colour_mesh` picks face or vertex colour from per-corner colours, for all of
them. :func:`combine_parts` joins the parts of trimesh-read formats, glTF and VRML (one
:class:`shellvox.model._texture.Material` or per-corner colours per part); the 3MF reader, whose
parts index a shared table of materials, joins its own with the two helpers.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from shellvox.errors import InputError, warn
from shellvox.model import ColouredMesh, Material
from shellvox.voxel.colour import decode_uint8


def checked_faces(path: Path, n_vertices: int, faces: NDArray[np.int64]) -> NDArray[np.int64]:
    """Return ``faces (F, 3) int64`` if every index names one of ``n_vertices`` vertices.

    trimesh (``process=False``) keeps a file's indices as they are, so an index past the
    vertices, or a negative one (which numpy would silently count from the end), is
    refused here before any colour is gathered by it.
    """
    if len(faces) and (faces.min() < 0 or faces.max() >= n_vertices):
        raise InputError(path, "has a face with a vertex index out of range", "re-export the mesh")
    return faces


def stack_parts(
    parts: Sequence[dict[str, Any]],
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Return the vertices ``(V, 3) float64`` and faces ``(F, 3) int64`` of all parts.

    Each part's faces are shifted past the vertices of the parts before it.

    Examples
    --------
    >>> tri = {"vertices": np.eye(3), "faces": np.array([[0, 1, 2]])}
    >>> stack_parts([tri, tri])[1].tolist()
    [[0, 1, 2], [3, 4, 5]]
    """
    offsets = np.cumsum([0] + [len(p["vertices"]) for p in parts[:-1]])
    vertices = np.concatenate([p["vertices"] for p in parts]).astype(np.float64)
    faces = np.concatenate([p["faces"] + o for p, o in zip(parts, offsets, strict=True)])
    return vertices, faces.astype(np.int64)


def corner_colour_mesh(
    source: str, vertices: NDArray[np.float64], faces: NDArray[np.int64], rgba: NDArray[np.uint8]
) -> ColouredMesh:
    """Return a mesh coloured per face where every face's corners agree, else per vertex.

    Parameters
    ----------
    source : str
        The model file.
    vertices : (V, 3) float64
        Vertex positions.
    faces : (F, 3) int64
        Triangles.
    rgba : (F, 3, 4) uint8
        sRGB + alpha per face corner.
    """
    if (rgba == rgba[:, :1]).all():
        return ColouredMesh(vertices, faces, "face", face_rgba=rgba[:, 0].copy(), source=source)
    return ColouredMesh(vertices, faces, "vertex", corner_rgba=rgba, source=source)


def combine_parts(path: Path, parts: list[dict[str, Any]]) -> ColouredMesh:
    """Join parts; the richest colour source wins (texture > vertex > face > none).

    Parameters
    ----------
    path : Path
        The model file, for messages.
    parts : list of dict
        Each with ``vertices (V, 3) float64`` and ``faces (F, 3) int64``, and either
        ``material`` (a :class:`Material`) with ``uv (F, 3, 2) float64``, or ``rgba
        (F, 3, 4) uint8`` per corner, or neither (no colour).

    Returns
    -------
    ColouredMesh
        Not yet merged. Next to textured parts a part with one colour becomes a plain
        material; one with varying colours its mean colour, with a warning.
    """
    vertices, faces = stack_parts(parts)
    source = str(path)
    white = np.full((1, 3, 4), 255, np.uint8)
    if any("material" in p for p in parts):
        materials: list[Material] = []
        uv, index = [], []
        for p in parts:
            n = len(p["faces"])
            if "material" in p:
                uv.append(p["uv"])
                material = p["material"]
            else:
                rgba = p.get("rgba", white)
                if not (rgba == rgba.reshape(-1, 4)[0]).all():
                    warn(
                        f"{path}: a primitive's vertex or face colours are replaced "
                        "by its mean colour next to textured primitives",
                    )
                material = Material("plain", factor=decode_uint8(rgba).reshape(-1, 4).mean(0))
                uv.append(np.zeros((n, 3, 2)))
            index.append(np.full(n, len(materials), np.int64))
            materials.append(material)
        return ColouredMesh(
            vertices,
            faces,
            "texture",
            corner_uv=np.concatenate(uv),
            face_material=np.concatenate(index),
            materials=tuple(materials),
            source=source,
        )
    if any("rgba" in p for p in parts):
        rgba = np.concatenate([p.get("rgba", np.repeat(white, len(p["faces"]), 0)) for p in parts])
        return corner_colour_mesh(source, vertices, faces, rgba)
    return ColouredMesh(vertices, faces, "none", source=source)
