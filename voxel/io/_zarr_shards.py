"""The store's array layout, and level-0 shards encoded with ``zarr`` where a slab is computed.

Every level's arrays (:func:`level_array`) are in shards of :data:`SHARD_ROWS` rows,
whatever the slabs. Where slabs hold whole shards (:func:`encoded_by_slabs`),
:class:`ShardEncoder` writes one slab's rows into in-memory arrays with the store's own
metadata (:func:`level_array`, as :class:`shellvox.voxel.io._zarr_writer.OmeZarrWriter` creates
them) and returns the shard files zarr made, which the writer then stores as they are:
the bytes are zarr's either way, so the store is the same wherever a slab is encoded.
:func:`to_planar` turns channels-last colour into the store's planar order.
"""

from __future__ import annotations

import threading
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import zarr
import zarr.registry
from numpy.typing import NDArray
from zarr.codecs import ZstdCodec
from zarr.core.buffer import cpu

from shellvox.voxel._compiled import kernel

#: Inner chunk ``(z, y, x)`` of every array (y and x at most the grid's): cubes, so a y or
#: x section through a tall build crosses a few dozen chunks along z, not one per slab
#: (zarr 3.1 reads a shard's chunks one by one, about 0.2 ms each: an x section of spot at
#: 100 mm on a J750 took 0.41 s in chunks of 8 x 256 x 256).
CHUNK_ZYX = (64, 64, 64)
#: Rows of a shard of every level (a shard holds the whole ``y, x`` extent of its rows).
SHARD_ROWS = CHUNK_ZYX[0]
#: zstd level of the chunks.
ZSTD_LEVEL = 1
#: What the bytes of a shard depend on beside the voxels (part of a run's key, so that
#: checkpointed shards of another layout are not reused).
STORE_LAYOUT = (
    f"zarr {zarr.__version__}, chunks {CHUNK_ZYX}, shards of {SHARD_ROWS} rows, zstd {ZSTD_LEVEL}"
)


class VoidTestedBuffer(cpu.NDBuffer):
    """zarr's CPU array buffer, with a one-pass test of an integer chunk against its fill value.

    With ``write_empty_chunks=False`` zarr tests every chunk it writes with
    ``NDBuffer.all_equal``, which calls ``np.array_equal(..., equal_nan=True)``; numpy 1.x
    answers that for integers by masking and copying the chunk: 2 ms for a 64^3 colour
    chunk, against 0.03 ms for one comparison (about a third of the store's writing time
    at 100 mm on a J750). The answer is the same, so the stored chunks and bytes are too.
    Registered with zarr, and used by :func:`write_solid` (zarr takes buffer classes by
    configuration only: sharding refuses a prototype given with the write).
    """

    def all_equal(self, other: Any, equal_nan: bool = True) -> bool:
        """Whether every element equals the scalar `other` (zarr's test of a void chunk)."""
        if other is not None and np.ndim(other) == 0 and self._data.dtype.kind in "biu":
            return not bool((self._data != other).any())
        return bool(super().all_equal(other, equal_nan))


zarr.registry.register_ndbuffer(VoidTestedBuffer)
#: zarr's configuration while the store's chunks are written (:class:`VoidTestedBuffer`).
_WRITE_CONFIG = {"ndbuffer": f"{VoidTestedBuffer.__module__}.{VoidTestedBuffer.__qualname__}"}
#: zarr's configuration is one for the process: writes that set it take turns.
_WRITE_LOCK = threading.Lock()


