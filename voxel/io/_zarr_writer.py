"""The stack as an OME-Zarr 0.5 store (Zarr v3), written slab by slab with ``zarr``.

``stack.ome.zarr/`` holds the colour image ``(c, z, y, x)`` uint8 (RGB or RGBA) at the
root and the label images ``labels/materials`` and ``labels/layers`` ``(z, y, x)`` uint8,
each as the levels ``0, 1, ...`` of a pyramid (:mod:`shellvox.voxel.io._pyramid`), with the
metadata of :mod:`shellvox.voxel.io._ome_metadata`.

Layout (:mod:`shellvox.voxel.io._zarr_shards`): every array is sharded, one shard file holding the
whole ``y, x`` extent of 64 z rows, in inner chunks of ``64 x 64 x 64`` voxels (z, y, x;
all channels together), each zstd-compressed. Inner chunks of void (all 0, the fill
value) are not stored, nor shards of void only (and zarr is handed only the box of chunks
around the solid voxels). Level 0's shards come encoded from the slab workers where the
slabs hold whole shards, else they are made here; the levels above 0 are made in the
writer thread as the slabs come. Each level fills its shard in buffers of its own
(colour and labels, 64 x 5 bytes per voxel of a level's row with RGB and two label
images) and keeps the rows the next level has not yet reduced (fewer than its z factor).
The bytes depend only on the voxels and the grid, never on the slabs or timing.

The store appears whole or not at all: it is written into a temporary folder beside it
(``.NAME.*.partial``) and renamed by :meth:`OmeZarrWriter.close`.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import zarr
from numpy.typing import NDArray

from shellvox.voxel.grid import GridSpec
from shellvox.voxel.io._ome_metadata import (
    LabelValue,
    image_attributes,
    label_attributes,
    level_transforms,
)
from shellvox.voxel.io._png_slices import _replace_folder
from shellvox.voxel.io._pyramid import Factors, downsample_colour, downsample_labels, level_factors
from shellvox.voxel.io._slab_thread import ClosingWriter, SlabThread
from shellvox.voxel.io._zarr_shards import SHARD_ROWS, level_array, to_planar, write_solid


@dataclass
class _Rows:
    """Consecutive z rows of one level.

    ``colour`` ``(n, Y, X, C)`` uint8, ``weight`` ``(n, Y, X)`` uint8 or float32 (the
    colour-layer voxels of level 0 each voxel stands for), ``labels`` ``(n, Y, X)`` uint8.
    """

    z: int
    colour: NDArray[np.uint8]
    weight: NDArray[Any]
    labels: dict[str, NDArray[np.uint8]] = field(default_factory=dict)

    def __len__(self) -> int:
        return int(self.weight.shape[0])

    def split(self, n: int) -> tuple[_Rows, _Rows | None]:
        """Return the first `n` rows and the rest (None: no rows, nor the slab they are of)."""
        head = _Rows(
            self.z, self.colour[:n], self.weight[:n], {k: v[:n] for k, v in self.labels.items()}
        )
        if n >= len(self):
            return head, None
        tail = _Rows(
            self.z + n, self.colour[n:], self.weight[n:], {k: v[n:] for k, v in self.labels.items()}
        )
        return head, tail

    def copy(self) -> _Rows:
        """Return the rows in arrays of their own."""
        return _Rows(
            self.z,
            self.colour.copy(),
            self.weight.copy(),
            {k: v.copy() for k, v in self.labels.items()},
        )

    @staticmethod
    def join(first: _Rows | None, second: _Rows) -> _Rows:
        """Return `first` followed by `second` (`first` may be None), copied once if both."""
        if first is None or len(first) == 0:
            return second
        return _Rows(
            first.z,
            np.concatenate([first.colour, second.colour]),
            np.concatenate([first.weight.astype(np.float32), second.weight.astype(np.float32)]),
            {k: np.concatenate([first.labels[k], second.labels[k]]) for k in first.labels},
        )


class _Level:
    """One level's arrays, the shard being filled, and the rows waiting to be reduced.

    The shard is filled in buffers of its own (colour ``(C, R, Y, X)`` as the store holds it,
    labels ``(R, Y, X)``, ``R`` the shard's rows), reused from shard to shard.
    """

    def __init__(self, arrays: dict[str, Any], factors: Factors | None) -> None:
        self.arrays = arrays  # "colour" and the label names -> zarr.Array
        self.factors = factors  # to the next level (None: the last)
        self._colour: NDArray[np.uint8] | None = None  # made when first filled
        self._labels: dict[str, NDArray[np.uint8]] = {}
        self._shard_z = 0  # first row of the shard being filled
        self._filled = 0  # its rows so far
        self.unreduced: _Rows | None = None

    def add(self, rows: _Rows, *, written: bool = False) -> _Rows | None:
        """Take rows (the next in z); write whole shards; return rows for the next level.

        `written`: the rows' shards are stored already (encoded where the slab was made;
        they start and end on shard boundaries, or at the grid's end). The rows may be
        views of memory reused once this returns: what is kept is copied.
        """
        if rows.z != self._shard_z + self._filled:
            raise ValueError(f"rows from z={rows.z}, expected {self._shard_z + self._filled}")
        if written:
            if rows.z % SHARD_ROWS:  # with the check above: no shard partly filled
                raise ValueError(f"encoded rows from z={rows.z} do not start a shard")
            self._shard_z = rows.z + len(rows)
        else:
            self._buffer(rows)
        if self.factors is None:
            return None
        pending = _Rows.join(self.unreduced, rows)
        n = len(pending) - len(pending) % self.factors[0]
        ready, rest = pending.split(n)
        self.unreduced = rest.copy() if rest is not None else None
        return _reduce(ready, self.factors) if n else None

    def flush(self) -> _Rows | None:
        """Write what is left; return the last (partial) block of rows for the next level."""
        self._write()
        if self.factors is None or self.unreduced is None or len(self.unreduced) == 0:
            return None
        rest, self.unreduced = self.unreduced, None
        return _reduce(rest, self.factors)

    def _buffer(self, rows: _Rows) -> None:
        """Copy rows into the shard's buffers, writing each shard as it fills."""
        array = self.arrays["colour"]
        if self._colour is None:
            depth = min(SHARD_ROWS, array.shape[1])
            self._colour = np.zeros((array.shape[0], depth, *array.shape[2:]), dtype=np.uint8)
            self._labels = {
                name: np.zeros((depth, *array.shape[2:]), dtype=np.uint8)
                for name in self.arrays
                if name != "colour"
            }
        at = 0
        while at < len(rows):
            n = min(self._colour.shape[1] - self._filled, len(rows) - at)
            into = slice(self._filled, self._filled + n)
            to_planar(rows.colour[at : at + n], self._colour[:, into])
            for name, buffer in self._labels.items():
                buffer[into] = rows.labels[name][at : at + n]
            self._filled += n
            at += n
            if self._filled == self._colour.shape[1]:
                self._write()

    def _write(self) -> None:
        """Write the shard filled so far (its solid chunks), and start the next one."""
        n = self._filled
        if n and self._colour is not None:
            write_solid(self.arrays["colour"], self._shard_z, self._colour[:, :n])
            for name, buffer in self._labels.items():
                write_solid(self.arrays[name], self._shard_z, buffer[:n])
        self._shard_z += n
        self._filled = 0


def _reduce(rows: _Rows, factors: Factors) -> _Rows:
    """Return the next level's rows of `rows` (which start on a block boundary)."""
    colour, weight = downsample_colour(rows.colour, rows.weight, factors)
    labels = {k: downsample_labels(v, factors) for k, v in rows.labels.items()}
    return _Rows(rows.z // factors[0], colour, weight, labels)


class OmeZarrWriter(ClosingWriter):
    """Write a stack's colour and labels to ``path`` (an OME-Zarr store) slab by slab.

    Parameters
    ----------
    path : Path
        The store (a folder, replaced if it exists).
    grid : GridSpec
        Shape, voxel size and origin (the levels' scale and translation).
    samples : int
        3 (RGB) or 4 (RGBA) colour channels.
    labels : mapping of str to sequence of LabelValue
        The label images (``materials``, ``layers``) and the values each may hold.
    queue_slabs : int
        Slabs that may wait for the writer thread.
    """

    def __init__(
        self,
        path: Path,
        grid: GridSpec,
        *,
        samples: int,
        labels: Mapping[str, Sequence[LabelValue]],
        queue_slabs: int = 2,
    ) -> None:
        if samples not in (3, 4):
            raise ValueError(f"samples must be 3 or 4, got {samples}")
        self.path = Path(path)
        self.grid = grid
        self.samples = samples
        self.label_names = tuple(labels)
        self._next_z = 0
        self._files: list[Path] | None = None
        self._temporary: Path | None = Path(
            tempfile.mkdtemp(prefix=f".{self.path.name}.", suffix=".partial", dir=self.path.parent)
        )
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(self._temporary, 0o777 & ~umask)  # mkdtemp makes 0700; the usual mode
        vx, vy, vz = grid.voxel_mm
        ox, oy, oz = grid.origin_mm
        self.factors = level_factors((vz, vy, vx), grid.shape_zyx)
        transforms = level_transforms((vz, vy, vx), (oz, oy, ox), self.factors)
        self._levels = self._create(labels, transforms)
        self._thread: SlabThread[tuple[_Rows, list[bytes] | None]] = SlabThread(
            str(self.path), self._consume, queue_slabs=queue_slabs
        )

    def _create(
        self,
        labels: Mapping[str, Sequence[LabelValue]],
        transforms: list[tuple[list[float], list[float]]],
    ) -> list[_Level]:
        """Create the groups (with their metadata) and every level's empty arrays."""
        assert self._temporary is not None
        store = zarr.storage.LocalStore(self._temporary)
        root = zarr.create_group(
            store, zarr_format=3, attributes={"ome": image_attributes(transforms, self.samples)}
        )
        groups = {"colour": root}
        if labels:
            parent = root.create_group(
                "labels", attributes={"ome": {"version": "0.5", "labels": list(labels)}}
            )
            for name, values in labels.items():
                groups[name] = parent.create_group(
                    name, attributes={"ome": label_attributes(name, transforms, values)}
                )
        shape = tuple(self.grid.shape_zyx)
        levels = []
        for k in range(len(transforms)):
            arrays = {
                name: level_array(group, str(k), shape, 0 if name != "colour" else self.samples)
                for name, group in groups.items()
            }
            factors = self.factors[k] if k < len(self.factors) else None
            levels.append(_Level(arrays, factors))
            if factors is not None:
                shape = tuple(-(-n // f) for n, f in zip(shape, factors, strict=True))
        return levels

    def write_slab(
        self,
        colour: NDArray[np.uint8],
        coloured: NDArray[np.bool_],
        labels: Mapping[str, NDArray[np.uint8]],
        shards: list[bytes] | None = None,
    ) -> None:
        """Queue the next slab (z rows in order).

        Parameters
        ----------
        colour : (Zs, Y, X, S) uint8
            sRGB (and alpha) of the voxels; at least ``samples`` channels.
        coloured : (Zs, Y, X) bool
            The colour-layer voxels (the colour pyramid averages only these).
        labels : mapping of str to (Zs, Y, X) uint8
            Every label image named at construction.
        shards : list of bytes, optional
            The slab's level-0 shard files already encoded
            (:meth:`shellvox.voxel.io._zarr_shards.ShardEncoder.encode`): stored as they are.
        """
        n = len(coloured)
        shape = (n, *self.grid.shape_zyx[1:])
        if colour.shape[:3] != shape or coloured.shape != shape:
            raise ValueError(f"slab must be {shape} voxels, got {colour.shape} {coloured.shape}")
        if colour.ndim != 4 or colour.shape[3] < self.samples:
            raise ValueError(f"colour must have {self.samples} channels, got {colour.shape}")
        if set(labels) != set(self.label_names):
            raise ValueError(f"labels must be {list(self.label_names)}, got {list(labels)}")
        if self._next_z + n > self.grid.shape_zyx[0]:
            raise ValueError(f"more than Z={self.grid.shape_zyx[0]} rows written")
        rows = _Rows(
            self._next_z,
            colour[..., : self.samples],
            coloured,
            {name: labels[name] for name in self.label_names},
        )
        self._thread.put((rows, shards))
        self._next_z += n

    def _consume(self, item: tuple[_Rows, list[bytes] | None]) -> None:
        """In the writer thread: level 0, then every level the rows complete."""
        rows, shards = item
        if shards is not None:
            self._store(shards, rows.z, len(rows))
        rows.weight = rows.weight.view(np.uint8)
        current = self._levels[0].add(rows, written=shards is not None)
        for level in self._levels[1:]:
            if current is None:
                break
            current = level.add(current)

    def _store(self, shards: list[bytes], z: int, n: int) -> None:
        """Put shard files (``[key, data, ...]``) of level 0 in place, as zarr made them.

        Each must be a shard of rows ``z`` to ``z + n`` (``z`` a shard's first row).
        """
        assert self._temporary is not None
        prefixes = ("0/c/", *(f"labels/{name}/0/c/" for name in self.label_names))
        first, last = z // SHARD_ROWS, -(-(z + n) // SHARD_ROWS)
        for key, data in zip(shards[::2], shards[1::2], strict=True):
            name = key.decode()
            parts = name.split("/")
            if not name.startswith(prefixes) or any(p in ("", ".", "..") for p in parts):
                raise ValueError(f"{self.path}: {name!r} is no shard of level 0")
            index = parts[parts.index("c") + (2 if name.startswith("0/") else 1)]  # its z
            if not index.isdigit() or not first <= int(index) < last:
                raise ValueError(f"{self.path}: {name!r} is no shard of rows {z}-{z + n}")
            path = self._temporary.joinpath(*parts)
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(data)

    def close(self) -> list[Path]:
        """Write the last rows of every level, move the store into place; return its files.

        Raises
        ------
        ValueError
            If fewer than ``Z`` rows were written (nothing is left behind).
        """
        if self._files is not None:
            return self._files
        try:
            if self._next_z != self.grid.shape_zyx[0]:
                raise ValueError(f"{self.path}: {self._next_z} of {self.grid.shape_zyx[0]} rows")
            self._thread.finish()
            carry: _Rows | None = None
            for level in self._levels:  # each level's rest completes the next one's
                forward = level.add(carry) if carry is not None else None
                last = level.flush()
                carry = forward if last is None else _Rows.join(forward, last)
            assert self._temporary is not None
            _replace_folder(self._temporary, self.path)
            self._temporary = None
        except BaseException:
            self.abort()
            raise
        self._files = sorted(p for p in self.path.rglob("*") if p.is_file())
        return self._files

    def abort(self) -> None:
        """Stop the writer thread and remove the temporary folder."""
        self._thread.abort()
        if self._temporary is not None:
            shutil.rmtree(self._temporary, ignore_errors=True)
            self._temporary = None
