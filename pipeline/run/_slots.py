"""Shared-memory slots through which forked slab workers hand slabs to the parent.

A slab is about 11 bytes a voxel (layers, colour, signed distance, band, materials);
pickled through a pipe it was copied four times and took a sixth of a printer-resolution
build. The slots are anonymous shared mappings made before the workers are forked, so
both sides see the same pages: a worker copies its slab into the slot the parent gave
it and returns only the small fields; the parent reads the arrays in place.

A slot stays taken while any array viewing it is alive (a writer thread may still hold
a slab it queued): the parent counts the references to the slot's base array, and
waits for a free slot before it sends the next task.
"""

from __future__ import annotations

import mmap
import sys
import time
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from shellvox.run._task import SLAB_ARRAYS
from shellvox.voxel.io.vdb import GridSpool
from shellvox.voxel.slab import SlabResult

#: Byte alignment of each array in a slot.
_ALIGN = 64

#: Slots beyond one per worker (slabs the writers still hold).
EXTRA_SLOTS = 4

#: Slot states: free, sent to a worker, loaded by the parent (free once no view is left).
_FREE, _SENT, _LOADED = 0, 1, 2


class SlabInSlot(NamedTuple):
    """What a worker returns: where its slab's arrays are, and the small fields."""

    slot: int
    shape: tuple[int, int, int]
    result: SlabResult  # with empty arrays in place of the big ones
    has_materials: bool
    tally: NDArray[np.int64] | None
    vdb: list[GridSpool] | None
    pages: dict[str, list[bytes]] | None = None
    #: The voxel arrays copied into the slot (the others load as empty arrays).
    sent: tuple[str, ...] = SLAB_ARRAYS


def _layout(shape: tuple[int, int, int]) -> list[tuple[str, int, tuple[int, ...], str]]:
    """Offsets of ``layers, rgba, sdf, sdf_band, materials`` for a slab of ``shape``."""
    fields = [
        ("layers", shape, "u1"),
        ("rgba", (*shape, 4), "u1"),
        ("sdf", shape, "f4"),
        ("sdf_band", shape, "?"),
        ("materials", shape, "u1"),
    ]
    out = []
    offset = 0
    for name, field_shape, dtype in fields:
        out.append((name, offset, field_shape, dtype))
        size = int(np.prod(field_shape)) * np.dtype(dtype).itemsize
        offset += -(-size // _ALIGN) * _ALIGN
    return out


def slot_bytes(shape: tuple[int, int, int]) -> int:
    """Bytes of a slot holding a slab of ``shape (Zs, Y, X)``."""
    _, offset, field_shape, dtype = _layout(shape)[-1]
    return offset + int(np.prod(field_shape)) * np.dtype(dtype).itemsize


class SlabSlots:
    """``n`` shared slots for slabs of at most ``shape`` (make them before forking).

    Parameters
    ----------
    n : int
        Slots (workers, plus the slabs writers may hold).
    shape : (3,) int
        Largest slab ``(Zs, Y, X)``.
    """

    def __init__(self, n: int, shape: tuple[int, int, int]) -> None:
        self.shape = shape
        size = slot_bytes(shape)
        self._maps = [mmap.mmap(-1, size) for _ in range(n)]
        self._bases = [np.frombuffer(m, dtype=np.uint8) for m in self._maps]
        self._baseline = sys.getrefcount(self._bases[0])
        self._state = [_FREE] * n

    def store(
        self,
        slot: int,
        result: SlabResult,
        materials: NDArray[np.uint8] | None,
        tally: NDArray[np.int64] | None,
        vdb: list[GridSpool] | None = None,
        pages: dict[str, list[bytes]] | None = None,
        send: tuple[str, ...] | None = None,
    ) -> SlabInSlot:
        """Copy a slab into ``slot`` (worker side); return what to send back.

        With `send` and pages, of the voxel arrays only those named in `send` are copied
        (what the parent still uses; the pages carry the rest), as on the Dask wire.
        """
        shape = (result.layers.shape[0], result.layers.shape[1], result.layers.shape[2])
        sent: tuple[str, ...] = SLAB_ARRAYS
        if send is not None and pages is not None:
            sent = tuple(name for name in SLAB_ARRAYS if name in send)
        views = self._views(slot, shape)
        for name in sent:
            views[name][...] = getattr(result, name)
        if materials is not None:
            views["materials"][...] = materials
        del views
        empty = np.zeros((0, 0, 0), np.uint8)
        small = result._replace(
            layers=empty,
            rgba=np.zeros((0, 0, 0, 4), np.uint8),
            sdf=np.zeros((0, 0, 0), np.float32),
            sdf_band=np.zeros((0, 0, 0), bool),
        )
        return SlabInSlot(slot, shape, small, materials is not None, tally, vdb, pages, sent)

    def load(self, item: SlabInSlot) -> tuple[SlabResult, NDArray[np.uint8] | None]:
        """Return the slab and its materials as views of the slot (parent side)."""
        self._state[item.slot] = _LOADED
        views = self._views(item.slot, item.shape)
        arrays: dict[str, Any] = {name: views[name] for name in item.sent}
        result = item.result._replace(**arrays)  # the others: the worker's empty arrays
        return result, views["materials"] if item.has_materials else None

    def take(self, timeout_s: float = 3600.0) -> int:
        """Return a free slot, waiting (polling) while writers still hold them all."""
        deadline = time.monotonic() + timeout_s
        while True:
            for slot in range(len(self._bases)):
                # counted as at __init__: the list's reference and the argument's
                held = sys.getrefcount(self._bases[slot])
                if self._state[slot] == _LOADED and held <= self._baseline:
                    self._state[slot] = _FREE
                if self._state[slot] == _FREE:
                    self._state[slot] = _SENT
                    return slot
            if time.monotonic() > deadline:
                raise RuntimeError("no slab slot came free (a writer holds every slab)")
            time.sleep(0.002)

    def _views(self, slot: int, shape: tuple[int, int, int]) -> dict[str, NDArray[Any]]:
        base = self._bases[slot]
        views: dict[str, NDArray[Any]] = {}
        for name, offset, field_shape, dtype in _layout(shape):
            size = int(np.prod(field_shape)) * np.dtype(dtype).itemsize
            views[name] = base[offset : offset + size].view(dtype).reshape(field_shape)
        return views
