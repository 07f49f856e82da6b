"""The viewer on a build's OME-Zarr store: the same slices as the TIFF stacks (issue 26).

Independent truth: the TIFF stacks read back by tifffile (at one voxel per pixel), and the
store's pyramid levels read with ``zarr`` alone (a zoomed-out region is the level's voxels
holding the asked-for ones).
"""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
import tifffile
import zarr

from shellvox.viewer import BuildFolder
from shellvox.viewer import _surface as surface_module
from shellvox.viewer._slices import probe
from shellvox.viewer._stacks import StackError
from shellvox.viewer._surface import Overview
from shellvox.viewer._zarr_stacks import ZarrStack, read_context

PLANE = {"z": ("y", "x"), "y": ("z", "x"), "x": ("z", "y")}
KINDS = {"layers": "layers.tif", "colour": "colour.tif", "materials": "materials.tif"}
GROUPS = {"layers": "labels/layers", "colour": "", "materials": "labels/materials"}


@pytest.fixture(scope="module")
def truth(small_zarr_build):
    return {kind: tifffile.imread(small_zarr_build / name) for kind, name in KINDS.items()}


@pytest.fixture(scope="module")
def folder(small_zarr_build):
    with BuildFolder.open(small_zarr_build) as opened:
        yield opened


def _plane(volume, axis, index, rows, cols):
    plane = volume[(slice(None),) * "zyx".index(axis) + (index,)]
    return plane[np.ix_(list(rows), list(cols))]


def test_a_build_with_the_store_is_read_from_it(folder):
    assert all(isinstance(stack, ZarrStack) for stack in folder.stacks.values())
    assert sorted(folder.stacks) == ["colour", "layers", "materials"]
    assert folder.describe()["colour_samples"] == 3


