"""TIFF pages and job slices encoded where the slab is computed, as a pure function.

:class:`shellvox.voxel.io._tiff_writer.TiffStackWriter` compresses each page (one strip) in its
writer thread, and :class:`shellvox.voxel.io._gcvf_writer.GcvfWriter` encodes each slice's PNG in
its threads, in the process that writes the files. A build's slab workers can do the same work
beside the numerics (:class:`PageEncoder`) and hand over the bytes, which the writers then store
as they are: the bytes are those :func:`compress_page` and
:meth:`shellvox.voxel.io._gcvf_writer.KeySlices.encode` give either way, so the files are the same
(and the OME-Zarr store's level-0 shards, :mod:`shellvox.voxel.io._zarr_shards`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel.io._compression import compress
from shellvox.voxel.io._deflate import pixel_bytes
from shellvox.voxel.io._gcvf_writer import KeySlices
from shellvox.voxel.io._zarr_shards import ShardEncoder


def compress_page(page: NDArray[np.uint8], level: int | None) -> bytes:
    """Return a ``(Y, X)`` or ``(Y, X, S)`` uint8 page as one deflate (zlib) stream.

    Parameters
    ----------
    page : (Y, X) or (Y, X, S) uint8
    level : int or None
        zlib level 1..9; None: the fast setting (:mod:`shellvox.voxel.io._compression`).
    """
    return compress(pixel_bytes(page).data, level)


@dataclass(frozen=True)
class PageEncoder:
    """The pages of a build's TIFF stacks, compressed as its writers would.

    Parameters
    ----------
    colour_samples : int or None
        3 (RGB) or 4 (RGBA) samples of ``colour.tif``; None: the build writes no TIFF
        stacks (nor ``materials.tif``).
    level : int or None
        zlib level of the stacks; None: the fast setting (:mod:`shellvox.voxel.io._compression`).
    materials_tif : bool
        The build writes ``materials.tif`` (with the same level).
    slices : KeySlices, optional
        The printer job's slice encoder (``job.gcvf``), when the build writes one.
    zarr : ShardEncoder, optional
        The OME-Zarr store's level-0 shards (``stack.ome.zarr``: ``[key, data, ...]``),
        when the build writes the store.
    """

    colour_samples: int | None
    level: int | None
    materials_tif: bool
    slices: KeySlices | None = None
    zarr: ShardEncoder | None = None

    def encode(
        self,
        layers: NDArray[np.uint8],
        rgba: NDArray[np.uint8],
        materials: NDArray[np.uint8] | None,
        z_start: int = 0,
    ) -> dict[str, list[bytes]]:
        """Return each stack's compressed pages of a slab, by file name.

        Parameters
        ----------
        layers : (Zs, Y, X) uint8
        rgba : (Zs, Y, X, 4) uint8
        materials : (Zs, Y, X) uint8, optional
            Given when the materials are known here (``materials.tif`` then included).
        z_start : int
            The slab's first row (where its shards of the store go).
        """
        samples = self.colour_samples
        pages: dict[str, list[bytes]] = {}
        if samples is not None:
            pages["layers.tif"] = [compress_page(page, self.level) for page in layers]
            pages["colour.tif"] = [compress_page(page[..., :samples], self.level) for page in rgba]
        if materials is not None and samples is not None and self.materials_tif:
            pages["materials.tif"] = [compress_page(page, self.level) for page in materials]
        if materials is not None and self.slices is not None:
            pages["job.gcvf"] = [self.slices.encode(plane) for plane in materials]
        zarr = self.zarr
        if zarr is not None and (materials is not None or "materials" not in zarr.label_names):
            labels = {"layers": layers, "materials": materials}
            chosen = {name: labels[name] for name in zarr.label_names}
            pages["stack.ome.zarr"] = zarr.encode(z_start, rgba, chosen)  # type: ignore[arg-type]
        return pages
