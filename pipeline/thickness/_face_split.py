"""Split faces so that per-face thickness can follow a texture (``--max-edge MM``).

A face's thickness comes from one robust colour, so a large face over very different
colours gets one compromise depth. :func:`split_faces` splits the edges longer than
``max_edge_mm`` of the chosen faces at their midpoints, again and again, until none is
left; :func:`split_for_thickness` chooses the faces whose colour spread is at least the
rule's ``split.min_spread_de00`` (faces of one colour gain nothing from splitting).

The split is conforming: a midpoint is one vertex shared by both faces of its edge, and a
face with 1, 2 or 3 split edges becomes 2, 3 (the shorter diagonal) or 4 faces with the
same orientation, so the mesh stays closed and oriented, and a neighbour of a chosen face
is split only along the shared edge. Every new corner is a point of its original face
with known barycentric coordinates, and the colour attributes are interpolated there the
way :meth:`ColouredMesh.colour_at` interpolates them (UVs linearly; vertex colours in
linear light): texture and face colours come out identical at the same surface points.
Vertex colours are re-quantised to ``uint8`` at new corners, so they may differ by one
sRGB step.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from shellvox.errors import InputError, opt
from shellvox.model import ColouredMesh
from shellvox.thickness._face_colour import FaceColour, face_colour
from shellvox.thickness._rule import ThicknessRule
from shellvox.voxel.colour import decode_uint8, encode_uint8

#: Barycentric coordinates of a face's corners and edge midpoints (local points 0..5;
#: midpoint 3 on edge 0-1, 4 on edge 1-2, 5 on edge 2-0).
LOCAL_POINTS = np.array(
    [[1, 0, 0], [0, 1, 0], [0, 0, 1], [0.5, 0.5, 0], [0, 0.5, 0.5], [0.5, 0, 0.5]],
    dtype=np.float64,
)
#: Children of a face, as local points, per case (after rotating the split edges first).
TEMPLATES = {
    "none": np.array([[0, 1, 2]]),
    "one": np.array([[0, 3, 2], [3, 1, 2]]),  # edge 0-1 split
    "two_04": np.array([[3, 1, 4], [0, 3, 4], [0, 4, 2]]),  # edges 0-1, 1-2; diagonal 0-4
    "two_32": np.array([[3, 1, 4], [0, 3, 2], [3, 4, 2]]),  # same, diagonal 3-2
    "three": np.array([[0, 3, 5], [3, 1, 4], [5, 4, 2], [3, 4, 5]]),
}


@dataclass(frozen=True, eq=False)
class SplitMesh:
    """A mesh after splitting, with where each new face came from.

    Attributes
    ----------
    mesh : ColouredMesh
        Closed and oriented like the input, colour attributes carried over.
    parent : (F', ) int64
        Input face of every new face.
    barycentric : (F', 3, 3) float64
        Corner ``c`` of new face ``f`` is ``barycentric[f, c] @ input_triangle[parent[f]]``.
    """

    mesh: ColouredMesh
    parent: NDArray[np.int64]
    barycentric: NDArray[np.float64]


def split_faces(
    mesh: ColouredMesh,
    max_edge_mm: float,
    *,
    where: NDArray[np.bool_] | None = None,
    max_faces: int = 5_000_000,
    max_rounds: int = 64,
) -> SplitMesh:
    """Split edges longer than ``max_edge_mm`` of the chosen faces until none is left.

    Parameters
    ----------
    mesh : ColouredMesh
        Closed, consistently oriented.
    max_edge_mm : float, mm
        Longest edge a chosen face may keep (``> 0``).
    where : (F,) bool, optional
        Faces to refine (default all). Their children are refined too; other faces are
        split only along edges they share with refined faces.
    max_faces : int, optional
        Refuse (InputError naming ``--max-edge``) to make more faces than this.
    max_rounds : int, optional
        Rounds of halving before giving up (never reached in practice: each round halves
        every long edge).

    Returns
    -------
    SplitMesh

    Examples
    --------
    >>> import trimesh
    >>> box = trimesh.creation.box((4.0, 4.0, 4.0))
    >>> mesh = ColouredMesh(np.asarray(box.vertices), np.asarray(box.faces, np.int64))
    >>> split = split_faces(mesh, 2.0)
    >>> len(split.mesh.faces)
    96
    >>> corners = split.mesh.triangles
    >>> float(np.linalg.norm(corners - np.roll(corners, -1, axis=1), axis=2).max())
    2.0
    """
    if not (np.isfinite(max_edge_mm) and max_edge_mm > 0):
        raise ValueError(f"max_edge_mm must be a positive length, got {max_edge_mm!r}")
    vertices = mesh.vertices
    faces = mesh.faces
    refine = np.ones(len(faces), bool) if where is None else np.asarray(where, bool).copy()
    if refine.shape != (len(faces),):
        raise ValueError(f"where must be ({len(faces)},) bool, got shape {refine.shape}")
    parent = np.arange(len(faces), dtype=np.int64)
    barycentric = np.broadcast_to(np.eye(3), (len(faces), 3, 3)).copy()
    for _ in range(max_rounds):  # loop over rounds of halving, not faces
        step = _split_round(vertices, faces, refine, max_edge_mm)
        if step is None:
            break
        vertices, faces, source, local = step
        if len(faces) > max_faces:
            raise InputError(
                opt("max_edge"),
                f"splitting to {max_edge_mm:g} mm edges makes more than {max_faces:,} faces",
                f"choose a larger {opt('max_edge')}",
            )
        refine = refine[source]
        barycentric = np.einsum("fpk,fkc->fpc", local, barycentric[source])
        parent = parent[source]
    else:
        raise RuntimeError(f"edges still longer than {max_edge_mm} mm after {max_rounds} rounds")
    return SplitMesh(_carry(mesh, vertices, faces, parent, barycentric), parent, barycentric)


def split_for_thickness(
    mesh: ColouredMesh,
    rule: ThicknessRule,
    max_edge_mm: float,
    *,
    colour: FaceColour | None = None,
    max_faces: int = 5_000_000,
) -> ColouredMesh:
    """Split the faces whose colour spread is at least ``rule.split.min_spread_de00``.

    Parameters
    ----------
    mesh : ColouredMesh
    rule : ThicknessRule
    max_edge_mm : float, mm
        ``--max-edge``.
    colour : FaceColour, optional
        Precomputed :func:`shellvox.thickness._face_colour.face_colour` of ``mesh``.
    max_faces : int, optional
        Face limit (see :func:`split_faces`).

    Returns
    -------
    ColouredMesh
    """
    if colour is None:
        colour = face_colour(mesh)
    chosen = colour.spread_de00 >= rule.split.min_spread_de00
    if not chosen.any():
        return mesh
    return split_faces(mesh, max_edge_mm, where=chosen, max_faces=max_faces).mesh


def _split_round(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    refine: NDArray[np.bool_],
    max_edge_mm: float,
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]] | None:
    """One round: split every long edge of a refined face; None when there is none.

    Returns the new vertices, faces, the source face of every new face and the new
    corners in the source face's barycentric coordinates ``(F', 3, 3)``.
    """
    n_faces = len(faces)
    start = faces
    end = np.roll(faces, -1, axis=1)  # edge j joins corner j and corner j + 1
    low, high = np.minimum(start, end), np.maximum(start, end)
    keys, first, edge_id = np.unique(
        (low * len(vertices) + high).reshape(-1), return_index=True, return_inverse=True
    )
    edge_id = edge_id.reshape(n_faces, 3)
    a, b = low.reshape(-1)[first], high.reshape(-1)[first]
    long = np.linalg.norm(vertices[b] - vertices[a], axis=1) > max_edge_mm
    chosen = np.zeros(len(keys), dtype=bool)
    chosen[edge_id[refine].reshape(-1)] = True
    split = chosen & long
    if not split.any():
        return None
    midpoint = np.full(len(keys), -1, dtype=np.int64)
    midpoint[split] = len(vertices) + np.arange(int(split.sum()))
    vertices = np.concatenate([vertices, 0.5 * (vertices[a[split]] + vertices[b[split]])])

    marked = split[edge_id]
    count = marked.sum(axis=1)
    # Rotate corners so that a single split edge is edge 0 and two split edges are 0 and 1.
    unmarked_first = np.argmin(marked, axis=1)  # the unsplit edge when two are split
    rotation = np.where(count == 1, np.argmax(marked, axis=1), 0)
    rotation = np.where(count == 2, (unmarked_first + 1) % 3, rotation)
    order = (np.arange(3)[None, :] + rotation[:, None]) % 3
    corners = np.take_along_axis(faces, order, axis=1)
    edges = np.take_along_axis(edge_id, order, axis=1)
    points = np.concatenate([corners, midpoint[edges]], axis=1)  # (F, 6) vertex ids
    local_rotated = np.eye(3)[order]  # (F, 3, 3): rotated corner c is source corner order[c]
    local_points = np.einsum("pk,fkc->fpc", LOCAL_POINTS, local_rotated)  # (F, 6, 3)

    two = count == 2
    diagonal_04 = np.linalg.norm(vertices[points[:, 0]] - vertices[points[:, 4]], axis=1)
    diagonal_32 = np.linalg.norm(vertices[points[:, 3]] - vertices[points[:, 2]], axis=1)
    cases = {
        "none": count == 0,
        "one": count == 1,
        "two_04": two & (diagonal_04 <= diagonal_32),
        "two_32": two & (diagonal_04 > diagonal_32),
        "three": count == 3,
    }
    new_faces, sources, locals_ = [], [], []
    for name, members in cases.items():  # loop over the five cases, not faces
        chosen_faces = np.flatnonzero(members)
        if not len(chosen_faces):
            continue
        template = TEMPLATES[name]
        new_faces.append(points[chosen_faces][:, template].reshape(-1, 3))
        locals_.append(local_points[chosen_faces][:, template].reshape(-1, 3, 3))
        sources.append(np.repeat(chosen_faces, len(template)))
    source = np.concatenate(sources)
    keep_order = np.argsort(source, kind="stable")  # children stay where their face was
    return (
        vertices,
        np.concatenate(new_faces)[keep_order],
        source[keep_order],
        np.concatenate(locals_)[keep_order],
    )


def _carry(
    mesh: ColouredMesh,
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    parent: NDArray[np.int64],
    barycentric: NDArray[np.float64],
) -> ColouredMesh:
    """Return the split mesh with colour attributes interpolated from the parent faces."""
    changes: dict[str, object] = {"vertices": vertices, "faces": faces}
    if mesh.corner_uv is not None:
        changes["corner_uv"] = np.einsum("fcp,fpk->fck", barycentric, mesh.corner_uv[parent])
    if mesh.corner_rgba is not None:
        linear = np.einsum("fcp,fpk->fck", barycentric, decode_uint8(mesh.corner_rgba[parent]))
        rgba = encode_uint8(linear)
        # Corners that are parent corners keep their exact value.
        at_corner = np.isclose(barycentric.max(axis=2), 1.0, rtol=0.0, atol=1e-12)
        which = np.argmax(barycentric, axis=2)
        original = mesh.corner_rgba[parent[:, None], which]
        changes["corner_rgba"] = np.where(at_corner[..., None], original, rgba)
    for name in ("face_rgba", "face_material"):
        value = getattr(mesh, name)
        if value is not None:
            changes[name] = value[parent]
    if mesh.solid is not None:  # a piece of a face crossing another may cross it too
        changes["solid"] = mesh.solid._replace(partly=mesh.solid.partly[parent])
    return dataclasses.replace(mesh, **changes)  # type: ignore[arg-type]
