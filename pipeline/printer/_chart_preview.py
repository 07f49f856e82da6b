"""A top view of the calibration chart: each patch in its predicted colour, with its label."""

from __future__ import annotations

from typing import Any

import colour
import numpy as np

from shellvox.printer._chart import ChartLayout
from shellvox.printer._profile import PrinterProfile
from shellvox.voxel.colour import observer, predict

#: Preview pixels per mm.
PIXELS_PER_MM = 8


def chart_preview(layout: ChartLayout, profile: PrinterProfile) -> Any:
    """Return a PIL image: the chart seen from above (y up), patches in their predicted colour.

    The colour is the two-flux prediction of each patch under the profile's optics (D50,
    gloss included), shown in sRGB; label plates white with their labels.
    """
    from PIL import Image, ImageDraw, ImageFont

    optics = profile.optics
    seen = observer(optics.wavelengths_nm)
    xyz = predict(optics, layout.patches) @ seen.weights
    rgb = colour.XYZ_to_RGB(
        xyz,
        colour.RGB_COLOURSPACES["sRGB"],
        illuminant=seen.white_xy,
        chromatic_adaptation_transform="Bradford",
        apply_cctf_encoding=True,
    )
    codes = np.rint(np.clip(rgb, 0, 1) * 255).astype(int)
    _, n_y, n_x = layout.grid.shape_zyx
    vx, vy, _ = layout.grid.voxel_mm
    width, height = round(n_x * vx * PIXELS_PER_MM), round(n_y * vy * PIXELS_PER_MM)
    image = Image.new("RGB", (width, height), (40, 40, 40))
    draw = ImageDraw.Draw(image)

    def box(b: np.ndarray[Any, Any]) -> tuple[float, float, float, float]:
        x0, y0, x1, y1 = (float(v) for v in b)
        s = PIXELS_PER_MM
        return (x0 * vx * s, height - y1 * vy * s, x1 * vx * s - 1, height - y0 * vy * s - 1)

    font = ImageFont.load_default(size=int(PIXELS_PER_MM * 1.6))
    for code, label, patch_box, label_box in zip(
        codes, layout.labels, layout.boxes, layout.label_boxes, strict=True
    ):
        draw.rectangle(box(patch_box), fill=tuple(int(c) for c in code))
        x0, y0, x1, y1 = box(label_box)
        draw.rectangle((x0, y0, x1, y1), fill=(235, 235, 235))
        draw.text(((x0 + x1) / 2, (y0 + y1) / 2), label, fill=(0, 0, 0), font=font, anchor="mm")
    return image
