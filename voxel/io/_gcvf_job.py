"""What a GrabCAD Voxel Print job holds besides its slices (:mod:`~shellvox.voxel.io._gcvf_writer`).

No specification is public. *Known* below means two or more public writers or readers do
it; *inferred* means one writer does it, or none states it and this module chose (the
sources are those of :mod:`~shellvox.voxel.io._gcvf_writer`).

``ConfigFile.xml`` (written last, once every VoxelCount is known)
-----------------------------------------------------------------
Element names and nesting as slice2vox and OpenVCAD write it and voxelprint-preview
parses it (known):

- ``Version`` 2 (meaning not documented).
- ``Resolution``: ``XDpi`` 600, ``YDpi`` 300, ``SliceThicknessNanoMeter`` 27000, the
  J750/J850 grid (600 x 300 dpi, 27 um layers); the grid's voxel size must match them.
- ``SliceDimensions``: ``SliceWidth``, ``SliceHeight`` in pixels (x, y).
- ``SliceRange``: ``StartIndex`` 0, ``NumberOfSlices`` (padding included).
- ``BitDepth`` 4 (meaning not documented publicly).
- ``MaxNumberOfColors``: `max_materials` (6; *inferred* that it is the material limit,
  so 3 for high-speed mode).
- ``DataSemantics`` ``Materials``, ``CreationMode`` ``MODEL_ONLY``, ``ImageFilePrefix``
  ``layer_`` (slice2vox's prefix; OpenVCAD names its slices ``gcvf_export_N.png`` and
  declares that prefix, so the prefix is read from here: *inferred*).
- ``MaterialList``: ``BackGroundMaterialRGBA``, the key of air: ``0 0 0 0`` (transparent,
  as OpenVCAD writes it and as the format's own template comment reads, "air color in
  Red/Green/Blue/Alpha order"), which leaves opaque black ``0 0 0 255`` to black
  material; then one ``Material`` per material used (``Name``, ``RGBA`` as four integers,
  ``VoxelCount`` = its pixels over all slices), in the table's order. The names are
  GrabCAD's short names (``VeroCY-V``, ``VeroMGT-V``, ``VeroYL-V``: slice2vox and OpenVCAD
  agree, known; ``VeroBlack``, ``VeroPureWht``: OpenVCAD, inferred), which the printer
  profile gives per material (``job_name``). Keys are arbitrary: the import GUI maps them.

The box, the height map and the surface (OpenVCAD's jobs hold them; inferred)
------------------------------------------------------------------------------
- ``MeshBbx.ktn`` (:func:`box_bytes`): six little-endian float32, ``0 0 0 W H N``, the
  job's box in voxels (slice width, slice height, number of slices).
- ``Zbuffer.png`` (:func:`zbuffer_png`): 16-bit greyscale, ``W x H``, rows in the slices'
  order: per pixel the highest slice index that holds material (a height map of the part
  seen from above); 0 where no slice does (*inferred*: the value of an empty column is
  not known).
- ``Mesh.stl`` (:func:`surface_stl`): binary STL of the part's surface in millimetres, in
  the job's frame (the box's corner, the outer corner of voxel ``(0, 0, 0)``, at the
  origin): the input surface as built, not one taken from the voxels.

Whether GrabCAD Print needs these three files could not be checked (no GrabCAD here).

Limits, checked before anything is written
------------------------------------------
At most `max_materials` (6; 3 in high-speed mode) non-background materials per job
(vdbmat-utils, citing the Stratasys guide), at least `min_slices` (30) slices (padded),
at most 65,535 slices (the height map's 16 bits), keys distinct and none equal to the
background, a voxel size that matches the dpi and layer thickness, and optionally the
printer's tray. Violations raise :class:`GcvfJobError` (a ``ValueError`` naming the
problem and the fix).
"""

from __future__ import annotations

import io
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import trimesh
from numpy.typing import NDArray
from PIL import Image

from shellvox.voxel._compiled import kernel
from shellvox.voxel.grid import GridSpec

MM_PER_INCH = 25.4
IMAGE_PREFIX = "layer_"
#: Relative tolerance between the grid's voxel size and the job's dpi and layer thickness.
VOXEL_SIZE_RTOL = 1e-6

#: Slices a job may have: the height map holds a slice index in 16 bits.
MAX_SLICES = 65535
#: The job's extra files (besides the slices and ``ConfigFile.xml``).
BOX_NAME, ZBUFFER_NAME, SURFACE_NAME = "MeshBbx.ktn", "Zbuffer.png", "Mesh.stl"

RGBA = tuple[int, int, int, int]


class GcvfJobError(ValueError):
    """A job that breaks a known limit of the format (or is described inconsistently).

    Attributes
    ----------
    problem : str
        What is wrong, with the values seen.
    fix : str
        What the user can change.
    """

    def __init__(self, problem: str, fix: str) -> None:
        self.problem = problem
        self.fix = fix
        super().__init__(f"{problem}; {fix}")


