"""The calibration chart: printable patches of known stacks, laid out on the printer's tray.

The patches are :func:`shellvox.voxel.colour._calibration.chart_patches` made printable: every
patch whose last layer is not pure white or pure black stands on :data:`BASE_MM` of
black, so that what lies beneath its last layer reflects (almost) nothing, as the model
assumes (``chart.json`` lists that base as the patch's last layer). Every layer is a
whole number of slices (at least one): ``chart.json`` records the printed thickness.

Layout (all sizes in mm, on the printer's grid, x to the right, y up, seen from above):
each patch is a :data:`PATCH_MM` square column standing on the tray, its layers listed
top first from its own top surface down (patches differ in height); below each patch,
:data:`LABEL_GAP_MM` away, a white label plate :data:`LABEL_MM` deep and
:data:`LABEL_PLATE_MM` tall carries the patch's label (``P001``, the id up to its first
``-``) in black in its top :data:`LABEL_TEXT_MM`; cells are :data:`GAP_MM` apart in rows
of ``columns``, with :data:`MARGIN_MM` of void around the chart. A mixed layer is
halftoned with the blue-noise tile (:mod:`shellvox.voxel.colour._blue_noise`) at the voxel's
global index: material ``j`` where the threshold first falls below the cumulative share
(the rule of :mod:`shellvox.voxel.colour._materials`).

Measure each patch in its middle with a d/8 spectrophotometer, specular included (SCI),
the chart lying on a black surface.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import NDArray

from shellvox.printer._profile import PrinterProfile
from shellvox.voxel.colour import DEFAULT_TILE, Patch, blue_noise_tile, chart_patches
from shellvox.voxel.grid import GridSpec

PATCH_MM = 8.0
GAP_MM = 2.0
LABEL_GAP_MM = 0.5
LABEL_MM = 2.5
LABEL_PLATE_MM = 0.5
LABEL_TEXT_MM = 0.2
MARGIN_MM = 2.0
BASE_MM = 1.0
#: Pixels of the label text per label height (Pillow's default font).
_FONT_FRACTION = 0.8


@dataclass(frozen=True, eq=False)
class ChartLayout:
    """Where every patch and label is on the grid, and what each patch is made of.

    Attributes
    ----------
    grid : GridSpec
        The chart's voxel grid (voxel ``(0, 0, 0)`` at the tray's corner).
    patches : list of Patch
        Printed patches (thickness a whole number of slices), materials in the order of
        ``material_indices``.
    slices : list of (L,) int64
        Each patch's layers in slices, top first.
    material_indices : (M,) uint8
        The profile's index of each of the patches' materials.
    boxes : (N, 4) int64
        Each patch's voxel box ``(x0, y0, x1, y1)`` (exclusive ends).
    labels : list of str
        Each patch's label.
    label_boxes : (N, 4) int64
        Each label plate's voxel box.
    white, black : int
        Profile indices of the label plate and the label text.
    """

    grid: GridSpec
    patches: list[Patch]
    slices: list[NDArray[np.int64]]
    material_indices: NDArray[np.uint8]
    boxes: NDArray[np.int64]
    labels: list[str]
    label_boxes: NDArray[np.int64]
    white: int
    black: int

    @cached_property
    def label_text(self) -> NDArray[np.bool_]:
        """The labels' text ``(Y, X) bool`` on the grid (True: black)."""
        return _label_text(self)


