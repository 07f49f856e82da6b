"""The store's levels: cubic chunks in 64-row shards, the same bytes however the slabs come.

Independent truth: the arrays read back with ``zarr`` alone, and each level's labels
against the mode of the level below's blocks computed with :func:`scipy.stats.mode`.
"""

from __future__ import annotations

import json
from pathlib import Path

import colour as colour_science
import numpy as np
import pytest
import zarr
from scipy import stats
from zarr.core.buffer import cpu

from shellvox.voxel.colour._srgb import DECODE_LUT_F32, linear_to_srgb
from shellvox.voxel.grid import GridSpec
from shellvox.voxel.io import LabelValue, OmeZarrWriter, downsample_labels
from shellvox.voxel.io import _zarr_shards as zarr_shards
from shellvox.voxel.io._pyramid import downsample_colour
from shellvox.voxel.io._zarr_shards import VoidTestedBuffer

#: A J750-like grid (voxel x, y, z mm): levels 1 and 2 span several 64-row shards.
GRID = GridSpec((0.0, 0.0, 0.0), (0.042, 0.085, 0.027), (300, 40, 70))
LABELS = {"layers": [LabelValue(v, (v, v, v, 255)) for v in range(4)]}


def _volume() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Colour ``(Z, Y, X, 3)``, colour-layer mask and layers ``(Z, Y, X)``: a ball."""
    z, y, x = np.indices(GRID.shape_zyx, dtype=np.float64)
    r = np.sqrt(((z - 150) / 140) ** 2 + ((y - 20) / 18) ** 2 + ((x - 35) / 30) ** 2)
    layers = np.select([r < 0.6, r < 0.8, r < 1.0], [3, 2, 1], 0).astype(np.uint8)
    rng = np.random.default_rng(4)
    colour = rng.integers(0, 256, (*GRID.shape_zyx, 3), dtype=np.uint8)
    colour[layers == 0] = 0
    return colour, layers == 1, layers


def _write(path: Path, slab_rows: int) -> Path:
    colour, coloured, layers = _volume()
    writer = OmeZarrWriter(path, GRID, samples=3, labels=LABELS)
    for z0 in range(0, GRID.shape_zyx[0], slab_rows):
        rows = slice(z0, z0 + slab_rows)
        writer.write_slab(colour[rows], coloured[rows], {"layers": layers[rows]})
    writer.close()
    return path


@pytest.fixture(scope="module")
def stores(tmp_path_factory):
    """The same volume in slabs of 7 rows and in one slab."""
    root = tmp_path_factory.mktemp("zarr_levels")
    return _write(root / "thin.ome.zarr", 7), _write(root / "whole.ome.zarr", GRID.shape_zyx[0])


def _mode(labels: np.ndarray, factors: tuple[int, int, int]) -> np.ndarray:
    """The most frequent value of every block (ties to the smallest), edge blocks padded
    with a value no block holds and left out of the count."""
    shape = [-(-n // f) * f for n, f in zip(labels.shape, factors, strict=True)]
    padded = np.full(shape, 255, np.uint8)
    padded[tuple(slice(0, n) for n in labels.shape)] = labels
    fz, fy, fx = factors
    blocks = padded.reshape(shape[0] // fz, fz, shape[1] // fy, fy, shape[2] // fx, fx)
    blocks = blocks.transpose(0, 2, 4, 1, 3, 5).reshape(*blocks.shape[::2], -1).astype(float)
    blocks[blocks == 255] = np.nan
    return stats.mode(blocks, axis=-1, nan_policy="omit").mode.astype(np.uint8)


def test_levels_are_cubic_chunks_in_64_row_shards(stores):
    thin, _ = stores
    root = zarr.open_group(thin, mode="r")
    n_levels = len(root.attrs["ome"]["multiscales"][0]["datasets"])
    assert n_levels >= 3
    for k in range(n_levels):
        for array in (root[str(k)], root[f"labels/layers/{k}"]):
            ny, nx = array.shape[-2:]
            assert array.chunks[-3:] == (64, min(64, ny), min(64, nx))
            assert array.shards is not None and array.shards[-3] == 64


def test_levels_are_the_same_bytes_however_the_slabs_come(stores):
    thin, whole = stores
    for k in range(3):
        for group in ("", "labels/layers/"):
            files = sorted(p.relative_to(thin) for p in (thin / f"{group}{k}").rglob("*"))
            assert len([f for f in files if "/c/" in f"/{f}"]) >= 2  # several shards
            for name in files:
                if (thin / name).is_file():
                    assert (thin / name).read_bytes() == (whole / name).read_bytes(), name


def test_each_level_holds_the_mode_of_the_level_below(stores):
    thin, _ = stores
    root = zarr.open_group(thin, mode="r")
    multiscale = root["labels/layers"].attrs["ome"]["multiscales"][0]
    scales = [d["coordinateTransformations"][0]["scale"] for d in multiscale["datasets"]]
    below = root["labels/layers/0"][:]
    assert np.array_equal(below, _volume()[2])
    for k in range(1, len(scales)):
        factors = tuple(round(a / b) for a, b in zip(scales[k], scales[k - 1], strict=True))
        level = root[f"labels/layers/{k}"][:]
        assert np.array_equal(level, _mode(below, factors)), k
        below = level
    meta = json.loads((thin / "labels/layers/1/zarr.json").read_text())
    assert meta["shape"][0] > 64  # level 1 crosses shards


@pytest.mark.parametrize("factors", [(2, 1, 2), (2, 1, 1), (2, 2, 2), (1, 3, 2), (3, 2, 4)])
def test_downsampled_labels_are_the_mode_of_every_block(factors):
    rng = np.random.default_rng(sum(factors))
    labels = rng.integers(0, 3, (9, 7, 13), dtype=np.uint8)  # many mixed blocks and ties
    labels[:, :3] = 2  # and uniform ones
    labels[4:, :, 6:] = 0
    assert np.array_equal(downsample_labels(labels, factors), _mode(labels, factors))


def _stored_inner_chunks(shard: bytes, n_chunks: int) -> np.ndarray:
    """Which inner chunks a shard stores: its index (at the end, before a CRC32C) holds an
    (offset, nbytes) uint64 pair per chunk, both 2**64 - 1 for a chunk not stored."""
    index = np.frombuffer(shard[-(16 * n_chunks + 4) : -4], dtype="<u8").reshape(-1, 2)
    return ~np.all(index == np.iinfo(np.uint64).max, axis=1)


def test_void_chunks_and_shards_are_not_stored(tmp_path):
    grid = GridSpec((0.0, 0.0, 0.0), (0.042, 0.085, 0.027), (200, 130, 70))
    layers = np.zeros(grid.shape_zyx, np.uint8)
    layers[70:90, 10:20, 66:69] = 2  # in shard 1 only; y chunk 0, x chunk 1
    colour = np.zeros((*grid.shape_zyx, 3), np.uint8)
    writer = OmeZarrWriter(tmp_path / "s.ome.zarr", grid, samples=3, labels=LABELS)
    for z0 in range(0, grid.shape_zyx[0], 16):
        rows = slice(z0, z0 + 16)
        writer.write_slab(colour[rows], layers[rows] == 1, {"layers": layers[rows]})
    writer.close()
    shards = sorted((tmp_path / "s.ome.zarr/labels/layers/0/c").rglob("*"))
    files = [p for p in shards if p.is_file()]
    assert [p.relative_to(tmp_path / "s.ome.zarr/labels/layers/0/c").parts for p in files] == [
        ("1", "0", "0")
    ]
    # the shard's 3 x 2 (y, x) chunks of 64: only (0, 1) holds solid voxels
    expected = np.zeros((1, 3, 2), bool)
    expected[0, 0, 1] = True
    assert np.array_equal(_stored_inner_chunks(files[0].read_bytes(), 6), expected.ravel())
    colour_files = (tmp_path / "s.ome.zarr/0").rglob("*")
    assert [p.name for p in colour_files if p.is_file()] == ["zarr.json"]  # colour all void
    read = zarr.open_group(tmp_path / "s.ome.zarr", mode="r")["labels/layers/0"][:]
    assert np.array_equal(read, layers)


def test_rgba_levels_hold_the_colour_and_the_linear_mean_of_it(tmp_path):
    colour, coloured, layers = _volume()
    alpha = np.random.default_rng(5).integers(0, 256, (*GRID.shape_zyx, 1), dtype=np.uint8)
    rgba = np.concatenate([colour, alpha], axis=-1)
    writer = OmeZarrWriter(tmp_path / "a.ome.zarr", GRID, samples=4, labels=LABELS)
    for z0 in range(0, GRID.shape_zyx[0], 10):
        rows = slice(z0, z0 + 10)
        writer.write_slab(rgba[rows], coloured[rows], {"layers": layers[rows]})
    writer.close()
    root = zarr.open_group(tmp_path / "a.ome.zarr", mode="r")
    assert np.array_equal(root["0"][:], np.moveaxis(rgba, -1, 0))
    scales = [
        d["coordinateTransformations"][0]["scale"]
        for d in root.attrs["ome"]["multiscales"][0]["datasets"]
    ]
    factors = tuple(round(a / b) for a, b in zip(scales[1][1:], scales[0][1:], strict=True))
    # the mean of the colour-layer voxels of each block: RGB in linear light, alpha as it is
    weight = coloured.astype(np.float64)
    n = _block_sum(weight, factors)
    linear = colour_science.cctf_decoding(colour / 255.0, function="sRGB")
    planes = [linear[..., c] for c in range(3)] + [alpha[..., 0] / 255.0]
    means = [np.divide(_block_sum(p * weight, factors), n, where=n > 0, out=np.zeros_like(n))
             for p in planes]  # fmt: skip
    codes = [colour_science.cctf_encoding(m, function="sRGB") for m in means[:3]] + means[3:]
    expected = np.where(n > 0, np.rint(np.stack(codes) * 255.0), 0)
    assert np.abs(root["1"][:].astype(int) - expected).max() <= 1


def _block_sum(values: np.ndarray, factors: tuple[int, ...]) -> np.ndarray:
    """Sum of every block (partial ones at the far edges) of a ``(Z, Y, X)`` array."""
    for axis, f in enumerate(factors):
        values = np.add.reduceat(values, np.arange(0, values.shape[axis], f), axis=axis)
    return values


@pytest.mark.parametrize("dtype", ["uint8", "uint16", "int32", "bool", "float32"])
def test_the_void_test_answers_as_zarrs_own(dtype):
    """:class:`VoidTestedBuffer.all_equal` against zarr's ``NDBuffer.all_equal``."""
    rng = np.random.default_rng(11)
    for case in range(40):
        chunk = np.zeros((3, 8, 8, 8), dtype=dtype)
        if case % 2:
            chunk.flat[rng.integers(chunk.size)] = 1
        fill = np.array(case % 3 == 0, dtype=dtype)[()] if dtype == "bool" else chunk.dtype.type(0)
        for other in (fill, None):
            fast = VoidTestedBuffer.from_numpy_array(chunk).all_equal(other)
            reference = cpu.NDBuffer.from_numpy_array(chunk).all_equal(other)
            assert fast == reference


