"""The soft proof's picture: each outer view as targeted, as predicted, and their errors.

:func:`soft_proof_image` draws one row per view, four panels each: the target colour, the
colour predicted from the voxels as written, the CIEDE2000 between them, and the part of
it the printing adds (the prediction against the separation's aim). Errors are drawn in
the steps of :data:`DE_STEPS` (:func:`de_colours`), colours from ColorBrewer's YlOrRd;
pixels whose target lies outside the printer's gamut are hatched in the total error's
panel (there the error is mostly the gamut's, which no printing removes). A scale and the
legend's lines close the picture. The picture's ``info["shellvox:panels"]`` (saved as a
PNG text chunk by the previews) is JSON: per view label, per panel name
(:data:`PANELS`), its box ``[left, top, width, height]`` in pixels.
"""

from __future__ import annotations

import json
import textwrap
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray
from PIL import Image, ImageDraw

#: Lower bounds of the error steps (CIEDE2000); the last step is open.
DE_STEPS = (0.0, 1.0, 2.0, 3.0, 5.0, 10.0)
#: sRGB of each step (ColorBrewer YlOrRd, 6 classes).
DE_RGB = np.array(
    [(255, 255, 178), (254, 217, 118), (254, 178, 76), (253, 141, 60), (240, 59, 32), (189, 0, 38)],
    np.uint8,
)
#: sRGB where the model is seen but nothing was predicted.
NO_PREDICTION_RGB = (200, 200, 200)
#: sRGB of the hatching over out-of-gamut targets, and its period (pixels).
HATCH_RGB = (40, 40, 40)
HATCH_PERIOD = 6
BACKGROUND = (255, 255, 255)
#: The panels of each view, left to right.
PANELS = ("target", "predicted", "total_de", "reproduction_de")


class ProofView(NamedTuple):
    """One outer view of the soft proof, rows top to bottom as drawn.

    Attributes
    ----------
    label : str
    hit : (H, W) bool
        Where the model is seen.
    target, predicted : (H, W, 3) uint8
        sRGB of the target and of the prediction.
    total_de, reproduction_de : (H, W) float64
        CIEDE2000 of the prediction against the target and against the aim (NaN: none).
    out_of_gamut : (H, W) bool
        The target lies outside the gamut.
    """

    label: str
    hit: NDArray[np.bool_]
    target: NDArray[np.uint8]
    predicted: NDArray[np.uint8]
    total_de: NDArray[np.float64]
    reproduction_de: NDArray[np.float64]
    out_of_gamut: NDArray[np.bool_]


def de_colours(delta_e: NDArray[np.float64]) -> NDArray[np.uint8]:
    """Return the scale's sRGB ``(..., 3) uint8`` of errors (grey where NaN).

    Examples
    --------
    >>> de_colours(np.array([0.5, 2.5, 12.0])).tolist()
    [[255, 255, 178], [254, 178, 76], [189, 0, 38]]
    """
    values = np.asarray(delta_e, np.float64)
    step = np.clip(np.searchsorted(DE_STEPS, np.nan_to_num(values, nan=0.0), "right") - 1, 0, 5)
    out = DE_RGB[step]
    out[np.isnan(values)] = NO_PREDICTION_RGB
    return out


def hatching(shape: tuple[int, int]) -> NDArray[np.bool_]:
    """Return the hatching's pixels ``(H, W) bool``: diagonal lines, :data:`HATCH_PERIOD` apart."""
    rows, cols = np.indices(shape)
    lines: NDArray[np.bool_] = (rows + cols) % HATCH_PERIOD == 0
    return lines


def soft_proof_image(views: Sequence[ProofView], legend: Sequence[str]) -> Image.Image:
    """Draw the views, four panels each, with the error scale and the legend's lines.

    Parameters
    ----------
    views : sequence of ProofView
        Each at the size it is drawn (one pixel per image pixel).
    legend : sequence of str
        Lines printed under the scale (the model, its optics, the sampling).

    Returns
    -------
    PIL.Image.Image
    """
    titles = (
        "target",
        "predicted print",
        "CIEDE2000, predicted vs target",
        "CIEDE2000, predicted vs aim",
    )
    boxes: dict[str, dict[str, list[int]]] = {}
    gap, label_h = 12, 18
    width = max(view.hit.shape[1] for view in views)
    panel_w = max(width, 190)
    rows = []
    for view in views:
        white = np.array(BACKGROUND, np.uint8)
        total = de_colours(view.total_de)
        total[view.out_of_gamut & hatching(view.hit.shape)] = HATCH_RGB
        panels = [
            view.target,
            view.predicted,
            total,
            de_colours(view.reproduction_de),
        ]
        rows.append([np.where(view.hit[..., None], p, white).astype(np.uint8) for p in panels])
    heights = [view.hit.shape[0] for view in views]
    canvas_w = 4 * panel_w + 5 * gap
    lines = [part for text in legend for part in textwrap.wrap(text, (canvas_w - 2 * gap) // 6)]
    scale_h = 40 + 16 * len(lines)
    canvas = Image.new(
        "RGB",
        (canvas_w, label_h + sum(heights) + (gap + label_h) * len(views) + scale_h),
        BACKGROUND,
    )
    draw = ImageDraw.Draw(canvas)
    for column, title in enumerate(titles):
        draw.text((gap + column * (panel_w + gap), 4), title, fill=(0, 0, 0))
    y = label_h
    for view, panels, height in zip(views, rows, heights, strict=True):
        draw.text((gap, y + 2), view.label, fill=(80, 80, 80))
        boxes[view.label] = {}
        for column, panel in enumerate(panels):
            left, top = gap + column * (panel_w + gap), y + label_h
            canvas.paste(Image.fromarray(panel, "RGB"), (left, top))
            boxes[view.label][PANELS[column]] = [left, top, panel.shape[1], panel.shape[0]]
        y += height + label_h + gap
    _scale(canvas, draw, gap, y)
    canvas.info["shellvox:panels"] = json.dumps(boxes)
    for line, text in enumerate(lines):
        draw.text((gap, y + 40 + 16 * line), text, fill=(0, 0, 0))
    return canvas


def _scale(canvas: Image.Image, draw: ImageDraw.ImageDraw, x: int, y: int) -> None:
    """Draw the error steps' swatches with their bounds, the hatching's and no prediction's."""
    bounds = [*DE_STEPS[1:], None]
    for step, (low, high) in enumerate(zip(DE_STEPS, bounds, strict=True)):
        left = x + step * 70
        draw.rectangle((left, y, left + 20, y + 14), fill=tuple(int(v) for v in DE_RGB[step]))
        text = f"{low:g}-{high:g}" if high is not None else f">= {low:g}"
        draw.text((left + 24, y + 2), text, fill=(0, 0, 0))
    left = x + 6 * 70
    draw.rectangle((left, y, left + 20, y + 14), fill=NO_PREDICTION_RGB)
    draw.text((left + 24, y + 2), "no prediction", fill=(0, 0, 0))
    left += 120
    swatch = np.broadcast_to(DE_RGB[0], (15, 21, 3)).copy()
    swatch[hatching((15, 21))] = HATCH_RGB
    canvas.paste(Image.fromarray(swatch, "RGB"), (left, y))
    draw.text((left + 24, y + 2), "target out of gamut (any step)", fill=(0, 0, 0))
