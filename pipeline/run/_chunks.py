"""A finished slab as bytes: the checkpoint of a resumable build and the Dask wire format.

:func:`encode_chunk` packs everything :meth:`shellvox.stack._stack._Job._stream` consumes of a
:class:`~shellvox.run._task.StackSlab` (the slab's arrays and counters, its materials
and tally, its encoded VDB leaves and pages, the layer field at the shell meshes' nodes)
into a zip of ``.npy`` members (the arrays deflated at zlib level 1, the leaves and
pages stored as they are, being compressed already; no pickles: :func:`decode_chunk`
reads it with ``allow_pickle=False``), and :func:`decode_chunk` gives back a slab that
feeds the writers exactly as the original does. A slab that comes with its pages leaves
out the voxel arrays the writing process does not use (the job's ``send``): they are
carried by the pages and leaves, and decode as empty arrays. :func:`save_chunk` puts such
bytes in place atomically (temporary name, fsync, rename), so a chunk file that exists is
complete.
"""

from __future__ import annotations

import io
import os
import tempfile
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from shellvox.run._task import SLAB_ARRAYS, StackSlab
from shellvox.voxel.geometry import FieldNodes
from shellvox.voxel.io.vdb import GridSpool
from shellvox.voxel.slab import SlabResult

#: zlib level of the chunks: slabs are mostly runs, which level 1 packs nearly as well.
CHUNK_LEVEL = 1

_ARRAYS = ("layers", "rgba", "sdf", "sdf_band", "layer_counts")
#: The voxel arrays a chunk with pages may leave out (:data:`shellvox.run._task.SLAB_ARRAYS`).
_LEFT_OUT = SLAB_ARRAYS
_COUNTERS = (
    "z_start",
    "z_stop",
    "n_unbalanced_rows",
    "n_nesting_violations",
    "n_nearest_queries",
    "n_distance_tests",
)
#: The layer field at the shell meshes' nodes (:class:`shellvox.voxel.geometry.FieldNodes`).
_NODE_ARRAYS = ("inside", "squared", "face")
_SPOOL_TEXT = ("name", "value_type", "grid_class")
_SPOOL_LISTS = {
    "leaf_origin": ((0, 3), np.int32),
    "leaf_offset": ((0,), np.int64),
    "leaf_length": ((0,), np.int64),
    "tile_origin": ((0, 3), np.int32),
    "tile_value": ((0,), np.float32),
    "tile_active": ((0,), np.bool_),
}


def encode_chunk(done: StackSlab, send: tuple[str, ...] | None = None) -> bytes:
    """Return a finished slab as the bytes of a chunk file (see the module).

    With `send` and pages, of the voxel arrays only those named in `send` (the others
    decode as empty arrays of their kind).
    """
    members: dict[str, NDArray[Any]] = {}
    stored: set[str] = set()  # compressed already
    slab = done.slab
    for name in _ARRAYS:
        array = getattr(slab, name)
        if send is not None and done.pages is not None and name in _LEFT_OUT and name not in send:
            array = np.zeros((0,) * array.ndim, array.dtype)
        members[f"slab.{name}"] = array
    for name in _COUNTERS:
        members[f"slab.{name}"] = np.array(int(getattr(slab, name)), np.int64)
    if slab.nodes is not None:
        members["nodes.first"] = np.array(slab.nodes.first, np.int64)
        for name in _NODE_ARRAYS:
            members[f"nodes.{name}"] = getattr(slab.nodes, name)
    if done.materials is not None:
        members["materials"] = done.materials
    if done.tally is not None:
        members["tally"] = done.tally
    members["n_spools"] = np.array(-1 if done.vdb is None else len(done.vdb), np.int64)
    for i, spool in enumerate(done.vdb or []):
        prefix = f"vdb{i}."
        for name in _SPOOL_TEXT:
            members[prefix + name] = np.array(getattr(spool, name))
        members[prefix + "background"] = np.array(spool.background, np.float64)
        members[prefix + "active_voxels"] = np.array(spool.active_voxels, np.int64)
        members[prefix + "bbox_min"] = np.asarray(spool.bbox_min, np.int64)
        members[prefix + "bbox_max"] = np.asarray(spool.bbox_max, np.int64)
        members[prefix + "stream"] = np.frombuffer(_spool_bytes(spool), np.uint8)
        stored.add(prefix + "stream")
        for name, (empty, dtype) in _SPOOL_LISTS.items():
            parts = getattr(spool, name)
            members[prefix + name] = (
                np.concatenate(parts).astype(dtype, copy=False) if parts else np.zeros(empty, dtype)
            )
    for name, pages in (done.pages or {}).items():  # compressed already, and small
        members[f"pages.{name}.data"] = np.frombuffer(b"".join(pages), np.uint8)
        stored.add(f"pages.{name}.data")
        members[f"pages.{name}.sizes"] = np.array([len(page) for page in pages], np.int64)
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED, compresslevel=CHUNK_LEVEL) as archive:
        for name, array in members.items():
            # open() takes the archive's method at the time (a ZipInfo would drop the level)
            archive.compression = zipfile.ZIP_STORED if name in stored else zipfile.ZIP_DEFLATED
            with archive.open(name + ".npy", "w", force_zip64=True) as member:
                np.save(member, np.asarray(array), allow_pickle=False)
    return buffer.getvalue()