def level_array(group: Any, name: str, shape_zyx: Sequence[int], samples: int) -> Any:
    """Create one level's array: ``(C, Z, Y, X)`` (``samples > 0``) or ``(Z, Y, X)`` uint8."""
    n_z, n_y, n_x = (int(n) for n in shape_zyx)
    cy, cx = min(CHUNK_ZYX[1], n_y), min(CHUNK_ZYX[2], n_x)
    chunks = (CHUNK_ZYX[0], cy, cx)
    shards = (SHARD_ROWS, -(-n_y // cy) * cy, -(-n_x // cx) * cx)
    lead = (samples,) if samples else ()
    return group.create_array(
        name,
        shape=(*lead, n_z, n_y, n_x),
        chunks=(*lead, *chunks),
        shards=(*lead, *shards),
        dtype="uint8",
        fill_value=0,
        compressors=ZstdCodec(level=ZSTD_LEVEL),
        config={"write_empty_chunks": False},
        dimension_names=(*(("c",) if samples else ()), "z", "y", "x"),
    )


def encoded_by_slabs(slab_rows: int) -> bool:
    """Whether slabs of `slab_rows` rows hold whole shards (their workers then encode them).

    >>> encoded_by_slabs(128), encoded_by_slabs(8)
    (True, False)
    """
    return slab_rows % SHARD_ROWS == 0


def write_solid(array: Any, z0: int, rows: NDArray[np.uint8]) -> None:
    """Write `rows` (``(..., n, Y, X)``) from row `z0`: only the chunks' box around non-void.

    Chunks outside the box hold void only and would not be stored anyway; leaving them out
    spares zarr the work (the shard's bytes are the same).
    """
    solid: NDArray[np.bool_] = np.any(rows.reshape(-1, *rows.shape[-2:]), axis=0)
    ys, xs = np.nonzero(solid.any(axis=1))[0], np.nonzero(solid.any(axis=0))[0]
    if not len(ys):
        return
    cy, cx = array.chunks[-2:]
    y0, y1 = ys[0] // cy * cy, -(-(ys[-1] + 1) // cy) * cy
    x0, x1 = xs[0] // cx * cx, -(-(xs[-1] + 1) // cx) * cx
    lead = (slice(None),) * (rows.ndim - 3)
    box = (slice(y0, y1), slice(x0, x1))
    with _WRITE_LOCK, zarr.config.set(_WRITE_CONFIG):
        array[(*lead, slice(z0, z0 + rows.shape[-3]), *box)] = rows[(*lead, slice(None), *box)]


@kernel
def to_planar(
    colour: NDArray[np.uint8], out: NDArray[np.uint8]
) -> None:  # pragma: no cover - compiled
    """Copy ``(n, Y, X, C)`` colour into ``(C, n, Y, X)`` `out` (the store's order).

    Three channels: each row read once, into its planes together.
    """
    n_z, n_y, n_x, n_c = colour.shape
    for z in range(n_z):
        for y in range(n_y):
            source = colour[z, y]
            if n_c == 3:
                red = out[0, z, y]
                green = out[1, z, y]
                blue = out[2, z, y]
                for x in range(n_x):
                    red[x] = source[x, 0]
                    green[x] = source[x, 1]
                    blue[x] = source[x, 2]
            else:
                for c in range(n_c):
                    plane = out[c, z, y]
                    for x in range(n_x):
                        plane[x] = source[x, c]


@dataclass(frozen=True)
class ShardEncoder:
    """Encode a slab's level-0 shards as the store's writer would (see the module).

    Parameters
    ----------
    shape_zyx : (3,) int
        The grid.
    samples : int
        Colour channels (3 or 4).
    slab_rows : int
        Rows of a slab (a multiple of :data:`SHARD_ROWS`, :func:`encoded_by_slabs`).
    label_names : tuple of str
        The label images (``materials``, ``layers``).
    """

    shape_zyx: tuple[int, int, int]
    samples: int
    slab_rows: int
    label_names: tuple[str, ...]

    def __post_init__(self) -> None:
        if not encoded_by_slabs(self.slab_rows):
            raise ValueError(f"slab_rows must be a multiple of {SHARD_ROWS}, got {self.slab_rows}")

    def encode(
        self, z0: int, colour: NDArray[np.uint8], labels: Mapping[str, NDArray[np.uint8]]
    ) -> list[bytes]:
        """Return the slab's shard files as ``[key, data, key, data, ...]``.

        Parameters
        ----------
        z0 : int
            The slab's first row (a multiple of ``slab_rows``).
        colour : (Zs, Y, X, S) uint8
            At least ``samples`` channels.
        labels : mapping of str to (Zs, Y, X) uint8
            Every label image.

        Returns
        -------
        list of bytes
            Each key (UTF-8, relative to the store, e.g. ``labels/layers/0/c/3/0/0``)
            followed by its file's bytes, keys sorted; void shards are absent.
        """
        files: dict[str, Any] = {}
        root = zarr.create_group(zarr.storage.MemoryStore(files), zarr_format=3)
        planar = np.moveaxis(colour[..., : self.samples], -1, 0)
        write_solid(level_array(root, "0", self.shape_zyx, self.samples), z0, planar)
        for name in self.label_names:
            group = root.require_group(f"labels/{name}")
            array = level_array(group, "0", self.shape_zyx, 0)
            write_solid(array, z0, labels[name])
        out: list[bytes] = []
        for key in sorted(files):
            if "/c/" in f"/{key}":
                out += [key.encode(), files[key].to_bytes()]
        return out
