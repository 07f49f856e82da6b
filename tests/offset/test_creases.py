"""Field shells keep the creases and corners of the offset: exact on convex polyhedra.

The inward offset of a convex polyhedron by ``D`` is the polyhedron of its faces' planes
moved in by ``D``; a point inside lies at ``min over faces (level - n . x)`` from the
surface. Every test measures against that analytic distance (or the analytic volume),
not against the project's own distance code.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from shellvox.offset.crossing.intersections import intersecting_pairs
from shellvox.offset.field.layer_field import field_surfaces

#: A rotation that puts no face or crease along the grid.
TURN = Rotation.from_euler("xyz", (17.0, -33.0, 51.0), degrees=True).as_matrix()


def _convex(points: np.ndarray) -> trimesh.Trimesh:
    hull = trimesh.convex.convex_hull(points @ TURN.T + (0.1, 0.2, 0.3))
    assert hull.is_watertight and hull.is_winding_consistent and hull.volume > 0
    return hull


def _planes(hull: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
    """Unit outward normals and levels (``n . x <= level`` inside) of a hull's faces."""
    normals = np.asarray(hull.face_normals)
    return normals, np.einsum("ij,ij->i", normals, hull.vertices[hull.faces[:, 0]])


def _analytic_distance(hull: trimesh.Trimesh, points: np.ndarray) -> np.ndarray:
    """Distance from points inside a convex polyhedron to its surface."""
    normals, levels = _planes(hull)
    return np.min(levels[None, :] - points @ normals.T, axis=1)


