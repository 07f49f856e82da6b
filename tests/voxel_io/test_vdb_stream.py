"""The streamed VDB writer against grids OpenVDB builds in memory from the same arrays.

The reference is OpenVDB's own ``copyFromArray`` (plus ``signedFloodFill`` for the level
set) and ``openvdb.write``; both files are read back with OpenVDB's reader and compared
voxel for voxel: values (active and inactive), active states and active counts.
"""

from __future__ import annotations

import numpy as np
import pytest
from openvdb_module import load_openvdb
from vdb_checks import describe_grids

from voxel.colour import codes_to_linear
from voxel.grid import GridSpec
from voxel.io.vdb import GRID_NAMES, MATERIAL_GRID, VdbStackWriter

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


def _reference(layers, rgb, coloured, sdf):
    """Grids built by OpenVDB itself, as the in-memory writer did."""
    vdb = load_openvdb()
    xyz = (2, 1, 0)
    density = vdb.FloatGrid(0.0)
    density.copyFromArray(np.ascontiguousarray((layers > 0).transpose(xyz), np.float32))
    layer = vdb.FloatGrid(0.0)
    layer.copyFromArray(np.ascontiguousarray(layers.transpose(xyz), np.float32))
    linear = codes_to_linear(rgb)
    linear[coloured] = np.maximum(linear[coloured], np.float32(1e-7))
    color = vdb.Vec3SGrid((0.0, 0.0, 0.0))
    color.copyFromArray(np.ascontiguousarray(linear.transpose(2, 1, 0, 3), np.float32))
    level = vdb.FloatGrid(HALF_WIDTH)
    level.copyFromArray(np.ascontiguousarray(sdf.transpose(xyz), np.float32))
    level.signedFloodFill()
    grids = dict(zip(GRID_NAMES, (density, layer, color, level), strict=True))
    for name, volume in grids.items():
        volume.name = name
    return grids


def _dense(volume, channels: int) -> tuple[np.ndarray, np.ndarray]:
    """Return ``(values (Z, Y, X[, 3]), active (Z, Y, X))`` of a grid over GRID."""
    shape = GRID.shape_zyx[::-1] + ((3,) if channels == 3 else ())
    values = np.zeros(shape, np.float32)
    volume.copyToArray(values, ijk=(0, 0, 0))
    active = np.zeros(GRID.shape_zyx[::-1], bool)
    for item in volume.iterOnValues():  # voxels and tiles
        lo, hi = item["min"], item["max"]
        active[lo[0] : hi[0] + 1, lo[1] : hi[1] + 1, lo[2] : hi[2] + 1] = True
    axes = (2, 1, 0, 3) if channels == 3 else (2, 1, 0)
    return values.transpose(axes), active.transpose(2, 1, 0)


@pytest.mark.parametrize("rows", [13, 8, 45])
def test_streamed_grids_equal_openvdbs_own(tmp_path, rows):
    vdb = load_openvdb()
    layers, rgb, coloured, sdf = _volumes()
    writer = VdbStackWriter(GRID, sdf_half_width_mm=HALF_WIDTH, spool_dir=tmp_path)
    for start in range(0, GRID.shape_zyx[0], rows):
        part = slice(start, start + rows)
        writer.write_slab(start, layers[part], rgb[part], coloured[part], sdf[part])
    summary = writer.write(tmp_path / "v.vdb", {"creator": "test"})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["v.vdb"]  # spools removed
    grids, _ = vdb.readAll(str(tmp_path / "v.vdb"))
    assert describe_grids(grids) == summary
    reference = _reference(layers, rgb, coloured, sdf)
    for volume in grids:
        ref = reference[volume.name]
        assert volume.activeVoxelCount() == ref.activeVoxelCount()
        assert volume.background == pytest.approx(ref.background)
        assert volume["creator"] == "test"
        channels = 3 if volume.valueTypeName == "vec3s" else 1
        got, got_on = _dense(volume, channels)
        want, want_on = _dense(ref, channels)
        np.testing.assert_array_equal(got, want, err_msg=volume.name)
        np.testing.assert_array_equal(got_on, want_on, err_msg=volume.name)
        np.testing.assert_allclose(volume.transform.voxelSize(), GRID.voxel_mm)
        np.testing.assert_allclose(
            volume.transform.indexToWorld((149, 36, 44)),
            GRID.index_to_world([[44, 36, 149]])[0],
        )
    # Stats metadata as OpenVDB's own writer stores it (read without loading the trees).
    ref_path = tmp_path / "ref.vdb"
    vdb.write(str(ref_path), grids=list(reference.values()))
    ours = {g.name: g for g in vdb.readAllGridMetadata(str(tmp_path / "v.vdb"))}
    theirs = {g.name: g for g in vdb.readAllGridMetadata(str(ref_path))}
    for name in GRID_NAMES:
        for key in ("file_bbox_min", "file_bbox_max", "file_voxel_count"):
            assert ours[name][key] == theirs[name][key], (name, key)
    by_name = {volume.name: volume for volume in grids}
    assert by_name["sdf"]["class"] == "level set"
    assert by_name["density"]["class"] == "fog volume"
    assert by_name["color"]["vector_type"] == "invariant"
    # The core is stored as tiles, not leaves (what keeps the files and memory small).
    touched = len(np.unique(np.argwhere(layers > 0) // 8, axis=0))  # 8^3 blocks inside
    assert by_name["density"].leafCount() < touched
    assert by_name["density"].leafCount() <= reference["density"].leafCount()


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
    vdb = load_openvdb()
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
    grids, _ = vdb.readAll(str(tmp_path / "v.vdb"))
    assert sorted(volume.name for volume in grids) == sorted([*GRID_NAMES, MATERIAL_GRID])
    assert describe_grids(grids) == summary
    reference = _reference(layers, rgb, coloured, sdf)
    material = vdb.FloatGrid(0.0)
    material.copyFromArray(np.ascontiguousarray(materials.transpose(2, 1, 0), np.float32))
    reference[MATERIAL_GRID] = material
    for volume in grids:  # the four grids are unchanged by the fifth
        ref = reference[volume.name]
        assert volume.activeVoxelCount() == ref.activeVoxelCount(), volume.name
        channels = 3 if volume.valueTypeName == "vec3s" else 1
        got, got_on = _dense(volume, channels)
        want, want_on = _dense(ref, channels)
        np.testing.assert_array_equal(got, want, err_msg=volume.name)
        np.testing.assert_array_equal(got_on, want_on, err_msg=volume.name)
    by_name = {volume.name: volume for volume in grids}
    values, active = _dense(by_name[MATERIAL_GRID], 1)
    np.testing.assert_array_equal(values.astype(np.uint8), materials)  # voxel for voxel
    np.testing.assert_array_equal(active, materials > 0)
    assert summary[MATERIAL_GRID]["active_voxels"] == np.count_nonzero(materials)
    # The constant core (material 9) is stored as tiles.
    touched = len(np.unique(np.argwhere(materials > 0) // 8, axis=0))
    assert by_name[MATERIAL_GRID].leafCount() < touched
    assert by_name[MATERIAL_GRID].leafCount() <= material.leafCount()


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
