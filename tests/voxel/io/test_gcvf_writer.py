"""GrabCAD Voxel Print jobs read back with zipfile, xml.etree and Pillow.

The expected slices come from the material table and the input volume alone: every
pixel must be its voxel's key, under the documented orientation (row 0 is the largest y
by default), and each ``VoxelCount`` is recounted from the decoded slices.
"""

from __future__ import annotations

import io
import itertools
import re
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest
import tifffile
from PIL import Image

import shellvox.voxel.io._gcvf_writer as gcvf_writer
from shellvox.atomic import atomic_path
from shellvox.printer import load_profile
from shellvox.voxel.grid import GridSpec
from shellvox.voxel.io import GcvfJobError, GcvfWriter, TiffStackWriter

J750 = load_profile("j750").voxel_mm
GRID = GridSpec((-3.0, 1.0, 0.5), J750, (37, 29, 53))
BACKGROUND = (0, 0, 0, 0)  # air, transparent
TABLE = [
    (0, "void", BACKGROUND),
    (1, "VeroCY-V", (0, 255, 255, 255)),
    (2, "VeroMGT-V", (255, 0, 255, 255)),
    (3, "VeroYL-V", (255, 255, 0, 255)),
    (4, "VeroBlack", (0, 0, 0, 255)),
    (5, "VeroPureWht", (255, 255, 255, 255)),
    (7, "VeroClear", (137, 137, 137, 255)),
]
KEY = {index: key for index, _, key in TABLE}


def _volume(grid: GridSpec = GRID, seed: int = 3) -> np.ndarray:
    """An ellipsoid: a white core, a random halftone skin of the other materials, void."""
    z, y, x = np.indices(grid.shape_zyx, dtype=np.float64)
    n_z, n_y, n_x = grid.shape_zyx
    r = np.sqrt(
        ((x - n_x / 2) / (0.45 * n_x)) ** 2
        + ((y - n_y / 2) / (0.45 * n_y)) ** 2
        + ((z - n_z / 2) / (0.45 * n_z)) ** 2
    )
    rng = np.random.default_rng(seed)
    volume = np.where(r < 1.0, rng.choice([1, 2, 3, 4, 7], size=r.shape), 0).astype(np.uint8)
    volume[r < 0.6] = 5
    return volume


def _write(path, volume, *, bounds=(0, 5, 6, 19, 37), grid=GRID, table=TABLE, **options):
    with GcvfWriter(path, grid, table, **options) as job:
        for start, stop in itertools.pairwise(bounds):
            job.write_slab(volume[start:stop])
    return job.summary


def _read(path):
    """Return (config root, {name: (H, W, 4) uint8 array}, {name: mode}) of a job."""
    with zipfile.ZipFile(path) as job:
        assert job.testzip() is None
        config = ET.fromstring(job.read("ConfigFile.xml"))
        images, modes = {}, {}
        for name in job.namelist():
            if name.startswith("layer_") and name.endswith(".png"):
                with Image.open(io.BytesIO(job.read(name))) as image:
                    modes[name] = image.mode
                    images[name] = np.asarray(image.convert("RGBA"))
    return config, images, modes


def _to_indices(image: np.ndarray) -> np.ndarray:
    """Decode keys back to material indices (-1 where a pixel is no key)."""
    indices = np.full(image.shape[:2], -1, dtype=np.int16)
    for index, key in KEY.items():
        indices[np.all(image == key, axis=-1)] = index
    return indices


