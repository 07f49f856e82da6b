"""OpenVDB's file format 224, written without OpenVDB: the file, each grid and its tree.

Used by :mod:`shellvox.voxel.io.vdb._writer` to stream ``volume.vdb``: leaves are encoded as
``LeafNode::writeBuffers`` stores them and appended to a spool file per grid
(:class:`shellvox.voxel.io.vdb._leaves.GridSpool`); :func:`write_file` then writes the header, each
grid's metadata and transform, the topology assembled from the leaf and tile lists (root,
4096^3 and 128^3 internal nodes, leaf masks) and the spooled buffers in OpenVDB's
depth-first order.

The bytes follow OpenVDB 10.0.1's ``io::Archive::write``, ``RootNode`` /
``InternalNode`` / ``LeafNode`` ``writeTopology`` and ``writeBuffers``,
``io::writeCompressedValues`` and ``io::zipToStream``, with ``COMPRESS_ACTIVE_MASK |
COMPRESS_ZIP``: a leaf stores its active values only (inactive ones are the background,
or for the level set plus or minus it, as selected by a mask), zlib-compressed. Files are
read by OpenVDB 10 and later; the tests read them back with OpenVDB's own reader.
"""

from __future__ import annotations

import hashlib
import struct
import uuid
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel.grid import GridSpec
from shellvox.voxel.io.vdb._leaves import (
    COPY_BYTES,
    L1,
    L2,
    LEAF,
    MASK_AND_NO_INACTIVE_VALS,
    NO_MASK_OR_INACTIVE_VALS,
    GridSpool,
    copy_records,
    zipped,
)

_MAGIC = 0x56444220
_FILE_VERSION = 224
_LIBRARY_VERSION = (10, 0)
_COMPRESS_ZIP = 0x1
_COMPRESS_ACTIVE_MASK = 0x2


def write_file(
    path: Path, spools: list[GridSpool], grid: GridSpec, metadata: dict[str, str]
) -> None:
    """Write the grids of `spools` to `path` (io::Archive::write, file format 224).

    Parameters
    ----------
    path : Path
    spools : list of GridSpool
        Their streams must still be open (the leaf buffers are copied from them).
    grid : GridSpec
        Gives the transform (voxel size and origin).
    metadata : dict of str to str
        Added to every grid's metadata.
    """
    with open(path, "w+b") as out:
        out.write(struct.pack("<qIIIb", _MAGIC, _FILE_VERSION, *_LIBRARY_VERSION, 1))
        uuid_at = out.tell()
        out.write(b"0" * 36)  # the file's UUID, written last
        out.write(struct.pack("<I", 0))  # no file-level metadata
        out.write(struct.pack("<i", len(spools)))
        for spool in spools:
            _write_grid(out, spool, grid, metadata)
        out.flush()
        file_uuid = content_uuid(out, uuid_at + 36)
        out.seek(uuid_at)
        out.write(str(file_uuid).encode("ascii"))  # 36 characters


def content_uuid(stream: IO[bytes], start: int) -> uuid.UUID:
    """Return the UUID of a file's bytes from `start` on (a name-based UUID, version 5).

    OpenVDB's writer gives every file a random UUID; readers use it only to tell files
    apart. Derived from the content, equal builds write equal files, and a file that
    differs gets another UUID.
    """
    hasher = hashlib.sha256()
    stream.seek(start)
    while block := stream.read(1 << 24):
        hasher.update(block)
    return uuid.UUID(bytes=hasher.digest()[:16], version=5)


