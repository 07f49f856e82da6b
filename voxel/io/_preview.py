"""Preview pictures of a layered stack: sections at true aspect and a depth histogram (PNG).

Pure rendering from arrays to :class:`PIL.Image.Image`; reading files is the caller's job.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from PIL import Image, ImageDraw
from scipy import ndimage

#: Display colour of layer 0 (outside), the bands (cycled) and the core (last).
OUTSIDE_RGB = (255, 255, 255)
BAND_RGB = ((120, 120, 120), (170, 150, 110), (110, 150, 170), (150, 110, 170))
CORE_RGB = (60, 60, 60)


def boundary_depths(
    layers: NDArray[np.uint8], pixel_mm: tuple[float, float], n_bands: int
) -> list[NDArray[np.float64]]:
    """Return, per band ``k``, the in-plane depth (mm) of its voxels next to band ``k + 1``.

    Depth is the section's 2-D Euclidean distance to the nearest outside voxel, which is
    at least the true 3-D depth (equal where the surface is perpendicular to the plane).
    """
    depth = ndimage.distance_transform_edt(layers > 0, sampling=(pixel_mm[1], pixel_mm[0]))
    result = []
    for band in range(1, n_bands + 1):
        deeper = ndimage.binary_dilation(layers > band)
        result.append(np.asarray(depth[(layers == band) & deeper], dtype=np.float64))
    return result


def histogram_image(
    depths: list[NDArray[np.float64]],
    expected_mm: list[float],
    *,
    bins: int = 60,
    size: tuple[int, int] = (900, 420),
) -> Image.Image:
    """Draw histograms of band inner-boundary depths with the configured depths as lines.

    Parameters
    ----------
    depths : list of (n,) float64, mm
        Depths per band (see :func:`boundary_depths`).
    expected_mm : list of float, mm
        Configured cumulative depth per band.
    """
    width, height = size
    image = Image.new("RGB", size, (255, 255, 255))
    draw = ImageDraw.Draw(image)
    values = [d for d in depths if len(d)]
    top = max([*(float(np.percentile(d, 99.5)) for d in values), *expected_mm, 1e-3]) * 1.15
    edges = np.linspace(0.0, top, bins + 1)
    counts = [np.histogram(d, bins=edges)[0] for d in depths]
    peak = max([1, *(int(c.max()) for c in counts if len(c))])
    left, bottom, plot_w, plot_h = 50, height - 40, width - 70, height - 80
    bar_w = plot_w / bins
    for band, band_counts in enumerate(counts):
        rgb = BAND_RGB[band % len(BAND_RGB)]
        for index, count in enumerate(band_counts):
            if count:
                x0 = left + index * bar_w
                y0 = bottom - plot_h * count / peak
                draw.rectangle([x0, y0, x0 + bar_w - 1, bottom], outline=rgb)
    for band, depth_mm in enumerate(expected_mm):
        x = left + plot_w * depth_mm / top
        draw.line([x, bottom, x, bottom - plot_h], fill=(200, 0, 0), width=2)
        draw.text((x + 3, 20 + 14 * band), f"band {band + 1}: {depth_mm:g} mm", fill=(200, 0, 0))
    draw.line([left, bottom, left + plot_w, bottom], fill=(0, 0, 0))
    for tick in np.linspace(0.0, top, 6):
        x = left + plot_w * tick / top
        draw.text((x - 10, bottom + 6), f"{tick:.2f}", fill=(0, 0, 0))
    draw.text(
        (left, bottom + 22),
        "depth of each band's inner boundary in the sections (mm)",
        fill=(0, 0, 0),
    )
    return image


def halftone_image(
    target_rgb: NDArray[np.uint8],
    materials: NDArray[np.uint8],
    display_rgb: NDArray[np.uint8],
    *,
    pixel_mm: tuple[float, float],
    inset_voxels: int = 48,
    max_pixels: int = 900,
) -> Image.Image:
    """Render a slice's target colours beside its halftoned materials, with a voxel inset.

    Parameters
    ----------
    target_rgb : (H, W, 3) uint8
        What each voxel should look like: the surface colour in the colour layers and
        the material's display colour elsewhere.
    materials : (H, W) uint8
        Material index per voxel (0 void, drawn white).
    display_rgb : (256, 3) uint8
        Display colour of each material index.
    pixel_mm : (2,) float, mm
        Physical ``(width, height)`` of one voxel.
    inset_voxels : int
        Side of the zoomed square, in voxels, centred on the densest colour.
    max_pixels : int
        Longest side of each of the two full views.

    Returns
    -------
    PIL.Image.Image
        ``[target | halftone]`` at true aspect above ``[target inset | halftone inset]``
        at voxel scale (each voxel a block of pixels).
    """
    palette = np.asarray(display_rgb, dtype=np.uint8).copy()
    palette[0] = OUTSIDE_RGB
    halftone = palette[materials]
    target = np.where((materials == 0)[..., None], np.uint8(255), target_rgb).astype(np.uint8)
    height_mm = materials.shape[0] * pixel_mm[1]
    width_mm = materials.shape[1] * pixel_mm[0]
    scale = max_pixels / max(height_mm, width_mm)
    size = (max(1, round(width_mm * scale)), max(1, round(height_mm * scale)))
    full = [
        Image.fromarray(a, "RGB").resize(size, Image.Resampling.NEAREST) for a in (target, halftone)
    ]
    # inset: the window with the most non-white, non-void voxels of the target
    colourful = (materials > 0) & (np.ptp(target.astype(np.int16), axis=-1) > 24)
    side = max(1, min(inset_voxels, *materials.shape))
    window = ndimage.uniform_filter(colourful.astype(np.float32), size=side, mode="constant")
    cy, cx = np.unravel_index(int(np.argmax(window)), window.shape)
    y0 = int(np.clip(cy - side // 2, 0, materials.shape[0] - side))
    x0 = int(np.clip(cx - side // 2, 0, materials.shape[1] - side))
    crop = (slice(y0, y0 + side), slice(x0, x0 + side))
    block = max(1, round(max_pixels / side / max(pixel_mm) * min(pixel_mm)))
    inset_size = (
        max(1, round(side * block * pixel_mm[0] / min(pixel_mm))),
        max(1, round(side * block * pixel_mm[1] / min(pixel_mm))),
    )
    insets = [
        Image.fromarray(np.ascontiguousarray(a[crop]), "RGB").resize(
            inset_size, Image.Resampling.NEAREST
        )
        for a in (target, halftone)
    ]
    gap = 8
    width = max(2 * size[0], 2 * inset_size[0]) + gap
    height = size[1] + inset_size[1] + gap + 20
    canvas = Image.new("RGB", (width, height), (255, 255, 255))
    canvas.paste(full[0], (0, 0))
    canvas.paste(full[1], (size[0] + gap, 0))
    canvas.paste(insets[0], (0, size[1] + gap))
    canvas.paste(insets[1], (inset_size[0] + gap, size[1] + gap))
    draw = ImageDraw.Draw(canvas)
    draw.text(
        (4, height - 16),
        f"target colour | halftoned materials; inset: {side} x {side} voxels at ({x0}, {y0})",
        fill=(0, 0, 0),
    )
    return canvas


def _palette(n_bands: int) -> NDArray[np.uint8]:
    """Display colour of every layer index: outside, bands (cycled), core, then magenta."""
    return np.array(
        [OUTSIDE_RGB, *(BAND_RGB[k % len(BAND_RGB)] for k in range(n_bands)), CORE_RGB]
        + [(255, 0, 255)] * (256 - n_bands - 2),
        dtype=np.uint8,
    )


#: How much lighter the layers under the colour are drawn in a colour section.
FADE = 0.55


def colour_and_layers(
    layers: NDArray[np.uint8],
    rgb: NDArray[np.uint8],
    *,
    colour_layers: tuple[int, ...],
    n_bands: int,
) -> tuple[NDArray[np.uint8], NDArray[np.uint8]]:
    """Return a section's colour picture and its layer picture, one pixel per voxel.

    Parameters
    ----------
    layers : (H, W) uint8
        Layer index of the section.
    rgb : (H, W, 3) uint8
        sRGB colour of the section (read in the colour layers only).
    colour_layers : tuple of int
        Layers drawn with their surface colour in the colour picture.
    n_bands : int
        ``K``; layer ``K + 1`` is the core.

    Returns
    -------
    colour, layer : (H, W, 3) uint8
        The colour layers in their colour, the other layers lightened, outside white;
        and every layer in its tone (:data:`BAND_RGB`, :data:`CORE_RGB`).
    """
    palette = _palette(n_bands)
    layer_picture = palette[layers]
    faded = (palette + (255 - palette.astype(np.float64)) * FADE).round().astype(np.uint8)
    colour_picture = faded[layers]
    coloured = np.isin(layers, np.asarray(colour_layers, dtype=np.uint8))
    colour_picture[coloured] = rgb[coloured]
    return colour_picture, layer_picture


def section_pair_image(
    layers: NDArray[np.uint8],
    rgb: NDArray[np.uint8],
    *,
    colour_layers: tuple[int, ...],
    n_bands: int,
    pixel_mm: tuple[float, float],
    title: str,
    max_pixels: int = 900,
    inset_voxels: int = 40,
    inset_pixels: int = 420,
) -> Image.Image:
    """Draw a section's colour beside its layers, and both zoomed to voxels below.

    Parameters
    ----------
    layers : (H, W) uint8
        Layer index of the section (rows top to bottom as drawn).
    rgb : (H, W, 3) uint8
        sRGB colour of the section.
    colour_layers, n_bands
        As in :func:`colour_and_layers`.
    pixel_mm : (2,) float, mm
        Physical ``(width, height)`` of one voxel in the section.
    title : str
        A line of text under the pictures.
    max_pixels : int
        Longest side of each full section.
    inset_voxels : int
        Side of the zoomed square, in voxels, centred where most vivid colour-layer
        voxels touch the layers under them.
    inset_pixels : int
        About the side of each zoomed square, in pixels (each voxel a block).

    Returns
    -------
    PIL.Image.Image
        ``[colour | layers]`` at true aspect (nearest resampling: every drawn colour is a
        voxel's), above ``[colour inset | layer inset]``.
    """
    colour, layer = colour_and_layers(layers, rgb, colour_layers=colour_layers, n_bands=n_bands)
    height_mm = layers.shape[0] * pixel_mm[1]
    width_mm = layers.shape[1] * pixel_mm[0]
    scale = max_pixels / max(height_mm, width_mm)
    size = (max(1, round(width_mm * scale)), max(1, round(height_mm * scale)))
    full = [Image.fromarray(a, "RGB").resize(size, Image.Resampling.NEAREST)
            for a in (colour, layer)]  # fmt: skip
    # the inset: where vivid colour meets the layers under it (its depth shows there)
    coloured = np.isin(layers, np.asarray(colour_layers, dtype=np.uint8))
    vivid = coloured & (np.ptp(rgb.astype(np.int16), axis=-1) > 24)
    under = ndimage.binary_dilation((layers > 0) & ~coloured, iterations=2)
    target = next(m for m in (vivid & under, vivid, coloured) if m.any() or m is coloured)
    side_y = max(1, min(inset_voxels, layers.shape[0]))
    side_x = max(1, min(inset_voxels, layers.shape[1]))
    window = ndimage.uniform_filter(target.astype(np.float32), size=(side_y, side_x),
                                    mode="constant")  # fmt: skip
    cy, cx = np.unravel_index(int(np.argmax(window)), window.shape)
    y0 = int(np.clip(cy - side_y // 2, 0, layers.shape[0] - side_y))
    x0 = int(np.clip(cx - side_x // 2, 0, layers.shape[1] - side_x))
    crop = (slice(y0, y0 + side_y), slice(x0, x0 + side_x))
    block = max(1, round(inset_pixels / max(side_x * pixel_mm[0], side_y * pixel_mm[1])
                         * min(pixel_mm)))  # fmt: skip
    inset_size = (
        max(1, round(side_x * block * pixel_mm[0] / min(pixel_mm))),
        max(1, round(side_y * block * pixel_mm[1] / min(pixel_mm))),
    )
    insets = [Image.fromarray(np.ascontiguousarray(a[crop]), "RGB").resize(
        inset_size, Image.Resampling.NEAREST) for a in (colour, layer)]  # fmt: skip
    gap = 8
    width = max(2 * size[0], 2 * inset_size[0]) + gap
    height = size[1] + inset_size[1] + 2 * gap + 36
    canvas = Image.new("RGB", (width, height), (255, 255, 255))
    canvas.paste(full[0], (0, 0))
    canvas.paste(full[1], (size[0] + gap, 0))
    top = size[1] + gap
    canvas.paste(insets[0], (0, top))
    canvas.paste(insets[1], (inset_size[0] + gap, top))
    draw = ImageDraw.Draw(canvas)
    # where the inset comes from, outlined on both full sections
    for left in (0, size[0] + gap):
        box = [left + x0 * size[0] / layers.shape[1], y0 * size[1] / layers.shape[0],
               left + (x0 + side_x) * size[0] / layers.shape[1] - 1,
               (y0 + side_y) * size[1] / layers.shape[0] - 1]  # fmt: skip
        draw.rectangle(box, outline=(255, 0, 255))
    draw.text((4, height - 32), title, fill=(0, 0, 0))
    draw.text((4, height - 16), f"colour | layers; below: {side_x} x {side_y} voxels at "
              f"voxel scale (magenta box)", fill=(0, 0, 0))  # fmt: skip
    return canvas


def outer_views_image(
    views: list[tuple[str, NDArray[np.uint8], NDArray[np.bool_], tuple[float, float]]],
    *,
    pixels_per_mm: float,
) -> Image.Image:
    """Draw orthographic views of the outer colour layer, all at one scale.

    Parameters
    ----------
    views : list of (label, (H, W, 3) uint8, (H, W) bool, (2,) float)
        Per view: its name, the colour seen at each pixel (rows top to bottom as
        drawn), where the model is, and the physical ``(width, height)`` of one pixel
        in mm.
    pixels_per_mm : float
        Drawing scale.

    Returns
    -------
    PIL.Image.Image
        The views in rows of three on white, each labelled.
    """
    pictures = []
    for label, rgb, hit, pixel_mm in views:
        picture = np.where(hit[..., None], rgb, np.uint8(255)).astype(np.uint8)
        size = (max(1, round(rgb.shape[1] * pixel_mm[0] * pixels_per_mm)),
                max(1, round(rgb.shape[0] * pixel_mm[1] * pixels_per_mm)))  # fmt: skip
        image = Image.fromarray(picture, "RGB").resize(size, Image.Resampling.NEAREST)
        pictures.append((label, image))
    gap, label_h, columns = 12, 18, 3
    rows = [pictures[i : i + columns] for i in range(0, len(pictures), columns)]
    widths = [max(p[1].size[0] for p in col) for col in zip(*rows, strict=False)]
    heights = [max(p[1].size[1] for p in row) for row in rows]
    canvas = Image.new(
        "RGB",
        (sum(widths) + gap * (len(widths) + 1), sum(heights) + (gap + label_h) * len(rows) + gap),
        (255, 255, 255),
    )
    draw = ImageDraw.Draw(canvas)
    y = gap
    for row, row_height in zip(rows, heights, strict=True):
        x = gap
        for (label, image), column_width in zip(row, widths, strict=False):
            draw.text((x, y), label, fill=(0, 0, 0))
            canvas.paste(image, (x, y + label_h))
            x += column_width + gap
        y += row_height + label_h + gap
    return canvas
