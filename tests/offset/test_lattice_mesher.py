"""Field shells meshed from a build's voxels: the slabs' nodes, marched in z order.

Independent routes: the voxels of slabs computed without nodes (the nodes must not change
them), a scan of the node grid itself fed to :class:`FieldMesher` (the same surfaces), and
the analytic offset of a box's faces.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from shellvox.offset.field.layer_field import FieldMesher, LatticeMesher
from shellvox.voxel.geometry import SurfaceIndex, inside_slab, nearest_in_reach, node_lattice
from shellvox.voxel.grid import GridSpec
from shellvox.voxel.slab import StackModel, compute_slab


def _model(mesh: trimesh.Trimesh, depth: np.ndarray, lattice=None) -> StackModel:
    faces = mesh.faces.astype(np.int64)
    rgba = np.full((len(faces), 4), 255, np.uint8)
    return StackModel(
        ((mesh.vertices, faces),),
        SurfaceIndex.build(mesh.vertices, faces),
        lambda face_ids, barycentric: rgba[face_ids],
        colour_layers=(1, 2),
        sdf_half_width_mm=0.2,
        depth_mm=depth,
        layer_rule="distance",
        field_nodes=lattice,
    )


def _slabs(model: StackModel, grid: GridSpec, rows: int):
    n_z = grid.shape_zyx[0]
    return [compute_slab(model, grid, z, min(n_z, z + rows)) for z in range(0, n_z, rows)]


@pytest.fixture(scope="module")
def ball():
    mesh = trimesh.creation.icosphere(subdivisions=2, radius=3.0)
    rng = np.random.default_rng(7)
    first = rng.uniform(0.3, 0.6, len(mesh.faces))
    depth = np.stack([first, first + rng.uniform(0.3, 0.5, len(mesh.faces))])
    grid = GridSpec.from_bounds(mesh.bounds[0], mesh.bounds[1], (0.05, 0.08, 0.04), margin_mm=0.1)
    return mesh, depth, grid, node_lattice(grid, 0.1)


def test_nodes_leave_the_voxels_as_they_are(ball):
    mesh, depth, grid, lattice = ball
    plain = _slabs(_model(mesh, depth), grid, 7)
    kept = _slabs(_model(mesh, depth, lattice), grid, 7)
    for a, b in zip(plain, kept, strict=True):
        assert a.nodes is None and b.nodes is not None
        for name in ("layers", "rgba", "sdf", "sdf_band", "layer_counts"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


def _surfaces_from_slabs(mesh, depth, grid, lattice, rows, merge_planar=True):
    mesher = LatticeMesher(mesh.vertices, mesh.faces, depth, grid, lattice)
    for slab in _slabs(_model(mesh, depth, lattice), grid, rows):
        mesher.add_nodes(slab.nodes)
    return mesher.surfaces(merge_planar=merge_planar, sharpen=merge_planar)


def test_slab_nodes_mesh_as_a_scan_of_the_node_grid(ball):
    mesh, depth, grid, lattice = ball
    assert lattice.stride_zyx == (2, 1, 2)
    made = [_surfaces_from_slabs(mesh, depth, grid, lattice, rows, False) for rows in (5, 16)]
    # The same nodes scanned as a grid of their own, by the field shells' own route.
    node_grid = made[0].grid
    v, f = mesh.vertices, mesh.faces.astype(np.int64)
    own = FieldMesher(v, f, depth, node_grid)
    inside, _ = inside_slab(v, f, node_grid, 0, node_grid.shape_zyx[0])
    near = nearest_in_reach(v, f, node_grid, 0, node_grid.shape_zyx[0], own.reach_mm, inside, 0.0)
    own.add(inside, near.squared_mm2, near.face)
    # as marched (the patches' CDT and the creases' choices are float)
    expected = own.surfaces(merge_planar=False, sharpen=False)
    assert not inside[[0, -1]].any() and not inside[:, [0, -1]].any()
    # (node positions differ in the last bit: origin + i * stride * voxel vs i * step)
    for surfaces in made:
        assert surfaces.marched_faces == expected.marched_faces
        for (va, fa), (vb, fb) in zip(surfaces.surfaces, expected.surfaces, strict=True):
            np.testing.assert_allclose(va, vb, rtol=0, atol=1e-12)
            np.testing.assert_array_equal(fa, fb)
    for v_k, f_k in _surfaces_from_slabs(mesh, depth, grid, lattice, 5).surfaces:
        assert trimesh.Trimesh(v_k, f_k, process=False).is_watertight


def test_box_shells_lie_at_their_faces_depths():
    # A box with another depth per side, on anisotropic voxels: away from where the
    # nearest side changes, each shell vertex lies at its nearest side's depth exactly
    # (the layer field is linear there), from the box's own planes.
    box = trimesh.creation.box(extents=(6.0, 5.0, 4.0))
    normals = box.face_normals
    side = np.argmax(np.abs(normals), axis=1) * 2 + (normals.max(axis=1) > 0.5)
    side_depth = np.array([0.4, 0.5, 0.6, 0.7, 0.45, 0.55])
    depth = np.stack([side_depth[side], side_depth[side] + 0.5])
    grid = GridSpec.from_bounds(
        box.bounds[0], box.bounds[1], (0.0423, 0.0846, 0.027), margin_mm=0.05
    )
    surfaces = _surfaces_from_slabs(box, depth, grid, node_lattice(grid, 0.1), 24)
    half = box.extents / 2
    step = max(surfaces.grid.voxel_mm)
    for k, (v, f) in enumerate(surfaces.surfaces):
        shell = trimesh.Trimesh(v, f, process=False)
        assert shell.is_watertight and shell.volume > 0
        # distance to each side, in the order x-, x+, y-, y+, z-, z+
        to_side = np.stack([v + half, half - v], axis=2).reshape(len(v), 6)
        order = np.argsort(to_side, axis=1)
        d = np.take_along_axis(to_side, order[:, :1], axis=1)[:, 0]
        second = np.take_along_axis(to_side, order[:, 1:2], axis=1)[:, 0]
        clear = second - d > 2 * step  # the nearest side is the same around the vertex
        assert clear.sum() > 100, clear.sum()
        wanted = side_depth[order[clear, 0]] + 0.5 * k
        np.testing.assert_allclose(d[clear], wanted, rtol=0, atol=1e-9)