@pytest.mark.parametrize("first_row", ["max_y", "min_y"])
def test_job_reads_back_as_the_volume(tmp_path, first_row):
    volume = _volume()
    summary = _write(tmp_path / "job.gcvf", volume, first_row=first_row)
    config, images, modes = _read(tmp_path / "job.gcvf")
    n_z, n_y, n_x = GRID.shape_zyx

    assert config.tag == "GCVF"
    assert config.findtext("Version") == "2"
    assert config.findtext("Resolution/XDpi") == "600"
    assert config.findtext("Resolution/YDpi") == "300"
    assert config.findtext("Resolution/SliceThicknessNanoMeter") == "27000"
    assert int(config.findtext("SliceDimensions/SliceWidth")) == n_x
    assert int(config.findtext("SliceDimensions/SliceHeight")) == n_y
    assert config.findtext("SliceRange/StartIndex") == "0"
    assert int(config.findtext("SliceRange/NumberOfSlices")) == n_z == len(images)
    assert config.findtext("DataSemantics") == "Materials"
    assert config.findtext("CreationMode") == "MODEL_ONLY"
    assert config.findtext("ImageFilePrefix") == "layer_"
    assert config.findtext("MaxNumberOfColors") == "6"
    assert config.findtext("BitDepth") == "4"
    assert config.findtext("MaterialList/BackGroundMaterialRGBA") == "0 0 0 0"

    # Contiguous, unpadded names from 0; every slice RGBA (never a palette) of the declared size.
    assert sorted(images) == sorted(f"layer_{z}.png" for z in range(n_z))
    assert set(modes.values()) == {"RGBA"}
    assert {image.shape for image in images.values()} == {(n_y, n_x, 4)}

    decoded = np.stack([_to_indices(images[f"layer_{z}.png"]) for z in range(n_z)])
    assert decoded.min() >= 0, "a pixel holds a colour that is no material key"
    expected = volume[:, ::-1, :] if first_row == "max_y" else volume
    np.testing.assert_array_equal(decoded, expected)

    # One Material per material used, in table order, with its count over all slices.
    listed = [
        (
            m.findtext("Name"),
            tuple(map(int, m.findtext("RGBA").split())),
            int(m.findtext("VoxelCount")),
        )
        for m in config.findall("MaterialList/Material")
    ]
    stack = np.stack([images[f"layer_{z}.png"] for z in range(n_z)])
    assert listed == [
        (name, key, int(np.all(stack == key, axis=-1).sum()))
        for index, name, key in TABLE
        if index and np.any(volume == index)
    ]
    assert [name for name, _, _ in listed] == [
        "VeroCY-V",
        "VeroMGT-V",
        "VeroYL-V",
        "VeroBlack",
        "VeroPureWht",
        "VeroClear",
    ]
    assert summary.n_slices == n_z and summary.n_padding_slices == 0
    assert summary.voxel_counts == {
        int(i): int(c) for i, c in enumerate(np.bincount(volume.ravel())) if c
    }


def test_orientation_of_one_voxel(tmp_path):
    """Voxel (z=0, y=0, x=0), the lowest y, is the bottom-left pixel of layer_0."""
    volume = np.zeros(GRID.shape_zyx, dtype=np.uint8)
    volume[0, 0, 0] = 1
    volume[-1, -1, -1] = 2
    _write(tmp_path / "job.gcvf", volume)
    config, images, _ = _read(tmp_path / "job.gcvf")
    # Only the materials used are listed.
    listed = config.findall("MaterialList/Material")
    assert [(m.findtext("Name"), m.findtext("VoxelCount")) for m in listed] == [
        ("VeroCY-V", "1"),
        ("VeroMGT-V", "1"),
    ]
    first, last = images["layer_0.png"], images[f"layer_{GRID.shape_zyx[0] - 1}.png"]
    assert tuple(first[-1, 0]) == KEY[1]
    assert tuple(last[0, -1]) == KEY[2]
    assert np.all(first[:-1] == BACKGROUND) and np.all(first[-1, 1:] == BACKGROUND)


def test_materials_tif_agrees_with_the_slices(tmp_path):
    volume = _volume(seed=11)
    target = tmp_path / "materials.tif"
    with (
        atomic_path(target) as tif_path,
        TiffStackWriter(tif_path, GRID) as tif,
        GcvfWriter(tmp_path / "job.gcvf", GRID, TABLE) as job,
    ):
        for start in range(0, GRID.shape_zyx[0], 8):
            slab = volume[start : start + 8]
            tif.write_slab(slab)
            job.write_slab(slab)
    _, images, _ = _read(tmp_path / "job.gcvf")
    with tifffile.TiffFile(target) as tiff:
        stack = tiff.asarray()
        assert tiff.is_imagej
        assert tiff.imagej_metadata["spacing"] == pytest.approx(0.027)
    assert stack.dtype == np.uint8 and stack.shape == GRID.shape_zyx
    decoded = np.stack([_to_indices(images[f"layer_{z}.png"]) for z in range(len(stack))])
    # layer_N.png row r, column c is materials.tif page N, row Y - 1 - r, column c.
    np.testing.assert_array_equal(decoded[:, ::-1, :], stack)


