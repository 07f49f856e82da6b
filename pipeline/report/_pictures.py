"""The preview pictures, each with its title, labelled panels and a key (PNG, via Pillow).

Pure rendering from arrays to :class:`PIL.Image.Image`; :mod:`shellvox.report._previews`
reads the build. Voxels are drawn by nearest resampling, so every colour of a panel is a
voxel's or one of the layer tones (:func:`layer_tones`); the key's swatches hold exactly
those colours (:mod:`shellvox.report._key`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray
from PIL import Image, ImageDraw
from scipy import ndimage

from shellvox.report._key import (
    RGB,
    TEXT_RGB,
    WHITE,
    KeyRow,
    Swatch,
    caption_font,
    framed,
    labelled_grid,
    line_height,
)
from shellvox.voxel.io import BAND_RGB, CORE_RGB, FADE, OUTSIDE_RGB

#: Longest side of a whole section or slice, pixels.
FULL_PIXELS = 900
#: Least and most side of a zoomed square, pixels (it matches the whole section's side).
INSET_PIXELS = (240, 420)
#: Outline of the zoomed square on the whole sections.
INSET_BOX_RGB = (255, 0, 255)
#: A voxel is vivid when its sRGB channels span more than this (where the inset goes).
VIVID_SPAN = 24
#: Colour of the configured depths in the depth histogram.
DEPTH_LINE_RGB = (200, 0, 0)


def layer_tones(n_bands: int) -> tuple[NDArray[np.uint8], NDArray[np.uint8]]:
    """Return the tone of every layer index, and its lightened tone (under the colour).

    Parameters
    ----------
    n_bands : int
        ``K``; layer 0 is outside, ``1..K`` the bands, ``K + 1`` the core.

    Returns
    -------
    tone, faded : (256, 3) uint8
        Outside white, the bands in :data:`~shellvox.voxel.io.BAND_RGB` (cycled), the core
        in :data:`~shellvox.voxel.io.CORE_RGB`, other indices magenta; ``faded`` is each
        lightened by :data:`~shellvox.voxel.io.FADE` towards white.
    """
    tone = np.array(
        [OUTSIDE_RGB, *(BAND_RGB[k % len(BAND_RGB)] for k in range(n_bands)), CORE_RGB]
        + [(255, 0, 255)] * (256 - n_bands - 2),
        dtype=np.uint8,
    )
    faded = (tone + (255 - tone.astype(np.float64)) * FADE).round().astype(np.uint8)
    return tone, faded


def _rgb(value: Sequence[int] | NDArray[np.uint8]) -> RGB:
    return (int(value[0]), int(value[1]), int(value[2]))


def _densest(mask: NDArray[np.bool_], side_y: int, side_x: int) -> tuple[int, int]:
    """Return the corner ``(y0, x0)`` of the ``side_y x side_x`` window with most of ``mask``."""
    window = ndimage.uniform_filter(mask.astype(np.float32), size=(side_y, side_x), mode="constant")
    cy, cx = np.unravel_index(int(np.argmax(window)), window.shape)
    y0 = int(np.clip(cy - side_y // 2, 0, mask.shape[0] - side_y))
    x0 = int(np.clip(cx - side_x // 2, 0, mask.shape[1] - side_x))
    return y0, x0


def _whole_and_zoomed(
    panels: Sequence[tuple[str, NDArray[np.uint8]]],
    focus: NDArray[np.bool_],
    pixel_mm: tuple[float, float],
    inset_voxels: int,
) -> tuple[Image.Image, str]:
    """Lay two pictures of one plane whole (true aspect) and zoomed to voxels where ``focus`` is.

    The zoomed square is ``inset_voxels`` voxels of the coarser axis on each side (square
    in mm), each voxel a block of pixels. A wide plane gives rows ``[whole | zoomed]``, a
    tall one columns; a plane no larger than the square is drawn whole only. Returns the
    body and a description of the zoomed square.
    """
    height, width = focus.shape
    height_mm, width_mm = height * pixel_mm[1], width * pixel_mm[0]
    scale = FULL_PIXELS / max(height_mm, width_mm)
    size = (max(1, round(width_mm * scale)), max(1, round(height_mm * scale)))
    wide = size[0] >= size[1]
    inset_px = int(np.clip(size[1] if wide else size[0], *INSET_PIXELS))
    side_mm = inset_voxels * max(pixel_mm)  # a square in mm, ``inset_voxels`` coarse voxels
    side_x = max(1, min(round(side_mm / pixel_mm[0]), width))
    side_y = max(1, min(round(side_mm / pixel_mm[1]), height))
    y0, x0 = _densest(focus, side_y, side_x)
    block = max(1, round(inset_px / side_mm * min(pixel_mm)))  # pixels per finest voxel
    inset_size = (max(1, round(side_x * block * pixel_mm[0] / min(pixel_mm))),
                  max(1, round(side_y * block * pixel_mm[1] / min(pixel_mm))))  # fmt: skip
    box = (x0 * size[0] / width, y0 * size[1] / height,
           (x0 + side_x) * size[0] / width - 1, (y0 + side_y) * size[1] / height - 1)  # fmt: skip
    whole, zoomed = [], []
    if side_x == width and side_y == height:  # the whole plane is voxels large already
        for label, array in panels:
            picture = Image.fromarray(np.ascontiguousarray(array), "RGB")
            whole.append((label, picture.resize(size, Image.Resampling.NEAREST)))
        return labelled_grid(whole, 2), f"{width} x {height} voxels"
    for label, array in panels:
        picture = Image.fromarray(np.ascontiguousarray(array), "RGB")
        full = picture.resize(size, Image.Resampling.NEAREST)
        ImageDraw.Draw(full).rectangle(box, outline=INSET_BOX_RGB)
        whole.append((label, full))
        crop = picture.crop((x0, y0, x0 + side_x, y0 + side_y))
        zoomed.append((f"{label}, zoomed", crop.resize(inset_size, Image.Resampling.NEAREST)))
    cells = (
        [c for pair in zip(whole, zoomed, strict=True) for c in pair] if wide else whole + zoomed
    )
    where = (
        f"zoomed: {side_x} x {side_y} voxels ({side_x * pixel_mm[0]:.2f} x "
        f"{side_y * pixel_mm[1]:.2f} mm) from ({x0}, {y0}) as drawn, the magenta box"
    )
    return labelled_grid(cells, 2), where


def section_picture(
    layers: NDArray[np.uint8],
    rgb: NDArray[np.uint8],
    *,
    colour_layers: Sequence[int],
    layer_names: Sequence[str],
    pixel_mm: tuple[float, float],
    title: str,
    inset_voxels: int = 40,
) -> Image.Image:
    """Draw a section's colour and its layers, whole and zoomed, with the layers' key.

    Parameters
    ----------
    layers : (H, W) uint8
        Layer index of the section (rows top to bottom as drawn).
    rgb : (H, W, 3) uint8
        sRGB colour of the section (read in the colour layers only).
    colour_layers : sequence of int
        Layers drawn in their surface colour in the colour panel.
    layer_names : sequence of str
        Name of each layer index, outside first and core last (``K + 2`` names).
    pixel_mm : (2,) float, mm
        Physical ``(width, height)`` of one voxel in the section.
    title : str
        The caption above.
    inset_voxels : int
        Side of the zoomed square, in voxels along the coarser axis, where vivid colour
        meets the layers under it.

    Returns
    -------
    PIL.Image.Image
        The colour panel shows the colour layers in their colour and the other layers in
        their lightened tones; the layers panel every layer in its tone. The key names each
        layer with both swatches.
    """
    n_bands = len(layer_names) - 2
    tone, faded = layer_tones(n_bands)
    coloured = np.isin(layers, np.asarray(colour_layers, dtype=np.uint8))
    colour = faded[layers]
    colour[coloured] = rgb[coloured]
    vivid = coloured & (np.ptp(rgb.astype(np.int16), axis=-1) > VIVID_SPAN)
    under = ndimage.binary_dilation((layers > 0) & ~coloured, iterations=2)
    focus = next(m for m in (vivid & under, vivid, coloured) if m.any() or m is coloured)
    body, where = _whole_and_zoomed(
        [("colour", colour), ("layers", tone[layers])], focus, pixel_mm, inset_voxels
    )
    is_colour = set(int(c) for c in colour_layers)
    under_colour = [Swatch(name, _rgb(faded[i])) for i, name in enumerate(layer_names)
                    if i not in is_colour and i > 0]  # fmt: skip
    key = [
        KeyRow("layers", [Swatch(name, _rgb(tone[i])) for i, name in enumerate(layer_names)]),
        KeyRow("colour, under the colour layers", under_colour),
    ]
    colour_names = ", ".join(layer_names[i] for i in sorted(is_colour) if i < len(layer_names))
    notes = [f"colour: {colour_names or 'no layer'} in the surface colour; {where}"]
    return framed(body, title=title, key=key, notes=notes)


def halftone_picture(
    target_rgb: NDArray[np.uint8],
    materials: NDArray[np.uint8],
    display_rgb: NDArray[np.uint8],
    *,
    material_names: dict[int, str],
    pixel_mm: tuple[float, float],
    title: str,
    inset_voxels: int = 48,
) -> Image.Image:
    """Draw a slice's target colours beside its halftoned materials, whole and zoomed.

    Parameters
    ----------
    target_rgb : (H, W, 3) uint8
        What each voxel should look like: the surface colour in the colour layers, the
        material's display colour elsewhere.
    materials : (H, W) uint8
        Material index per voxel (0 void, drawn white).
    display_rgb : (256, 3) uint8
        Display colour of each material index.
    material_names : dict of int to str
        Name of each material index (the key lists them all).
    pixel_mm : (2,) float, mm
        Physical ``(width, height)`` of one voxel.
    title : str
        The caption above.
    inset_voxels : int
        Side of the zoomed square, in voxels along the coarser axis, where the target's
        colour is densest.

    Returns
    -------
    PIL.Image.Image
    """
    palette = np.asarray(display_rgb, dtype=np.uint8).copy()
    palette[0] = OUTSIDE_RGB
    halftone = palette[materials]
    target = np.where((materials == 0)[..., None], np.uint8(255), target_rgb).astype(np.uint8)
    focus = (materials > 0) & (np.ptp(target.astype(np.int16), axis=-1) > VIVID_SPAN)
    body, where = _whole_and_zoomed(
        [("target colour", target), ("halftoned materials", halftone)],
        focus,
        pixel_mm,
        inset_voxels,
    )
    key = [KeyRow("materials", [Swatch(name, _rgb(palette[index]))
                                for index, name in sorted(material_names.items())])]  # fmt: skip
    notes = ["target colour: the surface colour in the colour layers, the material's colour "
             f"elsewhere; {where}"]  # fmt: skip
    return framed(body, title=title, key=key, notes=notes)


def outer_views_picture(
    views: Sequence[tuple[str, NDArray[np.uint8], NDArray[np.bool_], tuple[float, float]]],
    *,
    pixels_per_mm: float,
    title: str,
    columns: int = 3,
) -> Image.Image:
    """Draw orthographic views of the outer colour layer, all at one scale, in rows.

    Parameters
    ----------
    views : sequence of (str, (H, W, 3) uint8, (H, W) bool, (2,) float)
        Per view: its name, the colour seen at each pixel (rows top to bottom as drawn),
        where the model is, and the physical ``(width, height)`` of one pixel in mm.
    pixels_per_mm : float
        Drawing scale.
    title : str
        The caption above.
    columns : int
        Views per row.

    Returns
    -------
    PIL.Image.Image
    """
    cells = []
    for label, rgb, hit, pixel_mm in views:
        picture = np.where(hit[..., None], rgb, np.uint8(255)).astype(np.uint8)
        size = (max(1, round(rgb.shape[1] * pixel_mm[0] * pixels_per_mm)),
                max(1, round(rgb.shape[0] * pixel_mm[1] * pixels_per_mm)))  # fmt: skip
        image = Image.fromarray(picture, "RGB").resize(size, Image.Resampling.NEAREST)
        cells.append((label, image))
    key = [KeyRow("", [Swatch("no part on the line of sight", WHITE)])]
    return framed(labelled_grid(cells, columns), title=title, key=key)


def depth_histogram_picture(
    depths: Sequence[NDArray[np.float64]],
    expected_mm: Sequence[float],
    *,
    band_names: Sequence[str],
    title: str,
    bins: int = 60,
    size: tuple[int, int] = (860, 320),
) -> Image.Image:
    """Draw histograms of the bands' inner-boundary depths with the configured depths.

    Parameters
    ----------
    depths : sequence of (n,) float64, mm
        Depths per band (:func:`shellvox.voxel.io.boundary_depths`).
    expected_mm : sequence of float, mm
        Configured cumulative depth per band (drawn as lines).
    band_names : sequence of str
        Name of each band.
    title : str
        The caption above.
    bins : int
        Bars across the depth axis.
    size : (2,) int
        The plot's ``(width, height)`` in pixels, axis labels included.

    Returns
    -------
    PIL.Image.Image
    """
    font = caption_font()
    line = line_height(font)
    width, height = size
    plot = Image.new("RGB", size, WHITE)
    draw = ImageDraw.Draw(plot)
    values = [d for d in depths if len(d)]
    top = max([*(float(np.percentile(d, 99.5)) for d in values), *expected_mm, 1e-3]) * 1.15
    edges = np.linspace(0.0, top, bins + 1)
    counts = [np.histogram(d, bins=edges)[0] for d in depths]
    peak = max([1, *(int(c.max()) for c in counts if len(c))])
    left, bottom = 10, height - 2 * line - 6
    plot_w, plot_h = width - 2 * left, bottom - 4
    bar_w = plot_w / bins
    colours = [_rgb(BAND_RGB[band % len(BAND_RGB)]) for band in range(len(depths))]
    for band_counts, rgb in zip(counts, colours, strict=True):
        for index in np.flatnonzero(band_counts):
            x0 = left + index * bar_w
            y0 = bottom - plot_h * band_counts[index] / peak
            draw.rectangle([x0, y0, x0 + bar_w - 1, bottom], outline=rgb, width=2)
    for depth_mm in expected_mm:
        x = left + plot_w * depth_mm / top
        draw.line([x, bottom, x, bottom - plot_h], fill=DEPTH_LINE_RGB, width=2)
    draw.line([left, bottom, left + plot_w, bottom], fill=TEXT_RGB)
    for tick in np.linspace(0.0, top, 6):
        x = left + plot_w * tick / top
        draw.line([x, bottom, x, bottom + 4], fill=TEXT_RGB)
        text = f"{tick:.2f}"
        half = font.getlength(text) / 2
        draw.text((min(max(x - half, 0), width - 2 * half), bottom + 5), text, fill=TEXT_RGB,
                  font=font)  # fmt: skip
    axis = f"depth (mm); bar height: voxels, the tallest {peak:,}"
    draw.text((left, bottom + 5 + line), axis, fill=TEXT_RGB, font=font)
    key = [
        KeyRow("bands", [Swatch(n, c) for n, c in zip(band_names, colours, strict=True)]),
        KeyRow("configured depth", [Swatch(f"{n}: {d:g} mm", DEPTH_LINE_RGB)
                                    for n, d in zip(band_names, expected_mm, strict=True)]),
    ]  # fmt: skip
    return framed(plot, title=title, key=key)
