"""The streamed VDB writer against grids OpenVDB builds in memory from the same arrays.

The reference is OpenVDB's own ``copyFromArray`` (plus ``signedFloodFill`` for the level
set) and ``openvdb.write``; both files are read back with OpenVDB's reader and compared
voxel for voxel: values (active and inactive), active states and active counts. OpenVDB
runs in Debian's python3, in its own process (:mod:`shellvox.testing`).
"""

from __future__ import annotations

import numpy as np
import pytest

from shellvox.testing import describe_grids, read_grid_metadata, read_vdb, write_grids
from shellvox.voxel.colour import codes_to_linear
from shellvox.voxel.grid import GridSpec
from shellvox.voxel.io.vdb import GRID_NAMES, MATERIAL_GRID, VdbStackWriter

# 150 voxels in x: two 128^3 internal nodes; y and the last leaf row are partial.
GRID = GridSpec((-1.0, 2.0, 0.5), (0.05, 0.08, 0.03), (45, 37, 150))
HALF_WIDTH = 0.12


def _volumes() -> tuple[np.ndarray, ...]:
    """An ellipsoid in three layers, colour in layer 1, a level set band at its surface."""
    z, y, x = np.indices(GRID.shape_zyx, dtype=np.float64)
    r = np.sqrt(((x - 75) / 70) ** 2 + ((y - 18) / 17) ** 2 + ((z - 22) / 21) ** 2)
    layers = np.select([r < 0.45, r < 0.7, r < 1.0], [3, 2, 1], 0).astype(np.uint8)
    rng = np.random.default_rng(7)
    rgb = rng.integers(0, 256, (*GRID.shape_zyx, 3)).astype(np.uint8)
    rgb[:, :, :40] = (0, 0, 0)  # black colour voxels stay active
    rgb[layers != 1] = 0
    coloured = layers == 1
    sdf = np.where(np.abs(r - 1.0) < 0.1, (r - 1.0), HALF_WIDTH).astype(np.float32)
    return layers, rgb, coloured, sdf


def _reference(path, layers, rgb, coloured, sdf, materials=None):
    """Write the grids OpenVDB builds itself from the arrays; return them as read back."""
    xyz = (2, 1, 0)
    linear = codes_to_linear(rgb)
    linear[coloured] = np.maximum(linear[coloured], np.float32(1e-7))
    grids = [
        {"name": "density", "array": (layers > 0).transpose(xyz), "background": 0.0},
        {"name": "layer", "array": layers.transpose(xyz), "background": 0.0},
        {"name": "color", "array": linear.transpose(2, 1, 0, 3), "background": [0.0] * 3},
        {"name": "sdf", "array": sdf.transpose(xyz), "background": HALF_WIDTH, "level_set": True},
    ]
    if materials is not None:
        grids.append({"name": MATERIAL_GRID, "array": materials.transpose(xyz), "background": 0.0})
    write_grids(path, grids)
    return read_vdb(path, dense_xyz=GRID.shape_zyx[::-1])