def decode_chunk(data: bytes) -> StackSlab:
    """Return the slab that :func:`encode_chunk` packed into `data`.

    Raises
    ------
    ValueError
        `data` is not a chunk (a damaged file: resume recomputes the slab).
    """
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as archive:
            members = {name: archive[name] for name in archive.files}
    except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError) as error:
        raise ValueError(f"not a slab chunk ({error})") from None
    try:
        count = {name: int(members[f"slab.{name}"]) for name in _COUNTERS}
        slab = SlabResult(
            z_start=count["z_start"],
            z_stop=count["z_stop"],
            layers=members["slab.layers"],
            rgba=members["slab.rgba"],
            sdf=members["slab.sdf"],
            sdf_band=members["slab.sdf_band"],
            n_unbalanced_rows=count["n_unbalanced_rows"],
            n_nesting_violations=count["n_nesting_violations"],
            n_nearest_queries=count["n_nearest_queries"],
            n_distance_tests=count["n_distance_tests"],
            layer_counts=members["slab.layer_counts"],
            nodes=None
            if "nodes.first" not in members
            else FieldNodes(
                int(members["nodes.first"]), *(members[f"nodes.{n}"] for n in _NODE_ARRAYS)
            ),
        )
        n_spools = int(members["n_spools"])
        spools = None if n_spools < 0 else [_spool(members, f"vdb{i}.") for i in range(n_spools)]
        pages = {}
        for key in members:
            if key.startswith("pages.") and key.endswith(".data"):
                name = key[len("pages.") : -len(".data")]
                stream, sizes = members[key], members[f"pages.{name}.sizes"]
                ends = np.cumsum(sizes)
                pages[name] = [
                    stream[e - n : e].tobytes() for e, n in zip(ends, sizes, strict=True)
                ]
        return StackSlab(
            slab, members.get("materials"), members.get("tally"), spools, pages or None
        )
    except (KeyError, TypeError, ValueError) as error:
        raise ValueError(f"not a slab chunk (missing or bad {error})") from None


def save_chunk(path: Path, data: bytes) -> None:
    """Write `data` to `path` atomically: a temporary name, fsync, then rename.

    The temporary name (``.NAME.*.partial``) is one that
    :func:`shellvox.output._outdir.remove_leftovers` removes when a killed run left it.
    """
    handle, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".partial", dir=path.parent)
    try:
        with os.fdopen(handle, "wb") as stream:
            stream.write(data)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(name, path)
    finally:
        Path(name).unlink(missing_ok=True)


def _spool_bytes(spool: GridSpool) -> bytes:
    """Return the leaf buffers an in-memory spool holds."""
    if not isinstance(spool.stream, io.BytesIO):
        raise ValueError(f"{spool.name}: only in-memory spools can be checkpointed")
    return spool.stream.getvalue()


def _spool(members: dict[str, NDArray[Any]], prefix: str) -> GridSpool:
    """Rebuild one in-memory spool of a chunk."""
    stream = members[prefix + "stream"].tobytes()
    spool = GridSpool(
        str(members[prefix + "name"]),
        str(members[prefix + "value_type"]),
        str(members[prefix + "grid_class"]),
        float(members[prefix + "background"]),
        io.BytesIO(stream),
        size=len(stream),
        active_voxels=int(members[prefix + "active_voxels"]),
        bbox_min=members[prefix + "bbox_min"],
        bbox_max=members[prefix + "bbox_max"],
    )
    for name in _SPOOL_LISTS:
        setattr(spool, name, [members[prefix + name]])
    return spool
