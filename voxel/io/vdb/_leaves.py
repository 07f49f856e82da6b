"""Leaves of OpenVDB grids encoded as OpenVDB 10 writes them, and the spool that holds them.

:class:`GridSpool` takes one grid's 8^3 leaves and tiles as they come, slab by slab: each
leaf is encoded as ``LeafNode::writeBuffers`` stores it (value mask, then its active values
only, zlib-compressed by ``io::writeCompressedValues`` / ``io::zipToStream`` with
``COMPRESS_ACTIVE_MASK | COMPRESS_ZIP``) and appended to a spool file; tiles and the
leaves' places stay in memory until :func:`shellvox.voxel.io.vdb._format.write_file` assembles the
tree.
"""

from __future__ import annotations

import io
import itertools
import struct
from dataclasses import dataclass, field
from typing import BinaryIO

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel._compiled import kernel
from shellvox.voxel.io._compression import compress
from shellvox.voxel.io._deflate import compress_segments

#: io::writeCompressedValues metadata: inactive values are all the background; inactive
#: values are +-background, chosen by a selection mask (on: +background).
NO_MASK_OR_INACTIVE_VALS = 0
MASK_AND_NO_INACTIVE_VALS = 3
LEAF = 8  # leaf edge, voxels (log2 3)
L1 = 128  # 16 leaves (log2 4)
L2 = 4096  # 32 level-1 nodes (log2 5)
#: Spooled bytes gathered at a time when copying leaf buffers in tree order (the byte
#: index of a batch takes 16 times this).
COPY_BYTES = 1 << 22