def chart_layout(
    profile: PrinterProfile, *, patch_mm: float = PATCH_MM, columns: int | None = None
) -> ChartLayout:
    """Return the chart for `profile`: patches, their printed thickness and their places.

    Parameters
    ----------
    profile : PrinterProfile
        Needs white and black materials.
    patch_mm : float, mm
        Edge of a patch.
    columns : int, optional
        Patches per row (default: about square).
    """
    optics = profile.optics
    roles = optics.roles
    if "white" not in roles or "black" not in roles:
        raise ValueError(f"a chart needs white and black materials, the profile has {roles}")
    vx, vy, vz = profile.voxel_mm
    white, black = roles.index("white"), roles.index("black")
    patches, slices = [], []
    for patch in chart_patches(roles):
        fractions, thickness = patch.fractions, patch.thickness_mm
        last = fractions[-1]
        if not (last[white] == 1.0 or last[black] == 1.0):
            fractions = np.vstack([fractions, np.eye(len(roles))[black]])
            thickness = np.append(thickness, BASE_MM)
        n = np.maximum(1, np.rint(thickness / vz)).astype(np.int64)
        patches.append(Patch(patch.patch_id, fractions, (n * vz).astype(np.float64)))
        slices.append(n)
    count = len(patches)
    columns = columns or math.ceil(math.sqrt(count))
    rows = math.ceil(count / columns)
    pitch_x, pitch_y = patch_mm + GAP_MM, patch_mm + LABEL_GAP_MM + LABEL_MM + GAP_MM
    size_x = 2 * MARGIN_MM + columns * pitch_x - GAP_MM
    size_y = 2 * MARGIN_MM + rows * pitch_y - GAP_MM
    height = max(int(n.sum()) for n in slices)
    grid = GridSpec(
        (vx / 2, vy / 2, vz / 2),
        (vx, vy, vz),
        (height, math.ceil(size_y / vy), math.ceil(size_x / vx)),
    )
    order = np.arange(count, dtype=np.float64)
    col, row = order % columns, order // columns
    x0 = MARGIN_MM + col * pitch_x
    top = size_y - MARGIN_MM - row * pitch_y  # first row at the top (far y), read like a page
    y0 = top - patch_mm
    boxes = _voxel_boxes(x0, y0, x0 + patch_mm, top, vx, vy)
    label_top = y0 - LABEL_GAP_MM
    label_boxes = _voxel_boxes(x0, label_top - LABEL_MM, x0 + patch_mm, label_top, vx, vy)
    indices = np.array([m.index for m in profile.materials[1:]], np.uint8)
    return ChartLayout(
        grid,
        patches,
        slices,
        indices,
        boxes,
        [p.patch_id.split("-")[0] for p in patches],
        label_boxes,
        int(indices[white]),
        int(indices[black]),
    )


def _voxel_boxes(
    x0: NDArray[np.float64],
    y0: NDArray[np.float64],
    x1: NDArray[np.float64],
    y1: NDArray[np.float64],
    vx: float,
    vy: float,
) -> NDArray[np.int64]:
    """Voxel boxes ``(N, 4)`` of mm rectangles: the voxels whose centres lie inside."""
    corners = [np.rint(x0 / vx), np.rint(y0 / vy), np.rint(x1 / vx), np.rint(y1 / vy)]
    boxes: NDArray[np.int64] = np.stack(corners, axis=1).astype(np.int64)
    return boxes


def chart_slab(layout: ChartLayout, z_start: int, z_stop: int) -> NDArray[np.uint8]:
    """Return the material indices ``(Zs, Y, X) uint8`` of slices ``z_start .. z_stop - 1``.

    Slice 0 lies on the tray. Void (0) around the patches and labels.
    """
    _, n_y, n_x = layout.grid.shape_zyx
    out = np.zeros((z_stop - z_start, n_y, n_x), np.uint8)
    tile = blue_noise_tile(DEFAULT_TILE)
    s = tile.shape[0]
    for patch, slices, box in zip(layout.patches, layout.slices, layout.boxes, strict=True):
        x0, y0, x1, y1 = (int(v) for v in box)  # loop over patches (tens) and their layers
        top = int(slices.sum())  # layer l spans slices top - ends[l] .. top - starts[l] - 1
        ends = np.cumsum(slices)
        for fractions, start, end in zip(patch.fractions, ends - slices, ends, strict=True):
            lo, hi = max(z_start, top - int(end)), min(z_stop, top - int(start))
            if lo >= hi:
                continue
            target = out[lo - z_start : hi - z_start, y0:y1, x0:x1]
            if np.count_nonzero(fractions) == 1:
                target[...] = layout.material_indices[int(np.argmax(fractions))]
                continue
            cumulative = np.cumsum(fractions)
            cumulative[-1] = np.inf  # rounding never leaves a voxel without material
            thresholds = tile[
                np.ix_(np.arange(lo, hi) % s, np.arange(y0, y1) % s, np.arange(x0, x1) % s)
            ]
            pick = np.searchsorted(cumulative, thresholds, side="right")
            target[...] = layout.material_indices[pick]
    plate = max(1, round(LABEL_PLATE_MM / layout.grid.voxel_mm[2]))
    text = max(1, round(LABEL_TEXT_MM / layout.grid.voxel_mm[2]))
    for zi in range(z_start, min(z_stop, plate)):  # loop over the label's slices (tens)
        plane = out[zi - z_start]
        for x0, y0, x1, y1 in layout.label_boxes:
            plane[y0:y1, x0:x1] = layout.white
        if zi >= plate - text:
            plane[layout.label_text] = layout.black
    return out


