"""Serialisation of the stack: TIFF, PNG, GrabCAD jobs, OpenVDB, previews, deflate.

These modules import only :mod:`shellvox.voxel.grid`, :mod:`shellvox.voxel.colour._srgb` and each
other.

- :mod:`~shellvox.voxel.io._compression` every deflate stream's setting;
  :mod:`~shellvox.voxel.io._deflate` a compiled run-length encoder (the VDB leaves) and a page's
  bytes;
- :mod:`~shellvox.voxel.io._tiff_pages` pages encoded where a slab is computed;
  :mod:`~shellvox.voxel.io._tiff_writer` the TIFF stacks; :mod:`~shellvox.voxel.io._png_encode`,
  :mod:`~shellvox.voxel.io._png_slices` PNG slices; :mod:`~shellvox.voxel.io._gcvf_job`,
  :mod:`~shellvox.voxel.io._gcvf_writer` GrabCAD Voxel Print jobs;
  :mod:`~shellvox.voxel.io._slab_thread` the writer thread they share;
- :mod:`~shellvox.voxel.io._zarr_writer` the OME-Zarr store (with ``zarr``), its metadata
  :mod:`~shellvox.voxel.io._ome_metadata`, its levels :mod:`~shellvox.voxel.io._pyramid` and its
  level-0 shards encoded where a slab is computed :mod:`~shellvox.voxel.io._zarr_shards`;
- :mod:`shellvox.voxel.io.vdb` ``volume.vdb`` without OpenVDB; :mod:`~shellvox.voxel.io._preview`
  section pictures and the depth histogram; :mod:`~shellvox.voxel.io._proof_picture` the soft
  proof's picture.
"""

from __future__ import annotations

from shellvox.voxel.io._compression import check_level, compress, compressobj
from shellvox.voxel.io._deflate import pixel_bytes, zlib_compress
from shellvox.voxel.io._gcvf_job import RGBA, GcvfJobError, key_rgba, material_table
from shellvox.voxel.io._gcvf_writer import GcvfWriter, KeySlices
from shellvox.voxel.io._ome_metadata import LabelValue
from shellvox.voxel.io._png_encode import encode_png
from shellvox.voxel.io._png_slices import SIDECAR_NAME, PngSliceWriter
from shellvox.voxel.io._preview import (
    BAND_RGB,
    CORE_RGB,
    FADE,
    OUTSIDE_RGB,
    boundary_depths,
)
from shellvox.voxel.io._proof_picture import (
    DE_RGB,
    DE_STEPS,
    HATCH_PERIOD,
    HATCH_RGB,
    NO_PREDICTION_RGB,
    PANELS,
    ProofView,
    de_colours,
    soft_proof_image,
)
from shellvox.voxel.io._pyramid import downsample_colour, downsample_labels, level_factors
from shellvox.voxel.io._tiff_pages import PageEncoder
from shellvox.voxel.io._tiff_writer import TiffStackWriter
from shellvox.voxel.io._zarr_shards import SHARD_ROWS, STORE_LAYOUT, ShardEncoder, encoded_by_slabs
from shellvox.voxel.io._zarr_writer import OmeZarrWriter

__all__ = [
    "BAND_RGB",
    "CORE_RGB",
    "DE_RGB",
    "DE_STEPS",
    "FADE",
    "HATCH_PERIOD",
    "HATCH_RGB",
    "NO_PREDICTION_RGB",
    "OUTSIDE_RGB",
    "PANELS",
    "RGBA",
    "SHARD_ROWS",
    "SIDECAR_NAME",
    "STORE_LAYOUT",
    "GcvfJobError",
    "GcvfWriter",
    "KeySlices",
    "LabelValue",
    "OmeZarrWriter",
    "PageEncoder",
    "PngSliceWriter",
    "ProofView",
    "ShardEncoder",
    "TiffStackWriter",
    "boundary_depths",
    "check_level",
    "compress",
    "compressobj",
    "de_colours",
    "downsample_colour",
    "downsample_labels",
    "encode_png",
    "encoded_by_slabs",
    "key_rgba",
    "level_factors",
    "material_table",
    "pixel_bytes",
    "soft_proof_image",
    "zlib_compress",
]