@dataclass
class GridSpool:
    """One grid being written: leaf buffers spooled to `stream`, tiles kept in memory."""

    name: str
    value_type: str  # "float" or "vec3s"
    grid_class: str  # "fog volume", "level set", "unknown"
    background: float
    stream: BinaryIO
    size: int = 0
    leaf_origin: list[NDArray[np.int32]] = field(default_factory=list)
    leaf_offset: list[NDArray[np.int64]] = field(default_factory=list)
    leaf_length: list[NDArray[np.int64]] = field(default_factory=list)
    tile_origin: list[NDArray[np.int32]] = field(default_factory=list)
    tile_value: list[NDArray[np.float32]] = field(default_factory=list)
    tile_active: list[NDArray[np.bool_]] = field(default_factory=list)
    active_voxels: int = 0
    #: (x, y, z) index bounds of the active voxels (OpenVDB's empty box until one comes).
    bbox_min: NDArray[np.int64] = field(default_factory=lambda: np.full(3, 2**31 - 1))
    bbox_max: NDArray[np.int64] = field(default_factory=lambda: np.full(3, -(2**31)))

    def extend(self, low: NDArray[np.int64], high: NDArray[np.int64]) -> None:
        """Grow the active bounding box by boxes ``(n, 3)`` (inclusive corners)."""
        if len(low):
            self.bbox_min = np.minimum(self.bbox_min, low.min(axis=0))
            self.bbox_max = np.maximum(self.bbox_max, high.max(axis=0))

    def absorb(self, other: GridSpool) -> None:
        """Append the leaves and tiles of `other` (an in-memory spool of later rows)."""
        data = other.stream.getvalue() if isinstance(other.stream, io.BytesIO) else b""
        if len(data) != other.size:
            raise ValueError(f"{other.name}: spool of {other.size} bytes holds {len(data)}")
        self.stream.write(data)
        shift = self.size
        self.size += other.size
        self.leaf_origin += other.leaf_origin
        self.leaf_offset += [offset + shift for offset in other.leaf_offset]
        self.leaf_length += other.leaf_length
        self.tile_origin += other.tile_origin
        self.tile_value += other.tile_value
        self.tile_active += other.tile_active
        self.active_voxels += other.active_voxels
        self.bbox_min = np.minimum(self.bbox_min, other.bbox_min)
        self.bbox_max = np.maximum(self.bbox_max, other.bbox_max)

    @property
    def channels(self) -> int:
        """Values per voxel: 3 for Vec3s, 1 for float."""
        return 3 if self.value_type == "vec3s" else 1

    def add_tiles(
        self, origin: NDArray[np.int32], value: NDArray[np.float32], active: bool
    ) -> None:
        """Record 8^3 blocks at `origin` ``(n, 3)`` as tiles of their parent node."""
        if len(origin) == 0:
            return
        self.tile_origin.append(origin)
        self.tile_value.append(np.asarray(value, dtype=np.float32))
        self.tile_active.append(np.full(len(origin), active))
        if active:
            self.active_voxels += len(origin) * LEAF**3
            self.extend(origin.astype(np.int64), origin.astype(np.int64) + LEAF - 1)

    def add_leaves(
        self,
        origin: NDArray[np.int32],
        values: NDArray[np.float32],
        active: NDArray[np.bool_],
        inside: NDArray[np.bool_] | None,
        level: int | None,
        runs: bool = False,
    ) -> None:
        """Encode leaves as LeafNode::writeBuffers does and append them to the spool.

        Parameters
        ----------
        origin : (n, 3) int32
        values : (n, 512[, 3]) float32
        active : (n, 512) bool
        inside : (n, 512) bool, optional
            Level sets: where inactive values are -background.
        level : int or None
            Of the values: None, the fast setting (:mod:`shellvox.voxel.io._compression`); zlib's
            level; 0: stored raw.
        runs : bool
            Values are runs of equal numbers (density, layer): the compiled run encoder
            packs them in one call (about a quarter of zlib-ng's time per leaf, 2.6 times
            its bytes); otherwise zlib-ng per leaf.
        """
        if len(origin) == 0:
            return
        counts = active.sum(axis=1)
        masks = np.packbits(active, axis=1, bitorder="little")  # NodeMask<3>::save
        head = [masks, np.full((len(masks), 1), NO_MASK_OR_INACTIVE_VALS, np.uint8)]
        if inside is not None:
            # Inactive values are +background outside (selection on), -background inside.
            head[1][:] = MASK_AND_NO_INACTIVE_VALS
            head.append(np.packbits(~inside, axis=1, bitorder="little"))
        head_bytes = np.concatenate(head, axis=1)
        bounds = np.concatenate([[0], np.cumsum(counts.astype(np.int64) * 4 * self.channels)])
        if runs and level != 0:
            raw = np.ascontiguousarray(values[active], dtype="<f4").reshape(-1).view(np.uint8)
            body, body_lengths = _zipped_all(raw, bounds, level)
        else:
            # io::zipToStream per leaf with zlib-ng: colours and halftoned materials
            # need matches at any distance.
            packed = np.ascontiguousarray(values[active], dtype="<f4").tobytes()
            bodies = [zipped(packed[a:b], level) for a, b in itertools.pairwise(bounds)]
            body_lengths = np.fromiter((len(b) for b in bodies), np.int64, len(bodies))
            body = np.frombuffer(b"".join(bodies), np.uint8)
        record = _interleave(head_bytes, body, body_lengths)
        lengths = head_bytes.shape[1] + body_lengths
        offsets = self.size + np.concatenate([[0], np.cumsum(lengths)[:-1]])
        self.stream.write(record.tobytes())
        self.size += int(lengths.sum())
        self.leaf_origin.append(origin)
        self.leaf_offset.append(offsets.astype(np.int64))
        self.leaf_length.append(lengths)
        self.active_voxels += int(counts.sum())
        if counts.any():
            low, high = _active_box(origin, np.ascontiguousarray(active))
            self.extend(low[None], high[None])