def _write_grid(out: IO[bytes], spool: GridSpool, grid: GridSpec, metadata: dict[str, str]) -> None:
    """Archive::writeGrid: descriptor, compression, metadata, transform, tree."""
    type_name = "Tree_float_5_4_3" if spool.channels == 1 else "Tree_vec3s_5_4_3"
    for text in (spool.name, type_name, ""):  # GridDescriptor::writeHeader
        _string(out, text)
    positions_at = out.tell()
    out.write(struct.pack("<qqq", 0, 0, 0))
    grid_pos = out.tell()
    out.write(struct.pack("<I", _COMPRESS_ZIP | _COMPRESS_ACTIVE_MASK))
    meta: list[tuple[str, str, bytes]] = [
        ("class", "string", spool.grid_class.encode()),
        ("file_compression", "string", b"zip + active values"),
        ("is_local_space", "bool", b"\x00"),
        ("is_saved_as_half_float", "bool", b"\x00"),
        ("name", "string", spool.name.encode()),
        # GridBase::addStatsMetadata, as OpenVDB's writer adds (readers take the
        # bounds from here without loading the tree).
        ("file_bbox_min", "vec3i", struct.pack("<3i", *spool.bbox_min)),
        ("file_bbox_max", "vec3i", struct.pack("<3i", *spool.bbox_max)),
        ("file_voxel_count", "int64", struct.pack("<q", spool.active_voxels)),
    ]
    if spool.channels == 3:
        meta.append(("vector_type", "string", b"invariant"))
    meta += [(key, "string", value.encode()) for key, value in sorted(metadata.items())]
    out.write(struct.pack("<I", len(meta)))
    for key, type_name_, value in meta:
        _string(out, key)
        _string(out, type_name_)
        out.write(struct.pack("<I", len(value)))
        out.write(value)
    # Transform: a ScaleTranslateMap, as OpenVDB's createLinearTransform(); scale();
    # translate() gives. ScaleTranslateMap::write stores the translation, the scale,
    # the voxel size and the derived 1 / s, 1 / s^2 and 1 / 2s (Vec3d each).
    _string(out, "ScaleTranslateMap")
    scale = np.asarray(grid.voxel_mm, dtype=np.float64)
    for vec in (
        np.asarray(grid.origin_mm, np.float64),
        scale,
        scale,
        1.0 / scale,
        1.0 / scale**2,
        0.5 / scale,
    ):
        out.write(struct.pack("<3d", *vec))
    tree = _Tree.assemble(spool)
    out.write(struct.pack("<i", 1))  # one buffer per leaf
    tree.write_topology(out, spool)
    block_pos = out.tell()
    tree.write_buffers(out, spool)
    end_pos = out.tell()
    out.seek(positions_at)
    out.write(struct.pack("<qqq", grid_pos, block_pos, end_pos))
    out.seek(end_pos)


def _string(out: IO[bytes], text: str) -> None:
    data = text.encode()
    out.write(struct.pack("<I", len(data)))
    out.write(data)


@dataclass
class _Tree:
    """Leaves and tiles of one grid in OpenVDB's tree order."""

    origin: NDArray[np.int32]  # (L, 3) sorted leaves
    offset: NDArray[np.int64]
    length: NDArray[np.int64]
    tile_origin: NDArray[np.int32]  # (T, 3)
    tile_value: NDArray[np.float32]
    tile_active: NDArray[np.bool_]

    @classmethod
    def assemble(cls, spool: GridSpool) -> _Tree:
        def cat(parts: list[NDArray[Any]], shape: tuple[int, ...], dtype: Any) -> NDArray[Any]:
            return np.concatenate(parts) if parts else np.zeros(shape, dtype)

        origin = cat(spool.leaf_origin, (0, 3), np.int32)
        order = _tree_order(origin)
        return cls(
            origin[order],
            cat(spool.leaf_offset, (0,), np.int64)[order],
            cat(spool.leaf_length, (0,), np.int64)[order],
            cat(spool.tile_origin, (0, 3), np.int32),
            cat(spool.tile_value, (0,), np.float32),
            cat(spool.tile_active, (0,), np.bool_),
        )

    def write_topology(self, out: IO[bytes], spool: GridSpool) -> None:
        """RootNode::writeTopology and the internal nodes' and leaves' topology."""
        value_format = "<f" if spool.channels == 1 else "<3f"
        bg = (spool.background,) * spool.channels
        out.write(struct.pack(value_format, *bg))
        l1_leaf = _key(self.origin, L1)
        l1_tile = _key(self.tile_origin, L1)
        nodes1 = _unique_origins(np.concatenate([l1_leaf, l1_tile]))
        nodes1 = nodes1[_tree_order(nodes1)]
        nodes2 = _key(nodes1, L2)
        roots = _unique_origins(nodes2)
        roots = roots[np.lexsort(roots.T[::-1])]  # root table: Coord order (x, y, z)
        out.write(struct.pack("<ii", 0, len(roots)))  # no root tiles
        spool.stream.flush()
        data = np.memmap(spool.stream.name, dtype=np.uint8, mode="r") if spool.size else None
        leaf_start = np.searchsorted(_order_key(self.origin), _order_key(nodes1), side="left")
        leaf_stop = np.searchsorted(
            _order_key(self.origin), _order_key(nodes1 + L1 - 1), side="right"
        )
        tiles_by_node = _group(l1_tile, nodes1)
        for root in roots:
            out.write(struct.pack("<3i", *root))
            in_root = np.flatnonzero(np.all(nodes2 == root, axis=1))
            child = np.zeros(32**3, dtype=bool)
            child[_local_offset(nodes1[in_root], L1, 5)] = True
            out.write(np.packbits(child, bitorder="little").tobytes())
            out.write(np.packbits(np.zeros_like(child), bitorder="little").tobytes())
            out.write(bytes([NO_MASK_OR_INACTIVE_VALS]))  # no tiles: no values
            out.write(zipped(b"", 0))
            for n in in_root:
                leaves = slice(leaf_start[n], leaf_stop[n])
                self._write_node1(out, spool, nodes1[n], leaves, tiles_by_node.get(int(n)))
                if data is not None:  # LeafNode::writeTopology: the value masks
                    out.write(np.asarray(data[self.offset[leaves, None] + np.arange(64)]).tobytes())

    def _write_node1(
        self,
        out: IO[bytes],
        spool: GridSpool,
        node: NDArray[np.int32],
        leaves: slice,
        tiles: NDArray[np.int64] | None,
    ) -> None:
        """InternalNode<Leaf, 4>::writeTopology without its children's part."""
        child = np.zeros(16**3, dtype=bool)
        child[_local_offset(self.origin[leaves], LEAF, 4)] = True
        value_on = np.zeros(16**3, dtype=bool)
        outside = np.ones(16**3, dtype=bool)
        values = np.zeros((16**3, spool.channels), np.float32)
        if tiles is not None:
            where = _local_offset(self.tile_origin[tiles], LEAF, 4)
            value_on[where] = self.tile_active[tiles]
            outside[where[~self.tile_active[tiles]]] = False
            values[where, :] = self.tile_value[tiles, None]
        out.write(np.packbits(child, bitorder="little").tobytes())
        out.write(np.packbits(value_on, bitorder="little").tobytes())
        if spool.grid_class == "level set":
            out.write(bytes([MASK_AND_NO_INACTIVE_VALS]))
            out.write(np.packbits(outside, bitorder="little").tobytes())
        else:
            out.write(bytes([NO_MASK_OR_INACTIVE_VALS]))
        out.write(zipped(np.ascontiguousarray(values[value_on], dtype="<f4").tobytes(), 6))

    def write_buffers(self, out: IO[bytes], spool: GridSpool) -> None:
        """Tree::writeBuffers: every leaf's buffer, in tree order, from the spool."""
        if len(self.offset) == 0:
            return
        data = np.asarray(np.memmap(spool.stream.name, dtype=np.uint8, mode="r"))
        ends = np.cumsum(self.length)
        start = 0
        while start < len(self.offset):
            stop = int(
                np.searchsorted(ends, ends[start] - self.length[start] + COPY_BYTES, side="right")
            )
            stop = max(stop, start + 1)
            off, length = self.offset[start:stop], self.length[start:stop]
            before = np.concatenate([[0], np.cumsum(length)[:-1]]).astype(np.int64)
            chunk = np.empty(int(length.sum()), dtype=np.uint8)
            copy_records(data, off, length, chunk, before)
            out.write(chunk.data)
            start = stop


