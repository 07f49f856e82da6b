"""Lazy slice regions of TIFF stacks against tifffile's whole-stack reads."""

from __future__ import annotations

import numpy as np
import pytest
import tifffile

from shellvox.viewer import StackError, TiffStack
from shellvox.voxel.grid import GridSpec
from shellvox.voxel.io import TiffStackWriter

SHAPE = (23, 37, 41)


def _volume(samples: int) -> np.ndarray:
    """Blobs of a few values (runs), a noisy shell (literals), like a voxel model."""
    rng = np.random.default_rng(samples)
    z, y, x = np.indices(SHAPE)
    radius = np.sqrt((z - 11) ** 2 + ((y - 18) / 1.5) ** 2 + ((x - 20) / 1.8) ** 2)
    layers = np.digitize(-radius, [-11, -9, -7]).astype(np.uint8)
    if not samples:
        return np.where(layers == 1, rng.integers(1, 6, SHAPE), layers).astype(np.uint8)
    colour = rng.integers(0, 256, (*SHAPE, samples)).astype(np.uint8)
    return np.where((layers == 1)[..., None], colour, 0).astype(np.uint8)


def _write_shellvox(path, volume, samples, level):
    grid = GridSpec((0.0, 0.0, 0.0), (0.04, 0.08, 0.03), SHAPE)
    with TiffStackWriter(path, grid, samples=samples, compression_level=level) as tiff:
        tiff.write_slab(volume[:10])
        tiff.write_slab(volume[10:])


def _write_strips(path, volume, samples, level):
    # several strips a page (tifffile's own zlib): the layout other writers use
    tifffile.imwrite(
        path, volume, compression="zlib", compressionargs={"level": level}, rowsperstrip=5,
        photometric="rgb" if samples else "minisblack",
    )  # fmt: skip


def _expected(volume, axis, index, rows, cols):
    plane = volume[(slice(None),) * "zyx".index(axis) + (index,)]
    return plane[np.ix_(list(rows), list(cols))]


REGIONS = [
    ("z", 0, range(0, 37), range(0, 41)),
    ("z", 12, range(3, 36, 4), range(1, 40, 3)),
    ("y", 18, range(0, 23), range(0, 41)),
    ("y", 36, range(2, 22, 2), range(5, 17, 5)),
    ("x", 20, range(0, 23), range(0, 37)),
    ("x", 0, range(22, 23), range(7, 30, 6)),
]


@pytest.mark.parametrize(
    ("write", "level"),
    [(_write_shellvox, None), (_write_shellvox, 1), (_write_shellvox, 9), (_write_strips, 1),
     (_write_strips, 9)],
    ids=["runs", "zlib-1", "zlib-9", "strips-1", "strips-9"],
)  # fmt: skip
@pytest.mark.parametrize("samples", [0, 3, 4])
def test_regions_match_tifffile(tmp_path, write, level, samples) -> None:
    volume = _volume(samples)
    path = tmp_path / "stack.tif"
    write(path, volume, samples, level)
    np.testing.assert_array_equal(tifffile.imread(path), volume)  # the writer is right
    with TiffStack(path, SHAPE, samples=samples) as stack:
        assert (stack.rows_per_strip == 5) == (write is _write_strips)
        for axis, index, rows, cols in REGIONS:
            got = stack.region(axis, index, rows, cols)
            np.testing.assert_array_equal(got, _expected(volume, axis, index, rows, cols))
        z, y, x = 11, 18, 20
        np.testing.assert_array_equal(stack.voxel(z, y, x), volume[z, y, x].reshape(-1))
        empty = stack.region("y", 3, range(5, 5), range(0, 41))
        assert empty.shape[:2] == (0, 41)
        with pytest.raises(IndexError, match="outside"):
            stack.region("x", 41, range(0, 23), range(0, 37))
        with pytest.raises(IndexError, match="rows"):
            stack.region("z", 0, range(0, 38), range(0, 41))


def test_many_pages_read_in_two_threads_match(tmp_path) -> None:
    # more streams than one thread takes: the region is read in two halves at once
    rng = np.random.default_rng(5)
    volume = (rng.random((300, 8, 9)) < 0.3).astype(np.uint8) * rng.integers(1, 9, (300, 8, 9))
    volume = volume.astype(np.uint8)
    grid = GridSpec((0.0, 0.0, 0.0), (0.04, 0.08, 0.03), volume.shape)
    with TiffStackWriter(tmp_path / "s.tif", grid) as tiff:
        tiff.write_slab(volume)
    with TiffStack(tmp_path / "s.tif", volume.shape, samples=0) as stack:
        np.testing.assert_array_equal(stack.region("x", 4, range(300), range(8)), volume[:, :, 4])
        np.testing.assert_array_equal(
            stack.region("y", 7, range(1, 300, 3), range(9)), volume[1::3, 7]
        )


