"""The solid of a mesh as it comes: its inside by the winding number, its visible faces.

A mesh that is not one closed, consistently oriented surface (a scan with holes, a
character of parts pushed into each other, duplicated or flipped faces) still has an
inside: where the generalised winding number of its faces is at least 1/2 (Jacobson,
Kavan and Sorkine-Hornung 2013). :func:`solid_model` makes it printable as it is:

1. faces are turned to agree with their neighbours, patch by patch (libigl's
   ``bfs_orient``), and a patch whose own winding number is negative (inside out) is
   turned over;
2. the faces between the solid and the outside are kept as the model's surface (they
   decide the layers and the colour), the others (buried in the solid, or outside it)
   are left out (:func:`shellvox.voxel.geometry.visible_faces`); a face that crosses
   another (:func:`shellvox.offset.crossing.intersecting_pairs`) is kept as visible in
   part, and a voxel whose nearest point lies on its buried piece measures its depth to
   the outside instead (:mod:`shellvox.voxel.slab`);
3. the whole oriented soup is kept as the mesh's :class:`~shellvox.model.Solid`, whose
   winding number decides the inside of every voxel.

What cannot be built, a soup that encloses nothing (a sheet, points), is refused.
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from shellvox.errors import InputError
from shellvox.model._mesh import ColouredMesh, Solid
from shellvox.model._topology import (
    CORNER_FIELDS,
    edge_report,
    face_areas,
    face_parts,
    select_faces,
)


class SolidReport(NamedTuple):
    """What :func:`solid_model` did, for the user and the manifest.

    Attributes
    ----------
    boundary_edges : int
        Edges of one face (holes, closed by the winding number).
    non_manifold_edges : int
        Edges of more than two faces.
    patches : int
        Patches of faces that agree in orientation.
    turned_faces : int
        Faces turned to agree with their neighbours.
    turned_patches : int
        Patches turned outside out (their winding number was negative).
    hidden_faces : int
        Faces left out of the surface: buried in the solid, or outside it.
    """

    boundary_edges: int
    non_manifold_edges: int
    patches: int
    turned_faces: int
    turned_patches: int
    hidden_faces: int

    def line(self) -> str:
        """One line saying what was done."""
        done = []
        if self.boundary_edges:
            done.append(f"holes closed by the winding number across {self.boundary_edges} edges")
        if self.non_manifold_edges:
            done.append(f"{self.non_manifold_edges} non-manifold edges read as they are")
        if self.turned_faces:
            done.append(f"{self.turned_faces} faces turned to agree with their neighbours")
        if self.turned_patches:
            done.append(f"{self.turned_patches} parts turned outside out")
        if self.hidden_faces:
            done.append(f"{self.hidden_faces} buried or stray faces ignored")
        return "; ".join(done) or "closed and oriented"


def needs_solid(mesh: ColouredMesh) -> bool:
    """Whether the mesh is not one closed, consistently oriented surface of one part."""
    if not edge_report(mesh.faces).oriented:
        return True
    return face_parts(mesh.faces)[0] > 1


def solid_model(mesh: ColouredMesh) -> tuple[ColouredMesh, SolidReport]:
    """Return the mesh's visible faces with its oriented soup as its solid.

    Parameters
    ----------
    mesh : ColouredMesh
        Vertices merged by position, no zero-area faces; open, non-manifold, overlapping
        or inconsistently oriented.

    Returns
    -------
    mesh : ColouredMesh
        Its visible faces (counter-clockwise seen from outside), with ``solid`` set; the
        mesh itself where it is one closed oriented surface whose faces are all visible.
    report : SolidReport

    Raises
    ------
    InputError
        The faces enclose nothing (a sheet, or points).
    """
    import igl

    from shellvox.offset.crossing.intersections import intersecting_pairs
    from shellvox.voxel.geometry import soup_solid, visible_faces

    report = edge_report(mesh.faces)
    oriented, patch = igl.bfs_orient(mesh.faces)
    rotations = [mesh.faces[:, order] for order in ([0, 1, 2], [1, 2, 0], [2, 0, 1])]
    kept = np.any([np.all(oriented == r, axis=1) for r in rotations], axis=0)
    turned = ~kept
    patch = np.asarray(patch, dtype=np.int64).reshape(-1)
    n_patches = int(patch.max()) + 1 if len(patch) else 0
    faces = np.where(turned[:, None], mesh.faces[:, ::-1], mesh.faces)
    # a patch whose own winding number is negative on its faces' two sides is inside out
    sign = _patch_signs(mesh.vertices, faces, patch, n_patches)
    inside_out = sign[patch] < 0
    flipped = turned ^ inside_out
    faces = np.where(inside_out[:, None], faces[:, ::-1], faces)
    changes: dict[str, object] = {"faces": faces}
    for name in CORNER_FIELDS:
        value = getattr(mesh, name)
        if value is not None:
            changes[name] = np.where(flipped[:, None, None], value[:, ::-1], value)
    oriented_mesh = dataclasses.replace(mesh, **changes)  # type: ignore[arg-type]
    closed = edge_report(oriented_mesh.faces).oriented
    solid = soup_solid(oriented_mesh.vertices, oriented_mesh.faces)
    visible, partly = visible_faces(solid)
    # a face crossing another is visible in part at most; its samples may all be buried
    crossing = np.zeros(len(faces), dtype=bool)
    crossing[intersecting_pairs(oriented_mesh.vertices, oriented_mesh.faces).reshape(-1)] = True
    visible |= crossing
    partly |= crossing
    extent = float(np.ptp(mesh.vertices, axis=0).max())
    area = face_areas(mesh.vertices, faces)
    if not visible.any() or area[visible].sum() <= (extent * 1e-6) ** 2:
        raise InputError(
            mesh.source,
            "encloses no volume: its faces are a sheet or points (the winding number is "
            "nowhere 1/2 on one side of a face and not on the other)",
            "export a solid model",
        )
    if closed and visible.all() and not partly.any() and not flipped.any():
        shown = mesh  # one closed oriented surface, every face of it visible
    else:
        solid_faces = Solid(oriented_mesh.vertices, oriented_mesh.faces, closed, partly[visible])
        shown = dataclasses.replace(select_faces(oriented_mesh, visible), solid=solid_faces)
    return shown, SolidReport(
        boundary_edges=len(report.boundary),
        non_manifold_edges=len(report.non_manifold),
        patches=n_patches,
        turned_faces=int(turned.sum()),
        turned_patches=int(np.unique(patch[inside_out]).size),
        hidden_faces=int((~visible).sum()),
    )


def _patch_signs(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    patch: NDArray[np.int64],
    n_patches: int,
) -> NDArray[np.float64]:
    """Return, per patch, the area-weighted sum of its own winding number either side of it.

    About +1 per unit area for a patch facing outward (1 inside, 0 outside), -1 for one
    inside out; an open patch's values are fractional but keep the sign.
    """
    from shellvox.voxel.geometry import WindingTree

    corners = vertices[faces]
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    area = 0.5 * np.linalg.norm(normal, axis=1)
    unit = normal / np.maximum(2 * area, 1e-300)[:, None]
    centroid = corners.mean(axis=1)
    side = 1e-5 * float(np.linalg.norm(np.ptp(vertices, axis=0)))
    signs = np.zeros(n_patches)
    order = np.argsort(patch, kind="stable")
    bounds = np.searchsorted(patch[order], np.arange(n_patches + 1))
    for k in range(n_patches):  # a loop over patches (parts), not faces
        mine = order[bounds[k] : bounds[k + 1]]
        tree = WindingTree.build(vertices, faces[mine])
        step = side * unit[mine]
        points = np.concatenate([centroid[mine] + step, centroid[mine] - step])
        winding = tree.evaluate(points).reshape(2, -1).sum(axis=0)
        signs[k] = float(np.sum(area[mine] * winding))
    return signs
