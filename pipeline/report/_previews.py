"""Preview pictures of a build (``shellvox inspect``): sections, outer views, depths, halftone.

- ``section_xy.png``, ``section_xz.png``, ``section_yz.png``: on each axis a section
  that holds every layer of the volume, plenty of core and the most vivid colour
  (:func:`shellvox.report._planes.choose_plane`), drawn as its colour and its layers,
  whole and zoomed to voxels where the colour is densest, with a key of the layers'
  names and tones.
- ``outer_views.png``: the outer colour layer seen from the six sides, orthographic,
  at one scale: for each line of sight, the colour of the first colour-layer voxel.
- ``layer_depth_histogram.png``: the depth of each band's inner boundary in those three
  sections against the configured depths, with a key of the bands.
- ``halftone_z*.png``: with materials, the slice with the most colour voxels, target
  colour beside the halftoned materials, with a key of the materials' names and colours.
- ``soft_proof.png``: with the build's soft proof (``proof.ply``), the six outer views
  (at :data:`PROOF_PIXELS_PER_MM` pixels per mm or more, within :data:`PROOF_MAX_PIXELS`)
  as targeted, as predicted from the voxels as written, and the CIEDE2000 between them
  (hatched where the target is out of gamut) and between the prediction and the
  separation's aim (:func:`shellvox.voxel.io.soft_proof_image`). Each pixel is the proof
  interpolated at the voxel it sees (:meth:`shellvox.voxel.colour.SoftProof.at`, the
  samples facing the viewer); the legend states the optics (assumed or measured) and
  the sampling.

Each picture but the soft proof has a title above and its key below
(:mod:`shellvox.report._pictures`), text at :data:`~shellvox.report._key.CAPTION_PX`
pixels. One pass reads the stacks page by page (memory: a page, the view images and the
per-plane layer counts), then the chosen sections are read lazily
(:class:`~shellvox.viewer._stacks.TiffStack`).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import tifffile
from numpy.typing import NDArray
from PIL import Image
from PIL.PngImagePlugin import PngInfo

from shellvox.atomic import atomic_path
from shellvox.errors import InputError
from shellvox.output import PROOF_FILE, read_proof_ply
from shellvox.report._pictures import (
    depth_histogram_picture,
    halftone_picture,
    outer_views_picture,
    section_picture,
)
from shellvox.report._planes import LayerCounts
from shellvox.viewer import Axis, SectionCounts, TiffStack
from shellvox.voxel.colour import IN_GAMUT_DE, SoftProof
from shellvox.voxel.io import (
    ProofView,
    boundary_depths,
    soft_proof_image,
)

#: The soft proof's views are drawn at least this many pixels across the model's largest
#: side, at least :data:`PROOF_PIXELS_PER_MM` (a 1 mm patch is 4 pixels across), at most
#: :data:`PROOF_MAX_PIXELS` (a view of a tray is then drawn coarser; the legend says so).
PROOF_PIXELS = 200
PROOF_PIXELS_PER_MM = 4.0
PROOF_MAX_PIXELS = 1200


def write_previews(folder: Path, manifest: dict[str, Any]) -> list[Path]:
    """Write the preview pictures of the build in ``folder`` to ``folder/preview/``.

    Returns
    -------
    list of Path
        The pictures written.

    Raises
    ------
    ValueError
        A stack does not hold the manifest's grid (or cannot be read).
    """
    n_z, n_y, n_x = manifest["grid"]["shape_zyx"]
    vx, vy, vz = manifest["grid"]["voxel_size_mm"]
    n_bands = len(manifest["layers"]) - 2
    colour_layers = tuple(layer["index"] for layer in manifest["layers"] if layer["colour"])
    names = {
        int(layer["index"]): str(layer.get("name", layer["index"])) for layer in manifest["layers"]
    }
    layer_names = [names.get(index, str(index)) for index in range(n_bands + 2)]
    stats = _scan(folder, (n_z, n_y, n_x), colour_layers)
    preview = folder / "preview"
    preview.mkdir(exist_ok=True)
    written = []
    chosen = stats.planes.chosen(n_bands + 1, stats.counts.vivid)
    sectioned: list[tuple[NDArray[np.uint8], tuple[float, float]]] = []
    samples = 4 if manifest.get("tiff", {}).get("colour.tif", {}).get("samples") == 4 else 3
    with (
        TiffStack(folder / "layers.tif", (n_z, n_y, n_x), samples=0) as layers_stack,
        TiffStack(folder / "colour.tif", (n_z, n_y, n_x), samples=samples) as colour_stack,
    ):
        sections: tuple[tuple[Axis, tuple[str, str], tuple[float, float]], ...] = (
            ("z", ("y", "x"), (vx, vy)),
            ("y", ("z", "x"), (vx, vz)),
            ("x", ("z", "y"), (vy, vz)),
        )
        for axis, (row_axis, col_axis), pixel_mm in sections:
            index = chosen[axis]
            rows = range({"z": n_z, "y": n_y, "x": n_x}[row_axis])
            cols = range({"z": n_z, "y": n_y, "x": n_x}[col_axis])
            layers = layers_stack.region(axis, index, rows, cols)[::-1]
            rgb = colour_stack.region(axis, index, rows, cols)[::-1, :, :3]
            origin = manifest["grid"]["origin_mm"]["xyz".index(axis)]
            size = manifest["grid"]["voxel_size_mm"]["xyz".index(axis)]
            in_plane = stats.planes.counts[axis][index]
            held = [layer_names[i] for i in range(1, n_bands + 2) if in_plane[i]]
            title = (
                f"{col_axis}{row_axis} section at {axis} = {index} ({origin + index * size:.3f} "
                f"mm), {row_axis} up and {col_axis} right: {', '.join(held) or 'no layer'} "
                f"({int(in_plane[n_bands + 1]):,} core voxels, "
                f"{int(stats.counts.vivid[axis][index]):,} vivid colour-layer voxels)"
            )
            layers = np.ascontiguousarray(layers)
            sectioned.append((layers, pixel_mm))
            image = section_picture(
                layers,
                np.ascontiguousarray(rgb),
                colour_layers=colour_layers,
                layer_names=layer_names,
                pixel_mm=pixel_mm,
                title=title,
            )
            image.info["shellvox:section"] = json.dumps({"axis": axis, "index": index})
            written.append(_save(image, preview / f"section_{col_axis}{row_axis}.png"))
    written.append(_save(_outer_views(stats, (vx, vy, vz)), preview / "outer_views.png"))
    depths: list[list[NDArray[np.float64]]] = [[] for _ in range(n_bands)]
    for layers, pixel_mm in sectioned:
        for band, values in enumerate(boundary_depths(layers, pixel_mm, n_bands)):
            depths[band].append(values)
    expected = list(np.cumsum([float(layer["thickness_mm"]) for layer in manifest["layers"][1:-1]]))
    image = depth_histogram_picture(
        [np.concatenate(d) for d in depths],
        expected,
        band_names=layer_names[1:-1],
        title="Depth of each band's inner boundary in the three sections (at least the "
        "depth in 3-D; equal where the surface is perpendicular to the section), against "
        "the configured depths",
    )
    written.append(_save(image, preview / "layer_depth_histogram.png"))
    if "materials.tif" in manifest["files"] and manifest.get("materials"):
        z = int(np.argmax(stats.counts.colour_voxels))
        written.append(_halftone_preview(folder, manifest, z))
    if manifest.get("proof") and PROOF_FILE in manifest["files"]:
        try:
            proof = read_proof_ply(folder / PROOF_FILE)
        except ValueError as error:
            raise InputError(
                folder / PROOF_FILE, f"cannot be read ({error})", "rebuild with shellvox build"
            ) from None
        image = _soft_proof(stats, manifest, proof)
        written.append(_save(image, preview / "soft_proof.png"))
    return written


class _Scan:
    """What one pass over the pages gathers (see :func:`_scan`)."""

    def __init__(self, shape: tuple[int, int, int], colour_layers: tuple[int, ...]) -> None:
        n_z, n_y, n_x = shape
        self.counts = SectionCounts(shape, colour_layers)
        self.planes = LayerCounts(shape)
        # the outer colour layer seen along each axis: colour, and where it was seen
        self.top = np.zeros((n_y, n_x, 3), np.uint8)
        self.bottom = np.zeros((n_y, n_x, 3), np.uint8)
        self.top_hit = np.zeros((n_y, n_x), bool)
        self.bottom_hit = np.zeros((n_y, n_x), bool)
        self.front = np.zeros((n_z, n_x, 3), np.uint8)  # from -y
        self.back = np.zeros((n_z, n_x, 3), np.uint8)  # from +y
        self.left = np.zeros((n_z, n_y, 3), np.uint8)  # from -x
        self.right = np.zeros((n_z, n_y, 3), np.uint8)  # from +x
        self.y_hit = np.zeros((n_z, n_x), bool)
        self.x_hit = np.zeros((n_z, n_y), bool)
        # the voxel each view sees: z from +z and -z, y from -y and +y, x from -x and +x
        self.top_z = np.zeros((n_y, n_x), np.int32)
        self.bottom_z = np.zeros((n_y, n_x), np.int32)
        self.front_y = np.zeros((n_z, n_x), np.int32)
        self.back_y = np.zeros((n_z, n_x), np.int32)
        self.left_x = np.zeros((n_z, n_y), np.int32)
        self.right_x = np.zeros((n_z, n_y), np.int32)


def _scan(folder: Path, shape: tuple[int, int, int], colour_layers: tuple[int, ...]) -> _Scan:
    """Read layers.tif and colour.tif page by page; gather counts and views."""
    n_z, n_y, n_x = shape
    with (
        tifffile.TiffFile(folder / "layers.tif") as lt,
        tifffile.TiffFile(folder / "colour.tif") as ct,
    ):
        for name, tif in (("layers.tif", lt), ("colour.tif", ct)):  # before allocating
            found = (len(tif.pages), *tif.pages[0].shape[:2]) if len(tif.pages) else (0,)
            if found != shape:
                raise ValueError(
                    f"{name} holds {found} (z, y, x) voxels but the manifest's grid is {shape}"
                )
        stats = _Scan(shape, colour_layers)
        columns = np.arange(n_x)
        rows = np.arange(n_y)
        for z in range(n_z):  # one page at a time: memory stays one page
            layers = lt.pages[z].asarray()
            rgb = ct.pages[z].asarray()[..., :3]
            coloured = stats.counts.add_page(z, layers, rgb)
            stats.planes.add_page(z, layers)
            # the outer colour layer: from +z the last seen wins, from -z the first
            stats.top[coloured] = rgb[coloured]
            stats.top_z[coloured] = z
            stats.top_hit |= coloured
            first = coloured & ~stats.bottom_hit
            stats.bottom[first] = rgb[first]
            stats.bottom_z[first] = z
            stats.bottom_hit |= coloured
            along_y = coloured.any(axis=0)
            stats.y_hit[z] = along_y
            low, high = np.argmax(coloured, axis=0), n_y - 1 - np.argmax(coloured[::-1], axis=0)
            stats.front[z] = rgb[low, columns]
            stats.back[z] = rgb[high, columns]
            stats.front_y[z], stats.back_y[z] = low, high
            stats.x_hit[z] = coloured.any(axis=1)
            low, high = np.argmax(coloured, axis=1), n_x - 1 - np.argmax(coloured[:, ::-1], axis=1)
            stats.left[z] = rgb[rows, low]
            stats.right[z] = rgb[rows, high]
            stats.left_x[z], stats.right_x[z] = low, high
    return stats


def _outer_views(stats: _Scan, voxel_mm: tuple[float, float, float]) -> Image.Image:
    """Draw the six views, turned as a viewer outside the part sees them (up is up)."""
    vx, vy, vz = voxel_mm
    up = np.s_[::-1]  # image rows run downwards
    views = [
        ("top (from +z; x right, y up)", stats.top[up], stats.top_hit[up], (vx, vy)),
        ("front (from -y; x right, z up)", stats.front[up], stats.y_hit[up], (vx, vz)),
        ("right (from +x; y right, z up)", stats.right[up], stats.x_hit[up], (vy, vz)),
        (
            "bottom (from -z; x left, y up)",
            stats.bottom[::-1, ::-1],
            stats.bottom_hit[::-1, ::-1],
            (vx, vy),
        ),
        ("back (from +y; x left, z up)", stats.back[::-1, ::-1], stats.y_hit[::-1, ::-1], (vx, vz)),
        ("left (from -x; y left, z up)", stats.left[::-1, ::-1], stats.x_hit[::-1, ::-1], (vy, vz)),
    ]
    n_z, n_y = stats.x_hit.shape
    n_x = stats.y_hit.shape[1]
    largest_mm = max(n_x * vx, n_y * vy, n_z * vz)
    pixels_per_mm = 420 / largest_mm
    title = (
        "The outer colour layer from the six sides, orthographic, at one scale "
        f"({pixels_per_mm:.1f} pixels per mm): on each line of sight the first colour-layer voxel"
    )
    opposite = [views[i] for i in (0, 3, 1, 4, 2, 5)]  # each row: a view and its opposite
    return outer_views_picture(opposite, pixels_per_mm=pixels_per_mm, title=title, columns=2)


def _soft_proof(stats: _Scan, manifest: dict[str, Any], proof: SoftProof) -> Image.Image:
    """Draw the six views as targeted and as predicted, and their errors (see the module)."""
    grid = manifest["grid"]
    vx, vy, vz = grid["voxel_size_mm"]
    origin = np.asarray(grid["origin_mm"], np.float64)
    n_z, n_y, n_x = grid["shape_zyx"]
    z_rows, y_rows = np.arange(n_z)[:, None], np.arange(n_y)[:, None]
    y_cols, x_cols = np.arange(n_y)[None, :], np.arange(n_x)[None, :]
    up, turned = np.s_[::-1], np.s_[::-1, ::-1]
    # label, seen colour, hit, (x, y, z) voxel index, pixel (w, h) mm, towards the viewer
    views: list[tuple[Any, ...]] = [
        ("top (from +z; x right, y up)", stats.top, stats.top_hit,
         (x_cols, y_rows, stats.top_z), (vx, vy), (0, 0, 1), up),
        ("front (from -y; x right, z up)", stats.front, stats.y_hit,
         (x_cols, stats.front_y, z_rows), (vx, vz), (0, -1, 0), up),
        ("right (from +x; y right, z up)", stats.right, stats.x_hit,
         (stats.right_x, y_cols, z_rows), (vy, vz), (1, 0, 0), up),
        ("bottom (from -z; x left, y up)", stats.bottom, stats.bottom_hit,
         (x_cols, y_rows, stats.bottom_z), (vx, vy), (0, 0, -1), turned),
        ("back (from +y; x left, z up)", stats.back, stats.y_hit,
         (x_cols, stats.back_y, z_rows), (vx, vz), (0, 1, 0), turned),
        ("left (from -x; y left, z up)", stats.left, stats.x_hit,
         (stats.left_x, y_cols, z_rows), (vy, vz), (-1, 0, 0), turned),
    ]  # fmt: skip
    largest_mm = max(n_x * vx, n_y * vy, n_z * vz)
    pixels_per_mm = min(
        max(PROOF_PIXELS / largest_mm, PROOF_PIXELS_PER_MM), PROOF_MAX_PIXELS / largest_mm
    )
    drawn = []
    for label, rgb, hit, index, pixel_mm, towards, flip in views:
        height, width = hit.shape
        size = (max(1, round(width * pixel_mm[0] * pixels_per_mm)),
                max(1, round(height * pixel_mm[1] * pixels_per_mm)))  # fmt: skip
        rows = ((np.arange(size[1]) + 0.5) * height / size[1]).astype(np.intp)[:, None]
        cols = ((np.arange(size[0]) + 0.5) * width / size[0]).astype(np.intp)[None, :]
        xyz = [np.broadcast_to(i, hit.shape)[flip][rows, cols] for i in index]
        seen = hit[flip][rows, cols]
        points = origin + np.stack(xyz, axis=-1)[seen] * (vx, vy, vz)
        at = proof.at(points, np.asarray(towards, np.float64), same_side=0.0)
        predicted = np.zeros((*seen.shape, 3), np.uint8)
        predicted[seen] = at.srgb("predicted")
        total = np.full(seen.shape, np.nan)
        total[seen] = at.total_de
        reproduction = np.full(seen.shape, np.nan)
        reproduction[seen] = at.reproduction_de
        outside = np.zeros(seen.shape, bool)
        outside[seen] = at.gamut_de > IN_GAMUT_DE
        target = rgb[flip][rows, cols]
        drawn.append(ProofView(label, seen, target, predicted, total, reproduction, outside))
    return soft_proof_image(drawn, _proof_legend(manifest, proof, pixels_per_mm))


def _proof_legend(manifest: dict[str, Any], proof: SoftProof, pixels_per_mm: float) -> list[str]:
    """Return the soft proof's legend: the model, its optics, the sampling, the errors."""
    if proof.optics == "assumed":
        optics = (
            "ASSUMED optics (the profile's default absorption and scattering, not measured): "
            "print `shellvox chart`, measure it and run `shellvox calibrate` to replace them"
        )
    else:
        optics = f"the measured optics of printer profile {manifest.get('printer', '?')}"
    seen = proof.predicted
    inside = seen & proof.in_gamut
    spacing = proof.spacing_mm

    def median(values: NDArray[np.float64]) -> str:
        return f"{float(np.median(values)):.2f}" if len(values) else "-"

    return [
        "Predicted print: the two-flux (Kubelka-Munk) model over the material voxels as "
        "written, under " + optics + ".",
        f"Sampling: {len(proof):,} surface samples, mean spacing {spacing:.2f} mm (about "
        f"{1.0 / spacing**2:.0f} in a 1 mm patch); each pixel: the samples within "
        f"{3 * spacing:.2f} mm that face the viewer, weighted by 1 / distance^2; views "
        f"drawn at {pixels_per_mm:.1f} pixels per mm.",
        "CIEDE2000 vs target is hatched where the target lies outside the gamut (its "
        f"separation's aim is more than {IN_GAMUT_DE:g} away): no printing reaches it there; "
        "vs aim is the halftone's, voxels' and depth's part.",
        f"Over the samples: vs target median {median(proof.total_de[seen])}; in gamut "
        f"({int(inside.sum()):,}) median {median(proof.total_de[inside])}; vs aim median "
        f"{median(proof.reproduction_de[seen])}; gamut error median "
        f"{median(proof.gamut_de)}.",
    ]