@pytest.mark.parametrize("rows", [13, 8, 45])
def test_streamed_grids_equal_openvdbs_own(tmp_path, rows):
    layers, rgb, coloured, sdf = _volumes()
    writer = VdbStackWriter(GRID, sdf_half_width_mm=HALF_WIDTH, spool_dir=tmp_path)
    for start in range(0, GRID.shape_zyx[0], rows):
        part = slice(start, start + rows)
        writer.write_slab(start, layers[part], rgb[part], coloured[part], sdf[part])
    summary = writer.write(tmp_path / "v.vdb", {"creator": "test"})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["v.vdb"]  # spools removed
    grids = read_vdb(tmp_path / "v.vdb", dense_xyz=GRID.shape_zyx[::-1], points_ijk=[(149, 36, 44)])
    assert describe_grids(grids) == summary
    reference = _reference(tmp_path / "ref.vdb", layers, rgb, coloured, sdf)
    for name, volume in grids.items():
        ref = reference[name]
        assert volume.active_voxels == ref.active_voxels
        assert volume.background == pytest.approx(ref.background)
        assert volume.metadata["creator"] == "test"
        np.testing.assert_array_equal(volume.values, ref.values, err_msg=name)
        np.testing.assert_array_equal(volume.active, ref.active, err_msg=name)
        np.testing.assert_allclose(volume.voxel_size, GRID.voxel_mm)
        np.testing.assert_allclose(
            volume.index_to_world[0], GRID.index_to_world([[44, 36, 149]])[0]
        )
    # Stats metadata as OpenVDB's own writer stores it (read without loading the trees).
    ours = read_grid_metadata(tmp_path / "v.vdb")
    theirs = read_grid_metadata(tmp_path / "ref.vdb")
    for name in GRID_NAMES:
        for key in ("file_bbox_min", "file_bbox_max", "file_voxel_count"):
            assert ours[name][key] == theirs[name][key], (name, key)
    assert grids["sdf"].metadata["class"] == "level set"
    assert grids["density"].metadata["class"] == "fog volume"
    assert grids["color"].metadata["vector_type"] == "invariant"
    # The core is stored as tiles, not leaves (what keeps the files and memory small).
    touched = len(np.unique(np.argwhere(layers > 0) // 8, axis=0))  # 8^3 blocks inside
    assert grids["density"].leaf_count < touched
    assert grids["density"].leaf_count <= reference["density"].leaf_count


def test_streamed_writer_rejects_gaps_and_missing_rows(tmp_path):
    layers, rgb, coloured, sdf = _volumes()
    writer = VdbStackWriter(GRID, sdf_half_width_mm=HALF_WIDTH, spool_dir=tmp_path)
    writer.write_slab(0, layers[:8], rgb[:8], coloured[:8], sdf[:8])
    with pytest.raises(ValueError, match="expected row 8, got 9"):
        writer.write_slab(9, layers[9:], rgb[9:], coloured[9:], sdf[9:])
    with pytest.raises(ValueError, match="only 8 of 45 rows"):
        writer.write(tmp_path / "v.vdb")
    assert list(tmp_path.iterdir()) == []


def _materials(layers: np.ndarray) -> np.ndarray:
    """Random halftone materials 1..6 in the colour layer, 7 in the backing, 9 in the core."""
    rng = np.random.default_rng(13)
    materials = np.zeros(layers.shape, np.uint8)
    skin = layers == 1
    materials[skin] = rng.integers(1, 7, int(skin.sum()))
    materials[layers == 2] = 7
    materials[layers == 3] = 9
    return materials


@pytest.mark.parametrize("rows", [8, 13])
def test_material_grid_equals_openvdbs_own(tmp_path, rows):
    layers, rgb, coloured, sdf = _volumes()
    materials = _materials(layers)
    writer = VdbStackWriter(
        GRID, sdf_half_width_mm=HALF_WIDTH, spool_dir=tmp_path, material_grid=True
    )
    for start in range(0, GRID.shape_zyx[0], rows):
        part = slice(start, start + rows)
        writer.write_slab(
            start, layers[part], rgb[part], coloured[part], sdf[part], materials=materials[part]
        )
    summary = writer.write(tmp_path / "v.vdb")
    grids = read_vdb(tmp_path / "v.vdb", dense_xyz=GRID.shape_zyx[::-1])
    assert sorted(grids) == sorted([*GRID_NAMES, MATERIAL_GRID])
    assert describe_grids(grids) == summary
    reference = _reference(tmp_path / "ref.vdb", layers, rgb, coloured, sdf, materials)
    for name, volume in grids.items():  # the four grids are unchanged by the fifth
        ref = reference[name]
        assert volume.active_voxels == ref.active_voxels, name
        np.testing.assert_array_equal(volume.values, ref.values, err_msg=name)
        np.testing.assert_array_equal(volume.active, ref.active, err_msg=name)
    values, active = grids[MATERIAL_GRID].zyx()
    np.testing.assert_array_equal(values.astype(np.uint8), materials)  # voxel for voxel
    np.testing.assert_array_equal(active, materials > 0)
    assert summary[MATERIAL_GRID]["active_voxels"] == np.count_nonzero(materials)
    # The constant core (material 9) is stored as tiles.
    touched = len(np.unique(np.argwhere(materials > 0) // 8, axis=0))
    assert grids[MATERIAL_GRID].leaf_count < touched
    assert grids[MATERIAL_GRID].leaf_count <= reference[MATERIAL_GRID].leaf_count


def test_material_grid_is_given_exactly_when_asked_for(tmp_path):
    layers, rgb, coloured, sdf = _volumes()
    plain = VdbStackWriter(GRID, sdf_half_width_mm=HALF_WIDTH, spool_dir=tmp_path)
    with pytest.raises(ValueError, match="material_grid=True"):
        plain.write_slab(0, layers[:8], rgb[:8], coloured[:8], sdf[:8], materials=layers[:8])
    plain.close()
    with_grid = VdbStackWriter(
        GRID, sdf_half_width_mm=HALF_WIDTH, spool_dir=tmp_path, material_grid=True
    )
    with pytest.raises(ValueError, match="material_grid=True"):
        with_grid.write_slab(0, layers[:8], rgb[:8], coloured[:8], sdf[:8])
    with pytest.raises(ValueError, match="must have the shape of layers"):
        with_grid.write_slab(0, layers[:8], rgb[:8], coloured[:8], sdf[:8], materials=layers[:7])
    with_grid.close()
    assert list(tmp_path.iterdir()) == []