def test_short_jobs_are_padded_to_30_slices(tmp_path):
    grid = GridSpec((0.0, 0.0, 0.0), J750, (4, 9, 12))
    volume = _volume(grid)
    summary = _write(tmp_path / "job.gcvf", volume, bounds=(0, 3, 4), grid=grid)
    config, images, _ = _read(tmp_path / "job.gcvf")
    assert summary.n_padding_slices == 26 and summary.n_slices == 30
    assert int(config.findtext("SliceRange/NumberOfSlices")) == 30
    assert sorted(images) == sorted(f"layer_{z}.png" for z in range(30))
    for z in range(30):
        expected = volume[z, ::-1] if z < 4 else np.zeros(grid.shape_zyx[1:], np.uint8)
        np.testing.assert_array_equal(_to_indices(images[f"layer_{z}.png"]), expected)
    counts = {
        m.findtext("Name"): int(m.findtext("VoxelCount"))
        for m in config.findall("MaterialList/Material")
    }
    assert counts["VeroPureWht"] == int(np.count_nonzero(volume == 5))


def test_too_many_materials_are_refused_before_writing(tmp_path):
    table = [*TABLE, (9, "VeroUltraClear", (9, 9, 9, 255))]  # 7 besides void
    with pytest.raises(GcvfJobError, match=r"at most 6 materials besides the background, got 7"):
        GcvfWriter(tmp_path / "job.gcvf", GRID, table)
    with pytest.raises(GcvfJobError, match=r"at most 3 materials .* got 4"):
        GcvfWriter(tmp_path / "job.gcvf", GRID, TABLE[:5], max_materials=3)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ([(1, "VeroBlack", (0, 0, 0, 0))], "background .* key"),
        ([(1, "A", (1, 2, 3, 255)), (2, "B", (1, 2, 3, 255))], "keys repeat"),
        ([(1, "A", (1, 2, 3, 255)), (1, "B", (4, 5, 6, 255))], "indices repeat"),
        ([(1, "A", (1, 2, 300, 255))], "0..255"),
        ([(1, "A", (1, 2, 3))], "4 integers"),
        ([(0, "void", (9, 9, 9, 255))], "void but its key"),
        ([(256, "A", (1, 2, 3, 255))], "indices are integers 0..255"),
        ([(1, "", (1, 2, 3, 255))], "no name"),
    ],
)
def test_bad_material_tables_are_refused(tmp_path, table, message):
    with pytest.raises(GcvfJobError, match=message):
        GcvfWriter(tmp_path / "job.gcvf", GRID, table)
    assert list(tmp_path.iterdir()) == []


def test_grid_must_be_the_jobs_resolution_and_fit_the_tray(tmp_path):
    grid = GridSpec((0.0, 0.0, 0.0), (0.05, 0.05, 0.027), (40, 10, 10))
    with pytest.raises(GcvfJobError, match=r"voxel size .* is not the job's 600 x 300 dpi"):
        GcvfWriter(tmp_path / "job.gcvf", grid, TABLE)
    # 53 x 29 x 37 voxels are 2.24 x 2.46 x 1.0 mm.
    with pytest.raises(GcvfJobError, match="larger than the printer's tray"):
        GcvfWriter(tmp_path / "job.gcvf", GRID, TABLE, tray_mm=(2.0, 10.0, 10.0))
    assert list(tmp_path.iterdir()) == []
    # The 14 um high-quality mode with its own grid is accepted.
    fine = GridSpec((0.0, 0.0, 0.0), (J750[0], J750[1], 0.014), GRID.shape_zyx)
    summary = _write(tmp_path / "hq.gcvf", _volume(fine), grid=fine, slice_thickness_nm=14000)
    config, _, _ = _read(tmp_path / "hq.gcvf")
    assert config.findtext("Resolution/SliceThicknessNanoMeter") == "14000"
    assert summary.n_slices == 37


def test_unknown_indices_and_wrong_slabs_are_refused(tmp_path):
    volume = _volume()
    job = GcvfWriter(tmp_path / "job.gcvf", GRID, TABLE)
    with pytest.raises(ValueError, match=r"must be uint8 \(Zs, 29, 53\)"):
        job.write_slab(volume[:2, :, :50])
    bad = volume[:3].copy()
    bad[1, 2, 3] = 6  # not in the table
    with pytest.raises(ValueError, match=r"slices 0..2 hold material indices \[6\]"):
        job.write_slab(bad)
    job.write_slab(volume[:3])
    with pytest.raises(ValueError, match="3 of 37 slices written"):
        job.close()
    assert list(tmp_path.iterdir()) == []  # a failed close leaves no file