@dataclass(frozen=True)
class Material:
    """One row of the material table: index in the voxels, name and RGBA key in the slices."""

    index: int
    name: str
    rgba: RGBA


def config_xml(
    grid: GridSpec,
    dpi: tuple[int, int],
    slice_thickness_nm: int,
    n_slices: int,
    max_materials: int,
    background: RGBA,
    listed: tuple[tuple[Material, int], ...],
) -> bytes:
    """Return ``ConfigFile.xml`` of a job (element names and nesting as public writers use)."""
    _, n_y, n_x = grid.shape_zyx
    root = ET.Element("GCVF")

    def add(parent: ET.Element, tag: str, text: object = None) -> ET.Element:
        element = ET.SubElement(parent, tag)
        if text is not None:
            element.text = str(text)
        return element

    add(root, "Version", 2)
    resolution = add(root, "Resolution")
    add(resolution, "XDpi", dpi[0])
    add(resolution, "YDpi", dpi[1])
    add(resolution, "SliceThicknessNanoMeter", slice_thickness_nm)
    dimensions = add(root, "SliceDimensions")
    add(dimensions, "SliceWidth", n_x)
    add(dimensions, "SliceHeight", n_y)
    slice_range = add(root, "SliceRange")
    add(slice_range, "StartIndex", 0)
    add(slice_range, "NumberOfSlices", n_slices)
    add(root, "BitDepth", 4)
    add(root, "MaxNumberOfColors", max_materials)
    add(root, "DataSemantics", "Materials")
    add(root, "CreationMode", "MODEL_ONLY")
    add(root, "ImageFilePrefix", IMAGE_PREFIX)
    material_list = add(root, "MaterialList")
    add(material_list, "BackGroundMaterialRGBA", " ".join(map(str, background)))
    for material, count in listed:
        element = add(material_list, "Material")
        add(element, "Name", material.name)
        add(element, "RGBA", " ".join(map(str, material.rgba)))
        add(element, "VoxelCount", count)
    ET.indent(root, space="    ")
    text = ET.tostring(root, encoding="unicode")
    return f'<?xml version="1.0" encoding="UTF-8"?>\n{text}\n'.encode()


def key_rgba(value: Sequence[int], what: str) -> RGBA:
    """Return an RGBA key as four ints 0..255 or raise GcvfJobError."""
    try:
        parts = [int(v) for v in value]
        exact = all(v == w for v, w in zip(parts, value, strict=True))
        ok = len(parts) == 4 and exact and all(0 <= v <= 255 for v in parts)
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise GcvfJobError(
            f"{what} must be 4 integers 0..255 (R, G, B, A), got {value!r}",
            "give the key as R,G,B,A",
        )
    return (parts[0], parts[1], parts[2], parts[3])


def material_table(
    table: Sequence[tuple[int, str, Sequence[int]]], background: RGBA, max_materials: int
) -> tuple[Material, ...]:
    """Check the ``(index, name, rgba_key)`` table; return its non-background materials."""
    materials: list[Material] = []
    for row in table:
        if len(row) != 3:
            raise GcvfJobError(
                f"material table rows must be (index, name, rgba_key), got {row!r}",
                "give one row per material",
            )
        index, name, key = row
        rgba = key_rgba(key, f"the key of material {name!r}")
        if not isinstance(name, str) or not name.strip():
            raise GcvfJobError(f"material {index} has no name ({name!r})", "name every material")
        if not isinstance(index, int | np.integer) or not 0 <= index <= 255:
            raise GcvfJobError(
                f"material {name!r} has index {index!r}; indices are integers 0..255",
                "number the materials 1..255 (0 is void)",
            )
        if index == 0:
            if rgba != background:
                raise GcvfJobError(
                    f"material 0 ({name!r}) is void but its key {rgba} is not the background "
                    f"key {background}",
                    "give void the background key or leave it out of the table",
                )
            continue
        materials.append(Material(int(index), name, rgba))
    indices = [m.index for m in materials]
    if len(set(indices)) != len(indices):
        raise GcvfJobError(
            f"material indices repeat: {indices}", "give each material its own index"
        )
    keys = [m.rgba for m in materials]
    if len(set(keys)) != len(keys):
        raise GcvfJobError(f"material keys repeat: {keys}", "give each material its own RGBA key")
    clash = [m.name for m in materials if m.rgba == background]
    if clash:
        raise GcvfJobError(
            f"material {clash[0]!r} has the background (void) key {background}",
            "give it another key (black material e.g. 1 1 1 255)",
        )
    if len(materials) > max_materials:
        names = ", ".join(m.name for m in materials)
        raise GcvfJobError(
            f"a Voxel Print job holds at most {max_materials} materials besides the "
            f"background, got {len(materials)} ({names})",
            "use a printer profile or separation with fewer materials",
        )
    return tuple(materials)