def _unique_origins(origin: NDArray[np.int32]) -> NDArray[np.int32]:
    """``np.unique(origin, axis=0)`` of ``(n, 3)`` coordinates in [0, 2**20), one key each."""
    o = origin.astype(np.int64)
    keys = np.unique((o[:, 0] << 40) | (o[:, 1] << 20) | o[:, 2])
    mask = (1 << 20) - 1
    unique: NDArray[np.int32] = np.stack(
        [keys >> 40, (keys >> 20) & mask, keys & mask], axis=1
    ).astype(np.int32)
    return unique


def _key(origin: NDArray[np.int32], size: int) -> NDArray[np.int32]:
    """Origins of the nodes of edge `size` holding the given origins."""
    return (origin // size) * size


def _local_offset(origin: NDArray[np.int32], child: int, log2: int) -> NDArray[np.int64]:
    """Offsets of children (edge `child`) in their parent of ``2**log2`` children per axis."""
    local = (origin.astype(np.int64) // child) % (1 << log2)
    return (local[:, 0] << (2 * log2)) | (local[:, 1] << log2) | local[:, 2]


def _order_key(origin: NDArray[np.int32]) -> NDArray[np.int64]:
    """Return a sort key of OpenVDB's depth-first order (coordinates in [0, 2**20))."""
    o = origin.astype(np.int64)
    top = ((o[:, 0] // L2) << 16) | ((o[:, 1] // L2) << 8) | (o[:, 2] // L2)
    return (top << 27) | (_local_offset(origin, L1, 5) << 12) | _local_offset(origin, LEAF, 4)


def _tree_order(origin: NDArray[np.int32]) -> NDArray[np.int64]:
    if len(origin) and (origin.min() < 0 or origin.max() >= 1 << 20):
        raise ValueError("VDB index coordinates must lie in [0, 2**20)")
    return np.argsort(_order_key(origin), kind="stable")


def _group(keys: NDArray[np.int32], nodes: NDArray[np.int32]) -> dict[int, NDArray[np.int64]]:
    """Map node index -> indices of `keys` equal to that node's origin."""
    if len(keys) == 0:
        return {}
    node_key, key_key = _order_key(nodes), _order_key(keys)
    where = np.searchsorted(node_key, key_key)
    order = np.argsort(where, kind="stable")
    bounds = np.flatnonzero(np.diff(where[order])) + 1
    return {int(where[group[0]]): group for group in np.split(order, bounds)}