def test_aborted_writers_leave_no_file(tmp_path):
    volume = _volume()
    target = tmp_path / "job.gcvf"

    def interrupted() -> None:
        with atomic_path(target) as path, GcvfWriter(path, GRID, TABLE) as job:
            job.write_slab(volume[:10])
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        interrupted()
    assert list(tmp_path.iterdir()) == []
    job = GcvfWriter(target, GRID, TABLE)
    job.write_slab(volume[:10])
    job.abort()
    assert list(tmp_path.iterdir()) == []


def test_a_failure_in_the_writer_thread_reaches_the_caller(tmp_path, monkeypatch):
    calls = []

    def failing(indices, lut, **options):
        calls.append(1)
        if len(calls) == 3:
            raise OSError("disk full")
        return b""

    monkeypatch.setattr(gcvf_writer, "encode_indexed_png", failing)
    volume = _volume()

    def write() -> None:
        with GcvfWriter(tmp_path / "job.gcvf", GRID, TABLE, threads=1) as job:
            for start in range(0, GRID.shape_zyx[0], 2):
                job.write_slab(volume[start : start + 2])

    with pytest.raises(RuntimeError, match="disk full"):
        write()
    assert list(tmp_path.iterdir()) == []


def test_parallel_encoding_writes_the_same_bytes(tmp_path):
    volume = _volume()
    _write(tmp_path / "one.gcvf", volume, threads=1)
    _write(tmp_path / "three.gcvf", volume, threads=3, bounds=(0, 1, 2, 37))
    assert (tmp_path / "one.gcvf").read_bytes() == (tmp_path / "three.gcvf").read_bytes()
    with zipfile.ZipFile(tmp_path / "one.gcvf") as job:
        # PNGs are stored (already deflated); the box and height map follow, the config is last.
        infos = job.infolist()
        assert [i.filename for i in infos[-3:]] == ["MeshBbx.ktn", "Zbuffer.png", "ConfigFile.xml"]
        assert {i.compress_type for i in infos[:-1]} == {zipfile.ZIP_STORED}
        header = job.read("ConfigFile.xml")[:60]
    assert re.match(rb'<\?xml version="1.0" encoding="UTF-8"\?>\n<GCVF>', header)


def test_box_height_map_and_surface_read_back_as_the_build(tmp_path):
    import trimesh

    volume = _volume(seed=5)
    volume[:, 3, 4] = 0
    volume[7, 3, 4] = 2  # a column whose only material is low
    # The surface: a box around the ellipsoid, in the grid's world frame (mm).
    corner = np.asarray(GRID.origin_mm) - 0.5 * np.asarray(GRID.voxel_mm)
    box = trimesh.creation.box(extents=(1.0, 0.5, 0.25))
    box.apply_translation(corner + np.array([1.0, 1.0, 0.5]))
    surface = (np.asarray(box.vertices), np.asarray(box.faces, np.int64))
    _write(tmp_path / "job.gcvf", volume, surface=surface)
    n_z, n_y, n_x = GRID.shape_zyx
    with zipfile.ZipFile(tmp_path / "job.gcvf") as job:
        box_values = np.frombuffer(job.read("MeshBbx.ktn"), "<f4")
        with Image.open(io.BytesIO(job.read("Zbuffer.png"))) as image:
            zbuffer = np.asarray(image)
            mode = image.mode
        stl = trimesh.load(io.BytesIO(job.read("Mesh.stl")), file_type="stl")
    assert box_values.tolist() == [0, 0, 0, n_x, n_y, n_z]
    assert mode.startswith("I;16") and zbuffer.shape == (n_y, n_x)
    # The highest slice with material per column (row 0 is the largest y, as the slices).
    solid = volume != 0
    top = np.where(solid.any(0), n_z - 1 - np.argmax(solid[::-1], axis=0), 0)
    np.testing.assert_array_equal(zbuffer, top[::-1])
    assert zbuffer[n_y - 1 - 3, 4] == 7
    # The surface in mm with the job box's corner at the origin.
    np.testing.assert_allclose(stl.bounds, box.bounds - corner, atol=1e-5)
    assert len(stl.faces) == len(box.faces) and stl.is_watertight


def test_a_job_is_the_same_bytes_each_time(tmp_path):
    import trimesh

    box = trimesh.creation.box(extents=(1.0, 0.5, 0.25))
    surface = (np.asarray(box.vertices), np.asarray(box.faces, np.int64))
    volume = _volume(seed=8)
    _write(tmp_path / "a.gcvf", volume, surface=surface)
    _write(tmp_path / "b.gcvf", volume, surface=surface, threads=1, bounds=(0, 37))
    assert (tmp_path / "a.gcvf").read_bytes() == (tmp_path / "b.gcvf").read_bytes()