def _label_text(layout: ChartLayout) -> NDArray[np.bool_]:
    """Render each label with Pillow's default font into its plate (on the grid)."""
    from PIL import Image, ImageDraw, ImageFont

    vx, vy, _ = layout.grid.voxel_mm
    _, n_y, n_x = layout.grid.shape_zyx
    mask = np.zeros((n_y, n_x), bool)
    for label, (x0, y0, x1, y1) in zip(layout.labels, layout.label_boxes, strict=True):
        width, height = int(x1 - x0), round((y1 - y0) * vy / vx)  # square pixels of vx
        font = ImageFont.load_default(size=max(6, int(height * _FONT_FRACTION)))
        image = Image.new("L", (width, height), 0)
        draw = ImageDraw.Draw(image)
        left, top, right, bottom = draw.textbbox((0, 0), label, font=font)
        draw.text(
            ((width - (right - left)) / 2 - left, (height - (bottom - top)) / 2 - top),
            label,
            fill=255,
            font=font,
        )
        pixels = np.asarray(image) > 127  # row 0 at the top (far y)
        rows = np.arange(y0, y1)
        source = np.clip(((y1 - 0.5 - rows) * vy / vx).astype(np.int64), 0, height - 1)
        mask[y0:y1, x0:x1] = pixels[source]
    return mask


def chart_json(layout: ChartLayout, profile: PrinterProfile, profile_text: str) -> dict[str, Any]:
    """Return the content of ``chart.json`` (see ``shellvox chart``).

    ``printer`` keeps the profile's name, source and whole TOML text (what ``shellvox
    calibrate`` writes back with the fitted optics).
    """
    optics = profile.optics
    manifest = optics.manifest()
    manifest["materials"] = [
        {"name": n, "role": r, "k_per_mm": k.tolist(), "s_per_mm": s.tolist()}
        for n, r, k, s in zip(
            optics.names, optics.roles, optics.k_per_mm, optics.s_per_mm, strict=True
        )
    ]
    vx, vy, _ = layout.grid.voxel_mm
    patches = []
    for patch, label, box in zip(layout.patches, layout.labels, layout.boxes, strict=True):
        layers = [
            {
                "fractions": {
                    name: round(float(share), 6)
                    for name, share in zip(optics.names, row, strict=True)
                    if share > 0
                },
                "thickness_mm": round(float(t), 6),
            }
            for row, t in zip(patch.fractions, patch.thickness_mm, strict=True)
        ]
        x0, y0, x1, y1 = (float(v) for v in box)
        patches.append(
            {
                "id": patch.patch_id,
                "label": label,
                "box_mm": [
                    round(x0 * vx, 3),
                    round(y0 * vy, 3),
                    round(x1 * vx, 3),
                    round(y1 * vy, 3),
                ],
                "layers": layers,
            }
        )
    return {
        "format": "shellvox-chart",
        "version": 1,
        "printer": {"name": profile.name, "source": profile.source, "toml": profile_text},
        "measure": "spectral reflectance, d/8, specular included (SCI), chart on black",
        "optics": manifest,
        "patches": patches,
    }