def _shell_points(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    assert mesh.is_watertight and mesh.is_winding_consistent
    samples, _ = trimesh.sample.sample_surface(mesh, 50_000, seed=3)
    return np.concatenate([samples, vertices])


def _crossings(vertices: np.ndarray, faces: np.ndarray) -> int:
    """Crossing pairs, but for those with a sliver the grid leaves around a node or edge
    that lies exactly on the surface (under a micrometre high; the simplification
    removes them)."""
    pairs = intersecting_pairs(vertices, faces)
    tri = vertices[faces]
    doubled = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    longest = np.linalg.norm(tri - tri[:, [1, 2, 0]], axis=2).max(axis=1)
    thin = doubled / longest < 1e-6
    return int((~thin[pairs]).all(axis=1).sum())


TETRAHEDRON = np.array([[0.0, 0, 0], [6, 0, 0], [0, 6, 0], [0, 0, 6]])
#: A rhombicuboctahedron: the permutations of (+-1, +-1, +-(1 + sqrt 2)), 2.5 mm a side.
RHOMBI = (
    np.array(
        [
            np.roll(np.array((sx, sy, sz * (1 + np.sqrt(2)))), r)
            for sx in (-1, 1)
            for sy in (-1, 1)
            for sz in (-1, 1)
            for r in range(3)
        ]
    )
    * 1.25
)


def test_axis_aligned_polyhedra_shells_are_exact_at_their_creases_and_corners():
    # A corner of a cube cut off by a slanted plane: creases of 90 and 125 degrees and
    # four corners; three of its offset planes run through nodes of the grid.
    hull = trimesh.convex.convex_hull(TETRAHEDRON)
    v0, f0 = np.asarray(hull.vertices), np.asarray(hull.faces, dtype=np.int64)
    depths = (0.5, 1.0)
    depth = np.array([np.full(len(f0), d) for d in depths])
    sharp = field_surfaces(v0, f0, depth, 0.1)
    chamfered = field_surfaces(v0, f0, depth, 0.1, sharpen=False)
    for k, d in enumerate(depths):
        error = np.abs(_analytic_distance(hull, _shell_points(*sharp.surfaces[k])) - d)
        # exact but for vertices held EDGE_MARGIN of an edge off a node (1.7e-7 mm)
        assert error.max() <= 2e-7
        # Without the creases the grid cuts them off by a good share of a step.
        before = np.abs(_analytic_distance(hull, _shell_points(*chamfered.surfaces[k])) - d)
        assert before.max() > 0.02
        assert sharp.crease_points[k] > 0 and chamfered.crease_points[k] == 0
    (v1, f1), (v2, f2) = sharp.surfaces
    assert _crossings(np.concatenate([v1, v2]), np.concatenate([f1, f2 + len(v1)])) == 0


@pytest.mark.parametrize(
    "corners", [TETRAHEDRON, RHOMBI], ids=["tetrahedron", "rhombicuboctahedron"]
)
def test_turned_polyhedra_shells_keep_most_of_their_creases(corners):
    # Turned off the grid, a crease point is dropped where its triangles would turn
    # over (sharp creases whose line runs outside the chamfer's triangles): most of the
    # surface is exact, and nowhere is the error larger than a step.
    hull = _convex(corners)
    v0, f0 = np.asarray(hull.vertices), np.asarray(hull.faces, dtype=np.int64)
    depths = (0.5, 1.0)
    depth = np.array([np.full(len(f0), d) for d in depths])
    sharp = field_surfaces(v0, f0, depth, 0.1)
    chamfered = field_surfaces(v0, f0, depth, 0.1, sharpen=False)
    for k, d in enumerate(depths):
        after = np.abs(_analytic_distance(hull, _shell_points(*sharp.surfaces[k])) - d)
        before = np.abs(_analytic_distance(hull, _shell_points(*chamfered.surfaces[k])) - d)
        assert np.percentile(after, 99) < 0.5 * np.percentile(before, 99)
        assert np.percentile(after, 99) <= 0.01 * d
        assert after.max() <= 0.1
        assert np.median(after) <= 1e-9
    (v1, f1), (v2, f2) = sharp.surfaces
    assert _crossings(np.concatenate([v1, v2]), np.concatenate([f1, f2 + len(v1)])) == 0


def test_the_shell_of_a_tetrahedron_is_the_smaller_tetrahedron():
    hull = trimesh.convex.convex_hull(TETRAHEDRON)
    v0, f0 = np.asarray(hull.vertices), np.asarray(hull.faces, dtype=np.int64)
    ((v, f),) = field_surfaces(v0, f0, np.full((1, 4), 0.5), 0.1).surfaces
    # The offset is a tetrahedron scaled about the incentre by (r - D) / r.
    normals, levels = _planes(hull)
    r = 3 * hull.volume / hull.area
    centre = np.linalg.lstsq(normals, levels - r, rcond=None)[0]
    inner = (v0 - centre) * (r - 0.5) / r + centre
    shell = trimesh.Trimesh(v, f, process=False)
    # within the 1.7e-7 mm of the vertices held EDGE_MARGIN off the nodes on the surface
    assert shell.volume == pytest.approx(hull.volume * ((r - 0.5) / r) ** 3, rel=1e-6)
    # Its four corners are vertices of the shell.
    nearest = np.min(np.linalg.norm(v[None, :, :] - inner[:, None, :], axis=2), axis=1)
    assert nearest.max() <= 2e-7  # one corner is a node: held EDGE_MARGIN off it


def test_a_concave_crease_stays_round():
    # An L-shaped prism: its reflex edge's offset is a cylinder of radius D, which the
    # crease points leave alone (the planes' line lies outside the layer).
    from shapely.geometry import Polygon

    outline = np.array([[0.0, 0], [4, 0], [4, 2], [2, 2], [2, 4], [0, 4]])
    prism = trimesh.creation.extrude_polygon(Polygon(outline), 3.0)
    turn = np.vstack([np.column_stack([TURN, (0.1, 0.2, 0.3)]), [0, 0, 0, 1]])
    prism.apply_transform(turn)
    v0, f0 = np.asarray(prism.vertices), np.asarray(prism.faces, dtype=np.int64)
    depth = 0.5
    out = field_surfaces(v0, f0, np.full((1, len(f0)), depth), 0.1)
    ((v, f),) = out.surfaces
    points = _shell_points(v, f)
    error = np.abs(trimesh.proximity.ProximityQuery(prism).signed_distance(points)) - depth
    # Chords of the cylinder sag by at most (sqrt(3) step)^2 / (8 D), inward (the shell
    # nearer to the surface); away from the prism's ends, where the cylinder meets the
    # end faces' planes (a crease of a curved piece, chamfered), that is all.
    local = (np.linalg.inv(turn) @ np.column_stack([points, np.ones(len(points))]).T).T
    middle = (local[:, 2] > 1.0) & (local[:, 2] < 2.0)
    sag = 3 * 0.1**2 / (8 * depth)
    assert error[middle].max() <= 1e-6
    assert error[middle].min() >= -sag
    assert np.percentile(np.abs(error), 99) <= 0.01 * depth
    assert out.crease_points[0] > 0  # the convex creases are sharpened


def _fans_by_faces(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Fans at every vertex from trimesh's face adjacency (triangles at a vertex joined
    across the edges at it), counted with SciPy's connected components."""
    import scipy.sparse
    import scipy.sparse.csgraph

    faces = np.asarray(faces)
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    pairs = mesh.face_adjacency
    edges = mesh.face_adjacency_edges
    # a node per triangle corner (3 t + i); faces adjacent across an edge join at both ends
    rows, cols = [], []
    for end in (0, 1):
        v = edges[:, end][:, None]
        rows.append(3 * pairs[:, 0] + np.argmax(faces[pairs[:, 0]] == v, axis=1))
        cols.append(3 * pairs[:, 1] + np.argmax(faces[pairs[:, 1]] == v, axis=1))
    rows, cols = np.concatenate(rows), np.concatenate(cols)
    n = 3 * len(faces)
    graph = scipy.sparse.coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    _, label = scipy.sparse.csgraph.connected_components(graph, directed=False)
    node_vertex = np.asarray(faces).ravel()
    pairs_vl = np.unique(np.column_stack([node_vertex, label]), axis=0)
    return np.bincount(pairs_vl[:, 0], minlength=len(vertices))


def test_fans_count_the_cycles_of_triangles_at_every_vertex():
    from shellvox.offset.field.patch_topology import fans, twins

    def count(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
        faces = np.asarray(faces, dtype=np.int64)
        twin = twins(faces, len(vertices), np.zeros(len(faces), dtype=np.int64))
        return fans(faces, twin, len(vertices))

    sphere = trimesh.creation.icosphere(2)
    assert (count(sphere.vertices, sphere.faces) == 1).all()
    # two cubes touching at one corner: that corner has two fans
    box = trimesh.creation.box()
    vertices = np.concatenate([box.vertices, box.vertices[1:] + 1.0])
    shared = int(np.flatnonzero((box.vertices == 0.5).all(axis=1))[0])
    second = np.concatenate([[-1], np.arange(8, 15)])
    other = int(np.flatnonzero((box.vertices == -0.5).all(axis=1))[0])
    second[other] = shared
    remap = np.where(np.arange(8) == other, shared, second)
    faces = np.concatenate([box.faces, remap[box.faces]])
    got = count(vertices, faces)
    assert got[shared] == 2 and (np.delete(got, shared) == 1).all()
    np.testing.assert_array_equal(got, _fans_by_faces(vertices, faces))
    # an open hemisphere: one fan at every used vertex, open at the rim
    upper = sphere.faces[sphere.triangles_center[:, 2] > 0]
    used = np.zeros(len(sphere.vertices), dtype=bool)
    used[upper] = True
    got = count(sphere.vertices, upper)
    assert (got[used] == 1).all() and (got[~used] == 0).all()


def test_sharpened_surfaces_of_a_detailed_part_stay_two_manifold(shared_mesh):
    """The airplane at 100 mm, 1.5 mm in: the crease points that join coincident points
    left six vertices with two fans each; Manifold splits those into pinches that no
    simplification removes."""
    raw = trimesh.load(shared_mesh("airplane/colored_airplane.ply"), force="mesh")
    mesh = trimesh.Trimesh(raw.vertices, raw.faces, process=True)
    mesh.merge_vertices(merge_tex=True, merge_norm=True)
    mesh.apply_scale(100.0 / mesh.extents.max())
    depth = np.full((1, len(mesh.faces)), 1.5)
    out = field_surfaces(mesh.vertices, mesh.faces, depth, 0.1, merge_planar=False)
    assert out.crease_points[0] > 1000
    vertices, faces = out.surfaces[0]
    shell = trimesh.Trimesh(vertices, faces, process=False)
    assert shell.is_watertight and shell.is_winding_consistent
    used = np.unique(faces)
    assert len(np.unique(vertices[used], axis=0)) == len(used)  # no two at one position
    fans = _fans_by_faces(vertices, faces)
    assert (fans[used] == 1).all(), f"{int((fans > 1).sum())} vertices with several fans"


def test_layers_of_several_depths_cross_nothing(shared_mesh):
    """Faces at three depths in random order (a build's colours): the field jumps where
    the nearest face changes depth. Exact roots next to those jumps folded triangles
    across them (3,794 crossing pairs on spot at 30 mm), and so did creases between planes
    of two depths; those edges keep the linear share, and such layers their chamfers."""
    raw = trimesh.load(shared_mesh("spot/spot_triangulated.obj"), force="mesh")
    mesh = trimesh.Trimesh(raw.vertices, raw.faces, process=True)
    mesh.merge_vertices(merge_tex=True, merge_norm=True)
    mesh.apply_scale(30.0 / mesh.extents.max())
    first = np.random.default_rng(0).choice([0.3, 0.5, 0.8], len(mesh.faces))
    out = field_surfaces(mesh.vertices, mesh.faces, np.array([first, first + 0.4]), 0.1)
    (v1, f1), (v2, f2) = out.surfaces
    assert _crossings(np.concatenate([v1, v2]), np.concatenate([f1, f2 + len(v1)])) == 0
    for v, f in out.surfaces:
        shell = trimesh.Trimesh(v, f, process=False)
        assert shell.is_watertight and shell.is_winding_consistent