def test_the_store_is_the_same_bytes_with_zarrs_own_void_test(tmp_path, monkeypatch):
    """Writing with zarr's own test of void chunks stores the same files, byte for byte."""
    calls = []
    own = VoidTestedBuffer.all_equal
    monkeypatch.setattr(VoidTestedBuffer, "all_equal", lambda *a: calls.append(1) or own(*a))
    fast = _write(tmp_path / "fast.ome.zarr", 64)
    assert calls  # the writes went through the one-pass test
    monkeypatch.setattr(VoidTestedBuffer, "all_equal", own)
    monkeypatch.setattr(zarr_shards, "_WRITE_CONFIG", {})
    plain = _write(tmp_path / "plain.ome.zarr", 64)
    files = sorted(p.relative_to(fast) for p in fast.rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(plain) for p in plain.rglob("*") if p.is_file())
    assert any("/c/" in f"/{f}" for f in map(str, files))
    for name in files:
        assert (fast / name).read_bytes() == (plain / name).read_bytes(), name


@pytest.mark.parametrize("channels", [3, 4])
def test_colour_means_are_the_float32_sums_encoded_as_linear_to_srgb(channels):
    """Every block's code, exactly: float32 sums in (z, y, x) order, then the encoding."""
    rng = np.random.default_rng(channels)
    colour = rng.integers(0, 256, (9, 7, 11, channels), dtype=np.uint8)
    weight = (rng.random((9, 7, 11)) * (rng.random((9, 7, 11)) < 0.6) * 5).astype(np.float32)
    factors = (2, 3, 4)
    codes, total = downsample_colour(colour, weight, factors)
    lut = DECODE_LUT_F32
    for oz, oy, ox in np.ndindex(total.shape):
        sums = np.zeros(channels, np.float32)
        t = np.float32(0)
        for z, y, x in np.ndindex(factors):
            z, y, x = oz * 2 + z, oy * 3 + y, ox * 4 + x
            if z >= 9 or y >= 7 or x >= 11 or weight[z, y, x] == 0:
                continue
            w = weight[z, y, x]
            t += w
            sums[:3] += w * lut[colour[z, y, x, :3]]
            sums[3:] += w * np.float32(colour[z, y, x, 3:] / 255.0)
        assert total[oz, oy, ox] == t
        if t == 0:
            assert not codes[oz, oy, ox].any()
            continue
        means = (sums / t).astype(np.float64)
        expected = np.concatenate([linear_to_srgb(means[:3]), np.clip(means[3:], 0.0, 1.0)])
        assert np.array_equal(codes[oz, oy, ox], np.rint(expected * 255.0).astype(np.uint8))
