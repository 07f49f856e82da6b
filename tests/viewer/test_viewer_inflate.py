"""Random access into zlib streams against Python's zlib (an independent inflater)."""

from __future__ import annotations

import zlib

import numpy as np
import pytest

from pipeline.viewer import InflateError, pick_bytes
from voxel.io import zlib_compress


def _voxel_like(rng: np.random.Generator, n: int, period: int) -> bytes:
    """Runs of repeated pixels, noise, and repeats of earlier stretches (far matches)."""
    pixels = rng.integers(0, 256, (max(1, n // 40), period)).astype(np.uint8)
    runs = np.repeat(pixels, rng.integers(1, 400, len(pixels)), axis=0).reshape(-1)
    noise = rng.integers(0, 4, n // 3).astype(np.uint8) * 60
    gap = np.zeros(3000, np.uint8)
    data = np.concatenate([runs[:n], noise, runs[: n // 2], gap, noise[: n // 5]])
    return bytes(data)


def _fixed_codes(raw: bytes, period: int) -> bytes:
    compressor = zlib.compressobj(6, zlib.DEFLATED, 15, 9, zlib.Z_FIXED)
    return compressor.compress(raw) + compressor.flush()


def _pick(packed: list[bytes], wanted: list[np.ndarray], size: int) -> np.ndarray:
    data = np.frombuffer(b"".join(packed), dtype=np.uint8)
    bounds = np.concatenate([[0], np.cumsum([len(p) for p in packed])])
    wanted_bounds = np.concatenate([[0], np.cumsum([len(w) for w in wanted])])
    flat = np.concatenate(wanted) if wanted else np.zeros(0, np.int64)
    return pick_bytes(data, bounds, flat, wanted_bounds, max_inflated=size)


@pytest.mark.parametrize(
    "encode",
    [
        pytest.param(lambda raw, p: zlib.compress(raw, 0), id="stored"),
        pytest.param(lambda raw, p: zlib.compress(raw, 1), id="zlib-1"),
        pytest.param(lambda raw, p: zlib.compress(raw, 6), id="zlib-6"),
        pytest.param(lambda raw, p: zlib.compress(raw, 9), id="zlib-9"),
        pytest.param(_fixed_codes, id="fixed-codes"),
        pytest.param(lambda raw, p: zlib_compress(raw, p), id="shellvox-runs"),
    ],
)
@pytest.mark.parametrize("period", [1, 3, 4])
def test_bytes_at_random_positions_match_zlib(encode, period: int) -> None:
    rng = np.random.default_rng(period)
    raws = [_voxel_like(rng, int(n), period) for n in rng.integers(1, 60_000, 6)]
    raws.append(b"x")
    packed = [encode(raw, period) for raw in raws]
    for raw, stream in zip(raws, packed, strict=True):
        assert zlib.decompress(stream) == raw
    wanted = [rng.integers(0, len(raw), 3000) for raw in raws]
    wanted[0] = np.sort(wanted[0])  # ascending (the fast case) and any order
    wanted[1] = np.arange(len(raws[1]))  # every byte
    got = _pick(packed, wanted, max(len(r) for r in raws))
    expected = np.concatenate(
        [np.frombuffer(r, np.uint8)[w] for r, w in zip(raws, wanted, strict=True)]
    )
    np.testing.assert_array_equal(got, expected)


def test_streams_with_nothing_wanted_are_skipped() -> None:
    packed = [zlib.compress(b"abc" * 100), b"not zlib at all", zlib.compress(b"z" * 50)]
    got = _pick(packed, [np.array([5]), np.zeros(0, np.int64), np.array([49])], 300)
    assert got.tolist() == [ord("c"), ord("z")]


@pytest.mark.parametrize(
    ("stream", "wanted", "message"),
    [
        (b"\x00\x01abc", 0, "not a zlib stream"),
        (zlib.compress(bytes(range(256)) * 40)[:-300], 5000, "ends early"),
        (zlib.compress(b"abc" * 10), 30, "past the stream's end"),
        (zlib.compress(bytes(100_000)), 0, "more bytes than expected"),
    ],
)
def test_invalid_streams_are_refused(stream: bytes, wanted: int, message: str) -> None:
    with pytest.raises(InflateError, match=message):
        _pick([stream], [np.array([wanted])], 20_000)


def test_a_corrupted_stream_never_hangs_or_crashes() -> None:
    rng = np.random.default_rng(7)
    raw = _voxel_like(rng, 20_000, 3)
    stream = bytearray(zlib.compress(raw, 6))
    for _ in range(200):
        broken = bytearray(stream)
        for position in rng.integers(2, len(broken), 3):
            broken[position] ^= int(rng.integers(1, 256))
        try:
            got = _pick([bytes(broken)], [np.arange(0, len(raw), 7)], 2 * len(raw))
        except InflateError:
            continue
        assert got.shape == (len(range(0, len(raw), 7)),)  # valid by chance: any bytes