def _save(image: Image.Image, path: Path) -> Path:
    """Write `image` as PNG, with its ``shellvox:*`` info as text chunks."""
    text = PngInfo()
    for key, value in image.info.items():
        if isinstance(key, str) and key.startswith("shellvox:"):
            text.add_text(key, str(value))
    with atomic_path(path) as temporary:
        image.save(temporary, format="PNG", pnginfo=text)
    return path


def _halftone_preview(folder: Path, manifest: dict[str, Any], z: int) -> Path:
    """Draw slice `z` (the one with the most colour-layer voxels): target vs halftone."""
    vx, vy, vz = manifest["grid"]["voxel_size_mm"]
    display = np.zeros((256, 3), dtype=np.uint8)
    names = {}
    for material in manifest["materials"]:
        display[int(material["index"])] = material["display_srgb"]
        names[int(material["index"])] = str(material.get("name", material["index"]))
    with (
        tifffile.TiffFile(folder / "layers.tif") as lt,
        tifffile.TiffFile(folder / "colour.tif") as ct,
        tifffile.TiffFile(folder / "materials.tif") as mt,
    ):
        layers = lt.pages[z].asarray()
        colour = ct.pages[z].asarray()[..., :3]
        materials = mt.pages[z].asarray()
    colour_layers = [layer["index"] for layer in manifest["layers"] if layer["colour"]]
    target = np.where(np.isin(layers, colour_layers)[..., None], colour, display[materials])
    z_mm = manifest["grid"]["origin_mm"][2] + z * vz
    image = halftone_picture(
        target[::-1].astype(np.uint8),
        materials[::-1],
        display,
        material_names=names,
        pixel_mm=(vx, vy),
        title=f"Slice z = {z} ({z_mm:.3f} mm), the one with the most colour-layer voxels, "
        "seen from +z (x right, y up): the target colour beside the halftoned materials",
    )
    return _save(image, folder / "preview" / f"halftone_z{z:05d}.png")