@pytest.mark.parametrize(
    ("write", "message"),
    [
        (lambda p, v: tifffile.imwrite(p, v.astype(np.uint16), compression="zlib"), "not uint8"),
        (lambda p, v: tifffile.imwrite(p, v[:, :-1], compression="zlib"), "not uint8"),
        (lambda p, v: tifffile.imwrite(p, v[:5], compression="zlib"), "pages"),
        (lambda p, v: tifffile.imwrite(p, v, compression="lzma"), "not deflate"),
        (lambda p, v: tifffile.imwrite(p, v), "not deflate"),
        (lambda p, v: tifffile.imwrite(p, v, tile=(16, 16), compression="zlib"), "tiled"),
        (lambda p, v: tifffile.imwrite(p, v, compression="zlib", predictor=True), "predictor"),
        (lambda p, v: p.write_bytes(b"II*\0garbage"), "not a readable TIFF"),
    ],
)
def test_stacks_of_another_kind_are_refused(tmp_path, write, message) -> None:
    path = tmp_path / "bad.tif"
    write(path, _volume(0))
    with pytest.raises(StackError, match=message):
        TiffStack(path, SHAPE, samples=0)


def test_a_truncated_stack_is_refused(tmp_path) -> None:
    path = tmp_path / "s.tif"
    _write_shellvox(path, _volume(0), 0, None)
    data = path.read_bytes()
    for keep in (len(data) // 2, len(data) - 7, len(data) - 40, 300):  # pages, IFDs cut
        path.write_bytes(data[:keep])
        with pytest.raises(StackError):
            TiffStack(path, SHAPE, samples=0)


@pytest.mark.parametrize("damage", ["garbage", "too long", "too short"])
def test_a_damaged_strip_is_one_stack_error_on_every_axis(tmp_path, damage) -> None:
    import zlib

    path = tmp_path / "d.tif"
    _write_shellvox(path, _volume(0), 0, None)
    with TiffStack(path, SHAPE, samples=0) as stack:
        offset, count = int(stack.offsets[5, 0]), int(stack.counts[5, 0])
        expected = stack._strip_rows(0) * SHAPE[2]
    replacement = {
        "garbage": bytes(range(7, 7 + count % 200)) * (count // 200 + 1),
        "too long": zlib.compress(bytes(100 * expected)),  # would inflate 100 times over
        "too short": zlib.compress(bytes(expected // 2)),
    }[damage][:count]
    assert len(replacement) <= count
    data = bytearray(path.read_bytes())
    data[offset : offset + len(replacement)] = replacement
    path.write_bytes(bytes(data))
    for axis, index, rows, cols in (
        ("z", 5, range(SHAPE[1]), range(SHAPE[2])),
        ("y", 0, range(SHAPE[0]), range(SHAPE[2])),
        ("x", 3, range(SHAPE[0]), range(SHAPE[1])),
    ):
        with (
            TiffStack(path, SHAPE, samples=0) as stack,
            pytest.raises(StackError, match=f"{path}: page 5 "),
        ):
            stack.region(axis, index, rows, cols)


def test_the_cache_keeps_decoded_pages_within_its_budget(tmp_path) -> None:
    import threading

    from shellvox.viewer import StripCache

    volume = _volume(3)
    path = tmp_path / "c.tif"
    _write_shellvox(path, volume, 3, None)
    small = StripCache(budget_bytes=20_000)
    with TiffStack(path, SHAPE, samples=3, cache=small) as stack:
        for y in (3, 18, 30):  # every page decoded, the oldest dropped
            got = stack.region("y", y, range(23), range(41))
            np.testing.assert_array_equal(got, volume[:, y])
            assert 0 < small.used_bytes <= small.budget_bytes
    roomy = StripCache()
    with TiffStack(path, SHAPE, samples=3, cache=roomy) as stack:
        stack.warm(range(0, 23, 2), threading.Event())  # pages 0, 2, .. decoded ahead
        assert {key[1] for key in roomy._items} == set(range(0, 23, 2))
        np.testing.assert_array_equal(
            stack.region("x", 7, range(0, 23, 2), range(37)), volume[::2, :, 7]
        )
