"""The crease pass's splitting rounds stay within their budget, and the shells stay clean.

A part of many facets (a chain of dodecahedra, unioned) makes the crease pass split and
re-split most of its surface; its rounds visit at most ``WORK`` triangles per marched
triangle, counted at the splitting itself, and the shells the budget leaves, simplified
and checked by MeshLab (an independent reader), cross nothing.
"""

from __future__ import annotations

import manifold3d
import numpy as np
import pytest
import trimesh
from meshlab_process import needs_meshlab
from scipy.spatial.transform import Rotation

from shellvox.offset.field import creases
from shellvox.offset.methods import method_shells
from shellvox.testing import meshlab_crossing_faces

PHI = (1.0 + 5.0**0.5) / 2.0

#: The crease pass's own budget.
DEFAULT_WORK = creases.WORK


def _dodecahedron(radius_mm: float) -> trimesh.Trimesh:
    corners = [(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
    for a in (-1, 1):
        for b in (-1, 1):
            corners += [(0, a / PHI, b * PHI), (a / PHI, b * PHI, 0), (a * PHI, 0, b / PHI)]
    return trimesh.convex.convex_hull(np.array(corners, dtype=float) * radius_mm / np.sqrt(3))


def _chain(links: int) -> tuple[np.ndarray, np.ndarray]:
    """Dodecahedra 7 mm apart, each turned its own way, overlapping: one solid."""
    solid = None
    for i in range(links):
        turn = Rotation.from_euler("xyz", (13 * i, 29 * i, 41 * i), degrees=True).as_matrix()
        link = _dodecahedron(8.7)
        points = np.asarray(link.vertices) @ turn.T + (7.0 * i, 0.3 * i, 0.1)
        piece = manifold3d.Manifold(
            manifold3d.Mesh(
                vert_properties=points.astype(np.float32),
                tri_verts=np.asarray(link.faces, dtype=np.uint32),
            )
        )
        solid = piece if solid is None else solid + piece
    assert solid is not None
    out = solid.to_mesh()
    turn = Rotation.from_euler("xyz", (17.0, -33.0, 51.0), degrees=True).as_matrix()
    vertices = np.asarray(out.vert_properties, dtype=np.float64)[:, :3] @ turn.T
    return vertices + np.array([0.1, 0.2, 0.3]), np.asarray(out.tri_verts, dtype=np.int64)


@pytest.mark.slow
@needs_meshlab
@pytest.mark.parametrize("work", [DEFAULT_WORK, 1.0])
def test_the_splitting_rounds_stay_within_their_budget_and_the_shells_cross_nothing(
    monkeypatch, work
):
    # 1.0 is under what the chain's rounds visit unbounded (2.3 per marched triangle):
    # the budget binds, the passes stop, and what they made goes through the checks or
    # the surface stays as marched.
    vertices, faces = _chain(4)
    visits = []
    split = creases.split_triangles

    def counted(tri, *args):
        visits.append(len(tri))
        return split(tri, *args)

    monkeypatch.setattr(creases, "WORK", work)
    monkeypatch.setattr(creases, "MIN_WORK", 0)  # the chain is small: its share binds
    monkeypatch.setattr(creases, "split_triangles", counted)
    made = method_shells(vertices, faces, [0.5], method="field", step_mm=0.2)
    (marched,) = made.record["marched_faces"]
    assert 0 < sum(visits) <= work * marched
    if work == DEFAULT_WORK:  # unbound here: the creases are put back
        assert made.record["crease_points"][0] > 0
    for shell in made.shells:
        mesh = trimesh.Trimesh(shell.vertices, shell.faces, process=False)
        assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
        assert meshlab_crossing_faces(shell.vertices, shell.faces) == 0