def check_grid(
    grid: GridSpec,
    dpi: tuple[int, int],
    slice_thickness_nm: int,
    min_slices: int,
    tray_mm: tuple[float, float, float] | None,
) -> None:
    """Refuse a grid whose voxels are not the job's pixels, or which exceeds the tray."""
    if min(dpi) < 1 or slice_thickness_nm < 1:
        raise GcvfJobError(
            f"dpi {dpi} and slice thickness {slice_thickness_nm} nm must be positive",
            "use the printer's resolution (600 x 300 dpi, 27000 nm)",
        )
    expected = (MM_PER_INCH / dpi[0], MM_PER_INCH / dpi[1], slice_thickness_nm * 1e-6)
    if not np.allclose(grid.voxel_mm, expected, rtol=VOXEL_SIZE_RTOL, atol=0.0):
        got = ", ".join(f"{v:.6g}" for v in grid.voxel_mm)
        want = ", ".join(f"{v:.6g}" for v in expected)
        raise GcvfJobError(
            f"the voxel size ({got}) mm is not the job's {dpi[0]} x {dpi[1]} dpi and "
            f"{slice_thickness_nm} nm slices ({want}) mm",
            "build on the printer's grid to write a .gcvf job",
        )
    if tray_mm is not None:
        n_z, n_y, n_x = grid.shape_zyx
        size = np.asarray((n_x, n_y, max(n_z, min_slices)), np.float64) * np.asarray(expected)
        if np.any(size > np.asarray(tray_mm, np.float64)):
            raise GcvfJobError(
                f"the job is {size[0]:.1f} x {size[1]:.1f} x {size[2]:.1f} mm, larger than the "
                f"printer's tray {tray_mm[0]:g} x {tray_mm[1]:g} x {tray_mm[2]:g} mm",
                "scale the model down or split it",
            )
    if max(grid.shape_zyx[0], min_slices) > MAX_SLICES:
        raise GcvfJobError(
            f"the job would have {grid.shape_zyx[0]} slices, more than {MAX_SLICES}",
            "scale the model down or split it",
        )


@kernel
def raise_heights(heights: NDArray[np.int32], occupied: NDArray[np.uint8], z_start: int) -> None:
    """Set ``heights[y, x]`` to ``z_start + z`` for every ``occupied[z, y, x] != 0`` (in place).

    Slabs given in z order leave `heights` the highest occupied slice of each column.

    Parameters
    ----------
    heights : (Y, X) int32
        The height map so far (-1: nothing yet).
    occupied : (Zs, Y, X) uint8
        Nonzero where a voxel holds material.
    z_start : int
        Slice index of ``occupied[0]``.
    """
    n_z, n_y, n_x = occupied.shape
    for z in range(n_z):
        level = z_start + z
        for y in range(n_y):
            for x in range(n_x):
                if occupied[z, y, x] != 0:
                    heights[y, x] = level


def box_bytes(width: int, height: int, n_slices: int) -> bytes:
    """Return ``MeshBbx.ktn``: six little-endian float32, ``0 0 0 width height n_slices``.

    Examples
    --------
    >>> np.frombuffer(box_bytes(53, 29, 37), "<f4").tolist()
    [0.0, 0.0, 0.0, 53.0, 29.0, 37.0]
    """
    return np.array([0, 0, 0, width, height, n_slices], dtype="<f4").tobytes()


def zbuffer_png(heights: NDArray[np.int32], *, bottom_up: bool) -> bytes:
    """Return ``Zbuffer.png``: the height map as a 16-bit greyscale PNG (Pillow).

    Parameters
    ----------
    heights : (Y, X) int32
        Highest slice index holding material per column, -1 where none (written as 0).
    bottom_up : bool
        Image row 0 is the largest y (as the slices' ``first_row="max_y"``).
    """
    rows = heights[::-1] if bottom_up else heights
    image = Image.fromarray(np.ascontiguousarray(np.clip(rows, 0, None), dtype=np.uint16))
    buffer = io.BytesIO()
    image.save(buffer, format="PNG")
    return buffer.getvalue()


def surface_stl(
    vertices_mm: NDArray[np.float64], faces: NDArray[np.int64], grid: GridSpec
) -> bytes:
    """Return ``Mesh.stl``: the surface as binary STL (trimesh) in the job's frame.

    Parameters
    ----------
    vertices_mm : (V, 3) float64, mm
        The surface as built (the grid's world frame).
    faces : (F, 3) int64
    grid : GridSpec
        The job's grid: the outer corner of its voxel ``(0, 0, 0)`` becomes the origin.
    """
    corner = np.asarray(grid.origin_mm) - 0.5 * np.asarray(grid.voxel_mm)
    mesh = trimesh.Trimesh(np.asarray(vertices_mm) - corner, faces, process=False)
    data: bytes = trimesh.exchange.stl.export_stl(mesh)
    return data