@pytest.mark.parametrize("kind", sorted(KINDS))
@pytest.mark.parametrize("axis", ["z", "y", "x"])
def test_slices_at_one_voxel_a_pixel_are_the_tiff_stacks(folder, truth, kind, axis):
    shape = dict(zip("zyx", folder.grid.shape_zyx, strict=True))
    row_axis, col_axis = PLANE[axis]
    for index in (0, shape[axis] // 2, shape[axis] - 1):
        for rows, cols in (
            (range(shape[row_axis]), range(shape[col_axis])),
            (range(3, shape[row_axis] - 1), range(10, 20)),
        ):
            got = folder.stacks[kind].region(axis, index, rows, cols)
            assert np.array_equal(got, _plane(truth[kind], axis, index, rows, cols))


@pytest.mark.parametrize("kind", sorted(KINDS))
@pytest.mark.parametrize("axis", ["z", "y", "x"])
def test_zoomed_out_slices_are_the_coarser_levels_voxels(small_zarr_build, folder, kind, axis):
    root = zarr.open_group(small_zarr_build / "stack.ome.zarr", mode="r")
    group = root[GROUPS[kind]] if GROUPS[kind] else root
    level1 = group["1"][:]
    if kind == "colour":
        level1 = np.moveaxis(level1, 0, -1)
    factors = json.loads((small_zarr_build / "manifest.json").read_text())["zarr"]
    fz, fy, fx = factors["level_factors_zyx"][0]
    f = dict(zip("zyx", (fz, fy, fx), strict=True))
    shape = dict(zip("zyx", folder.grid.shape_zyx, strict=True))
    row_axis, col_axis = PLANE[axis]
    rows = range(1, shape[row_axis], 2 * f[row_axis])  # every second level-1 voxel or so
    cols = range(0, shape[col_axis], f[col_axis])
    index = shape[axis] // 2
    expected = _plane(
        level1,
        axis,
        index // f[axis],
        [r // f[row_axis] for r in rows],
        [c // f[col_axis] for c in cols],
    )
    assert np.array_equal(folder.stacks[kind].region(axis, index, rows, cols), expected)
    # with no chunk kept between reads, and columns not evenly spaced on the level (read
    # as their span, picked from after)
    uneven = range(0, shape[col_axis], f[col_axis] + 1)
    uncached = ZarrStack(
        small_zarr_build / "stack.ome.zarr" / GROUPS[kind],
        folder.grid.shape_zyx,
        samples=3 if kind == "colour" else 0,
        context=read_context(0),
    )
    assert np.array_equal(uncached.region(axis, index, rows, cols), expected)
    gaps = np.diff([c // f[col_axis] for c in uneven])
    assert len(set(gaps)) > 1 or f[col_axis] == 1  # uneven on the level where it can be
    assert np.array_equal(
        uncached.region(axis, index, rows, uneven),
        _plane(
            level1,
            axis,
            index // f[axis],
            [r // f[row_axis] for r in rows],
            [c // f[col_axis] for c in uneven],
        ),
    )


def test_every_slice_is_read_whole_through_a_cache_smaller_than_a_chunk(small_zarr_build, truth):
    shape = truth["layers"].shape
    stack = ZarrStack(small_zarr_build / "stack.ome.zarr/labels/layers", shape, samples=0,
                      context=read_context(1000))  # fmt: skip
    for index in [*range(0, shape[1], 7), 0]:
        got = stack.region("y", index, range(shape[0]), range(shape[2]))
        assert np.array_equal(got, truth["layers"][:, index])


def test_a_damaged_chunk_is_one_stack_error_naming_the_image(small_zarr_build, tmp_path, truth):
    copy = tmp_path / "store"
    shutil.copytree(small_zarr_build / "stack.ome.zarr/labels/layers", copy)
    shards = sorted(p for p in (copy / "0/c").rglob("*") if p.is_file())
    for shard in shards:
        data = bytearray(shard.read_bytes())
        data[: len(data) // 2] = bytes(len(data) // 2)  # the chunks' zstd frames zeroed
        shard.write_bytes(bytes(data))
    stack = ZarrStack(copy, truth["layers"].shape, samples=0)
    with pytest.raises(StackError, match=f"{copy}: level 0 cannot be read"):
        stack.pages(0, truth["layers"].shape[0])


def test_a_build_with_only_the_store_opens_and_reads_out_voxels(small_zarr_build, tmp_path, truth):
    folder = tmp_path / "build"
    shutil.copytree(small_zarr_build, folder)
    manifest = json.loads((folder / "manifest.json").read_text())
    for name in KINDS.values():
        (folder / name).unlink()
        del manifest["files"][name]
    (folder / "manifest.json").write_text(json.dumps(manifest))
    z, y, x = (n // 2 for n in truth["layers"].shape)
    with BuildFolder.open(folder) as opened:
        result = probe(opened, z, y, x)
    assert result["layer"]["index"] == truth["layers"][z, y, x]
    assert result["material"]["index"] == truth["materials"][z, y, x]
    with BuildFolder.open(small_zarr_build, source="tiff") as tiff:
        assert probe(tiff, z, y, x) == result


@pytest.mark.parametrize("source", ["zarr", "tiff"])
def test_whole_pages_in_blocks_are_the_tiff_pages(small_zarr_build, truth, source):
    with BuildFolder.open(small_zarr_build, source=source) as opened:
        for kind, stack in opened.stacks.items():
            n_z = truth[kind].shape[0]
            block = stack.page_block
            assert block == (64 if source == "zarr" else 1)
            pages = np.concatenate([stack.pages(z, min(n_z, z + 7)) for z in range(0, n_z, 7)])
            assert np.array_equal(pages, truth[kind]), kind


def test_the_overview_opens_on_the_same_slices_from_the_store_and_the_tiffs(
    small_zarr_build, monkeypatch
):
    found = []
    for source, pass_bytes in (("zarr", None), ("tiff", None), ("zarr", 1), ("tiff", 1)):
        if pass_bytes is not None:  # the pages in strips of one chunk's rows (or one row)
            monkeypatch.setattr(surface_module, "PASS_BYTES", pass_bytes)
        with BuildFolder.open(small_zarr_build, source=source) as opened:
            overview = Overview(opened)
            overview.start()
            assert overview.done.wait(120)
            overview.close()
            assert overview.error is None and overview.surface is not None
            found.append((overview.opening, overview.vivid, overview.surface.srgb.tobytes()))
    assert found[1:] == found[:1] * 3