@kernel
def _active_box(
    origin: NDArray[np.int32], active: NDArray[np.bool_]
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Return the inclusive ``(x, y, z)`` index box of the active voxels of leaves.

    `origin` is ``(n, 3)``; ``active (n, 512)`` in voxel order ``x << 6 | y << 3 | z``.
    """
    low = np.full(3, 2**62, np.int64)
    high = np.full(3, -(2**62), np.int64)
    for n in range(active.shape[0]):
        for offset in range(LEAF**3):
            if active[n, offset]:
                local = (offset >> 6, (offset >> 3) & 7, offset & 7)
                for a in range(3):
                    at = np.int64(origin[n, a]) + local[a]
                    low[a] = min(low[a], at)
                    high[a] = max(high[a], at)
    return low, high


def zipped(raw: bytes, level: int | None) -> bytes:
    """Return ``raw`` as io::zipToStream writes it: int64 size, then zlib data or raw bytes.

    A negative (or zero) size marks raw bytes, used when compression does not make them
    smaller and for ``level`` 0 (None: the fast setting of :mod:`shellvox.voxel.io._compression`).
    """
    if raw and level != 0:
        packed = compress(raw, level)
        if len(packed) < len(raw):
            return struct.pack("<q", len(packed)) + packed
    return struct.pack("<q", -len(raw)) + raw


def _zipped_all(
    raw: NDArray[np.uint8], bounds: NDArray[np.int64], level: int | None
) -> tuple[NDArray[np.uint8], NDArray[np.int64]]:
    """Each leaf's values as io::zipToStream writes them, back to back, and their lengths.

    int64 size, then zlib data (:func:`shellvox.voxel.io._deflate.compress_segments`, runs of equal
    float32 values found 4 bytes back); a negative (or zero) size marks raw bytes, used
    when compression does not make them smaller and for ``level`` 0.
    """
    sizes = np.diff(bounds)
    if level != 0:
        packed, packed_lengths = compress_segments(raw, bounds, period=4)
    else:
        packed, packed_lengths = np.zeros(0, np.uint8), np.zeros(len(sizes), np.int64)
    use = (packed_lengths < sizes) & (sizes > 0) & (level != 0)
    lengths = 8 + np.where(use, packed_lengths, sizes)
    prefix = np.where(use, packed_lengths, -sizes).astype("<i8").view(np.uint8).reshape(-1, 8)
    starts = np.concatenate([[0], np.cumsum(lengths)[:-1]]).astype(np.int64)
    packed_starts = np.concatenate([[0], np.cumsum(packed_lengths)[:-1]]).astype(np.int64)
    body = np.empty(int(lengths.sum()), dtype=np.uint8)
    _assemble(raw, bounds, packed, packed_starts, packed_lengths, use, prefix, starts, body)
    return body, lengths


@kernel
def _assemble(
    raw: NDArray[np.uint8],
    bounds: NDArray[np.int64],
    packed: NDArray[np.uint8],
    packed_starts: NDArray[np.int64],
    packed_lengths: NDArray[np.int64],
    use: NDArray[np.bool_],
    prefix: NDArray[np.uint8],
    starts: NDArray[np.int64],
    body: NDArray[np.uint8],
) -> None:
    """Copy each leaf's size prefix and its packed or raw bytes to ``body``."""
    for n in range(len(starts)):
        at = starts[n]
        for k in range(8):
            body[at + k] = prefix[n, k]
        at += 8
        if use[n]:
            first, count, source = packed_starts[n], packed_lengths[n], packed
        else:
            first, count, source = bounds[n], bounds[n + 1] - bounds[n], raw
        for k in range(count):
            body[at + k] = source[first + k]


def _interleave(
    head: NDArray[np.uint8], body: NDArray[np.uint8], body_lengths: NDArray[np.int64]
) -> NDArray[np.uint8]:
    """Return the records ``head[i] + body_i`` back to back (``body`` holds them in order)."""
    n, h = head.shape
    lengths = h + body_lengths
    starts = np.concatenate([[0], np.cumsum(lengths)[:-1]]).astype(np.int64)
    record = np.empty(int(lengths.sum()), dtype=np.uint8)
    heads = np.arange(n, dtype=np.int64) * h
    copy_records(np.ascontiguousarray(head).reshape(-1), heads, np.full(n, h), record, starts)
    body_starts = np.concatenate([[0], np.cumsum(body_lengths)[:-1]]).astype(np.int64)
    copy_records(body, body_starts, body_lengths.astype(np.int64), record, starts + h)
    return record


@kernel
def copy_records(
    source: NDArray[np.uint8],
    source_starts: NDArray[np.int64],
    lengths: NDArray[np.int64],
    out: NDArray[np.uint8],
    out_starts: NDArray[np.int64],
) -> None:
    """Copy ``source[source_starts[i]:][:lengths[i]]`` to ``out[out_starts[i]:]`` for each i."""
    for i in range(len(lengths)):
        a, b, n = source_starts[i], out_starts[i], lengths[i]
        out[b : b + n] = source[a : a + n]
