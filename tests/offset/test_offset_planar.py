"""One prism per flat patch (shellvox.offset.reference.planar): exact geometry, fallbacks, same
shells.

Truths: analytic areas of mitred polygon offsets and analytic box offsets; the per-face
prisms (the construction the patches replace) as the reference for the shells; trimesh
for closedness and volume.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

import shellvox.offset.reference.band as band
from shellvox.offset import offset_shells
from shellvox.offset.adjacency import edge_adjacency, face_normals
from shellvox.offset.crossing.intersections import intersecting_pairs
from shellvox.offset.reference.pieces import GROW_FRACTION, OUTSIDE_FRACTION
from shellvox.offset.reference.planar import coplanar_pairs, flat_patches, patch_prisms


def _grid(cells: set[tuple[int, int]]) -> tuple[np.ndarray, np.ndarray]:
    """Return a flat z = 0 mesh of unit squares (two triangles each), normal +z."""
    index: dict[tuple[int, int], int] = {}
    verts: list[tuple[float, float, float]] = []

    def vid(x: int, y: int) -> int:
        if (x, y) not in index:
            index[(x, y)] = len(verts)
            verts.append((float(x), float(y), 0.0))
        return index[(x, y)]

    faces = []
    for x, y in sorted(cells):
        a, b, c, d = vid(x, y), vid(x + 1, y), vid(x + 1, y + 1), vid(x, y + 1)
        faces += [(a, b, c), (a, c, d)]
    return np.array(verts), np.array(faces, dtype=np.int64)


def _one_patch(v, f, depth):
    normals, areas = face_normals(v, f)
    label = np.zeros(len(f), dtype=np.int64)
    return patch_prisms(v, f, normals, areas, label, 1, np.full(len(f), depth))


def test_l_shaped_patch_prism_is_the_mitred_outline_swept():
    # An L of three unit squares: 5 convex and 1 reflex right-angled corner.
    v, f = _grid({(0, 0), (1, 0), (0, 1)})
    depth = 0.7
    groups, covered = _one_patch(v, f, depth)
    assert covered.all() and len(groups) == 1
    pts, tris = groups[0]
    mesh = trimesh.Trimesh(pts[0], tris, process=False)
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
    assert len(intersecting_pairs(pts[0], tris)) == 0
    g = GROW_FRACTION * depth
    # Mitred offset of a rectilinear polygon: A + P g + (convex - reflex corners) g^2.
    area = 3.0 + 8.0 * g + (5 - 1) * g * g
    assert mesh.volume == pytest.approx(area * (1 + OUTSIDE_FRACTION) * depth, rel=1e-12)
    z = pts[0][:, 2]
    assert set(np.round(z, 12)) == {-depth, round(OUTSIDE_FRACTION * depth, 12)}


def test_patch_with_a_hole_is_a_ring():
    v, f = _grid({(x, y) for x in range(3) for y in range(3)} - {(1, 1)})
    groups, covered = _one_patch(v, f, 0.5)
    assert covered.all()
    mesh = trimesh.Trimesh(groups[0][0][0], groups[0][1], process=False)
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert mesh.euler_number == 0  # a solid ring (genus 1)
    g = GROW_FRACTION * 0.5
    # Outer square grows, the hole shrinks: A + P_out g + 4 g^2 + P_in g - 4 g^2.
    area = 8.0 + 12.0 * g + 4 * g * g + 4.0 * g - 4 * g * g
    assert mesh.volume == pytest.approx(area * (1 + OUTSIDE_FRACTION) * 0.5, rel=1e-12)


def test_outline_touching_itself_falls_back_to_face_prisms():
    # Two holes meeting at one corner: that vertex has two outgoing outline edges.
    v, f = _grid({(x, y) for x in range(4) for y in range(4)} - {(1, 1), (2, 2)})
    groups, covered = _one_patch(v, f, 0.5)
    assert groups == [] and not covered.any()


def test_slit_narrower_than_the_growth_falls_back():
    # Two arms on a bar, 1e-4 mm apart: grown by 1e-3 D = 5e-4 mm each, they would overlap.
    w = 1e-4
    xs = [0.0, 1.0, 1.0 + w, 2.0 + w]
    v = [(x, y, 0.0) for y in (-1.0, 0.0) for x in xs]  # bar: 0-3 bottom, 4-7 top
    v += [(0.0, 1.0, 0.0), (1.0, 1.0, 0.0), (1.0 + w, 1.0, 0.0), (2.0 + w, 1.0, 0.0)]
    quads = [(0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (4, 5, 9, 8), (6, 7, 11, 10)]
    f = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    groups, covered = _one_patch(np.array(v), f, 0.5)
    assert groups == [] and not covered.any()
    # Far enough apart, the same patch is one prism.
    v2 = np.array(v)
    v2[v2[:, 0] > 1.5, 0] += 0.5
    v2[np.isclose(v2[:, 0], 1.0 + w), 0] += 0.5
    groups, covered = _one_patch(v2, f, 0.5)
    assert len(groups) == 1 and covered.all()


def test_patches_follow_the_plane_and_the_depth():
    box = trimesh.creation.box((2.0, 3.0, 4.0)).subdivide()
    v, f = np.asarray(box.vertices), np.asarray(box.faces, dtype=np.int64)
    normals, _ = face_normals(v, f)
    adj = edge_adjacency(f)
    pairs = coplanar_pairs(normals, adj.face_left, adj.face_right)
    label, n = flat_patches(pairs, len(f), np.full(len(f), 0.5))
    assert n == 6  # one patch per side of the box
    side = np.round(normals).astype(int) @ np.array([1, 10, 100])
    assert len({(a, b) for a, b in zip(label, side, strict=True)}) == 6
    # Another depth on one face splits it off (it stays a single face: label -1).
    d = np.full(len(f), 0.5)
    d[0] = 0.6
    label, n = flat_patches(pairs, len(f), d)
    assert n == 6 and label[0] == -1


def _per_face_only(monkeypatch):
    monkeypatch.setattr(band, "flat_patches", lambda pairs, n_faces, d: (np.full(n_faces, -1), 0))


@pytest.mark.parametrize("thickness", [[0.5], [0.3, 0.6]])
def test_box_shells_are_the_analytic_boxes(thickness):
    size = np.array([10.0, 8.0, 6.0])
    box = trimesh.creation.box(size).subdivide().subdivide()
    shells = offset_shells(box.vertices, box.faces, thickness, method="robust")
    for shell, depth in zip(shells, np.cumsum(thickness), strict=True):
        mesh = trimesh.Trimesh(shell.vertices, shell.faces, process=False)
        assert mesh.is_watertight and mesh.is_winding_consistent
        assert mesh.volume == pytest.approx(np.prod(size - 2 * depth), rel=1e-9)
        assert len(intersecting_pairs(shell.vertices, shell.faces)) == 0


def test_patches_give_the_shells_of_the_face_prisms(monkeypatch):
    # A box with a notch (reflex edges, flat sides of several faces) and per-face depths
    # that make patches of equal depth next to single faces of another depth.
    notch = trimesh.creation.box((4.0, 4.0, 8.0))
    notch.apply_translation([3.0, 3.0, 0.0])
    solid = trimesh.creation.box((10.0, 10.0, 6.0)).difference(notch).subdivide()
    v, f = np.asarray(solid.vertices), np.asarray(solid.faces, dtype=np.int64)
    depth = np.where(np.arange(len(f)) % 7 == 0, 0.8, 0.5)
    merged = offset_shells(v, f, [depth], method="robust")
    _per_face_only(monkeypatch)
    reference = offset_shells(v, f, [depth], method="robust")
    for a, b in zip(merged, reference, strict=True):
        ma = trimesh.Trimesh(a.vertices, a.faces, process=False)
        mb = trimesh.Trimesh(b.vertices, b.faces, process=False)
        assert ma.is_watertight and ma.is_winding_consistent
        assert len(intersecting_pairs(a.vertices, a.faces)) == 0
        assert ma.volume == pytest.approx(mb.volume, rel=1e-9)
        # The per-face pieces also get a cap at vertices whose coplanar edges bend
        # inward by rounding (1e-16 rad) only; next to a deeper face such a cap reaches a
        # little under the shallower face (within 10 degrees of the normal). The patches
        # have none there: the area differs by that noise, well under 1e-5.
        assert ma.area == pytest.approx(mb.area, rel=1e-5)
        assert len(a.faces) <= len(b.faces)
