from __future__ import annotations

import colour
import numpy as np
import pytest
import tifffile

from shellvox.atomic import atomic_path, write_text_atomic
from shellvox.testing import describe_grids, read_vdb
from shellvox.voxel.grid import GridSpec
from shellvox.voxel.io import TiffStackWriter
from shellvox.voxel.io.vdb import VdbStackWriter

GRID = GridSpec((1.0, 2.0, 3.0), (0.0423, 0.0846, 0.027), (10, 20, 30))


@pytest.mark.parametrize("samples", [0, 3, 4])
def test_tiff_round_trip(tmp_path, samples):
    rng = np.random.default_rng(samples)
    shape = GRID.shape_zyx + ((samples,) if samples else ())
    data = rng.integers(0, 255, shape).astype(np.uint8)
    with TiffStackWriter(tmp_path / "a.tif", GRID, samples=samples) as writer:
        for start, stop in ((0, 3), (3, 4), (4, 10)):
            writer.write_slab(data[start:stop])
    with tifffile.TiffFile(tmp_path / "a.tif") as tiff:
        np.testing.assert_array_equal(tiff.asarray(), data)
        assert tiff.is_imagej
        assert tiff.imagej_metadata["unit"] == "mm"
        assert tiff.imagej_metadata["spacing"] == pytest.approx(0.027)
        x_res = tiff.pages[0].tags["XResolution"].value
        y_res = tiff.pages[0].tags["YResolution"].value
        assert x_res[1] / x_res[0] == pytest.approx(0.0423, rel=1e-5)
        assert y_res[1] / y_res[0] == pytest.approx(0.0846, rel=1e-5)
        assert tiff.pages[0].compression == tifffile.COMPRESSION.ADOBE_DEFLATE


def test_tiff_rejects_wrong_slabs(tmp_path):
    writer = TiffStackWriter(tmp_path / "b.tif", GRID)
    with pytest.raises(ValueError, match="slab must be uint8"):
        writer.write_slab(np.zeros((2, 20, 31), np.uint8))
    writer.write_slab(np.zeros((2, 20, 30), np.uint8))
    with pytest.raises(ValueError, match="2 of 10 pages"):
        writer.close()


def test_vdb_round_trip(tmp_path):
    layers = np.zeros(GRID.shape_zyx, np.uint8)
    layers[2:8, 5:15, 10:20] = 1
    layers[3:7, 7:13, 12:18] = 2
    rgb = np.zeros((*GRID.shape_zyx, 3), np.uint8)
    rgb[layers == 1] = (188, 137, 255)  # linear (0.5, 0.25, 1.0) to 8 bits
    coloured = layers == 1
    sdf = np.full(GRID.shape_zyx, 0.25, np.float32)
    sdf[layers == 1] = -0.01
    writer = VdbStackWriter(GRID, sdf_half_width_mm=0.25)
    writer.write_slab(0, layers[:4], rgb[:4], coloured[:4], sdf[:4])
    writer.write_slab(4, layers[4:], rgb[4:], coloured[4:], sdf[4:])
    summary = writer.write(tmp_path / "v.vdb", {"tool": "shellvox"})
    grids = read_vdb(tmp_path / "v.vdb", dense_xyz=GRID.shape_zyx[::-1], points_ijk=[(15, 10, 3)])
    assert describe_grids(grids) == summary
    assert summary["density"]["active_voxels"] == np.count_nonzero(layers)
    assert summary["color"]["active_voxels"] == np.count_nonzero(layers == 1)
    stored = grids["color"].values[10, 5, 2]
    expected = colour.models.eotf_sRGB(np.array([188, 137, 255]) / 255.0)
    np.testing.assert_allclose(stored, expected, atol=1e-6)  # linear light
    assert summary["sdf"]["class"] == "level set"
    for grid in grids.values():
        np.testing.assert_allclose(grid.voxel_size, GRID.voxel_mm)
    # index (i, j, k) = (x, y, z) maps to the voxel centre
    np.testing.assert_allclose(
        grids["layer"].index_to_world[0], GRID.index_to_world([[3, 10, 15]])[0]
    )
    np.testing.assert_array_equal(grids["layer"].zyx()[0], layers)
    assert grids["sdf"].values[15, 10, 5] == pytest.approx(-0.25)


def test_atomic_leaves_nothing_on_failure(tmp_path):
    target = tmp_path / "out.json"

    def fail() -> None:
        with atomic_path(target) as temporary:
            temporary.write_text("half")
            raise RuntimeError("boom")

    with pytest.raises(RuntimeError, match="boom"):
        fail()
    assert list(tmp_path.iterdir()) == []
    write_text_atomic(target, "{}")
    assert target.read_text() == "{}"
    assert [p.name for p in tmp_path.iterdir()] == ["out.json"]


def test_bigtiff_past_the_classic_limit(tmp_path, monkeypatch):
    import shellvox.voxel.io._tiff_writer as tiff_writer

    monkeypatch.setattr(tiff_writer, "CLASSIC_TIFF_LIMIT", 1000)
    data = np.arange(np.prod(GRID.shape_zyx)).reshape(GRID.shape_zyx).astype(np.uint8)
    with TiffStackWriter(tmp_path / "big.tif", GRID) as writer:
        assert writer.bigtiff
        writer.write_slab(data)
    with tifffile.TiffFile(tmp_path / "big.tif") as tiff:
        assert tiff.is_bigtiff
        assert tiff.imagej_metadata["unit"] == "mm"
        np.testing.assert_array_equal(tiff.asarray(), data)


def test_atomic_files_get_the_usual_mode(tmp_path):
    import os

    umask = os.umask(0o022)
    try:
        write_text_atomic(tmp_path / "a.json", "{}")
    finally:
        os.umask(umask)
    assert (tmp_path / "a.json").stat().st_mode & 0o777 == 0o644


def test_vdb_skips_empty_slabs_and_crops_to_content(tmp_path):
    layers = np.zeros(GRID.shape_zyx, np.uint8)
    layers[6, 3, 4] = 1  # one voxel in the last slab, far from the grid origin
    rgb = np.zeros((*GRID.shape_zyx, 3), np.uint8)  # black, yet a colour voxel
    sdf = np.full(GRID.shape_zyx, 0.25, np.float32)
    sdf[6, 3, 4] = -0.05
    writer = VdbStackWriter(GRID, sdf_half_width_mm=0.25)
    coloured = layers == 1
    writer.write_slab(0, layers[:4], rgb[:4], coloured[:4], sdf[:4])  # all background
    writer.write_slab(4, layers[4:], rgb[4:], coloured[4:], sdf[4:])
    summary = writer.write(tmp_path / "v.vdb", {})
    assert {name: grid["active_voxels"] for name, grid in summary.items()} == {
        "density": 1,
        "layer": 1,
        "color": 1,
        "sdf": 1,
    }
    by_name = read_vdb(tmp_path / "v.vdb", dense_xyz=GRID.shape_zyx[::-1])
    color = by_name["color"]
    assert color.values[4, 3, 6] == pytest.approx((0.0, 0.0, 0.0), abs=1e-6)
    # Cropped to the content, as OpenVDB itself reads it: each grid is the one 8^3 leaf
    # holding voxel (x, y, z) = (4, 3, 6), and its active box is that voxel; the empty
    # first slab and the rest of the 10 x 20 x 30 grid hold no leaf and no tile.
    for name, grid in by_name.items():
        assert grid.leaf_count == 1, name
        assert grid.active_bbox == ((4, 3, 6), (4, 3, 6)), name
        assert grid.leaf_bbox == ((0, 0, 0), (7, 7, 7)), name
