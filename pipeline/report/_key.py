"""Captions and keys of the preview pictures: a title above, labelled panels, a key below.

Text is drawn in Pillow's bundled sans-serif at :data:`CAPTION_PX` pixels (the pictures
are meant to be read at 100 %), black on white, so its antialiasing adds only neutral
greys. A key entry is a square swatch filled with exactly the colour the picture draws
(inside a neutral grey outline, so that white reads as a swatch too) and a name. The
frame's margins are :data:`MARGIN`; panels sit :data:`GAP` apart.

:func:`framed` records where its key is as the picture's ``info["shellvox:key"]`` (JSON
``[left, top, width, height]`` in pixels; the previews save it as a PNG text chunk).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import NamedTuple

from PIL import Image, ImageDraw, ImageFont

#: Size of all text in the previews, pixels (at 96 dpi, 10.5 pt).
CAPTION_PX = 14
#: Side of a key's colour swatch, pixels (the exact colour; a 1 pixel outline around it).
SWATCH_PX = 16
#: Space around the whole picture and between panels, pixels.
MARGIN = 8
GAP = 10
#: Colour of text, of the swatches' outline and of the frame around each panel.
TEXT_RGB = (0, 0, 0)
OUTLINE_RGB = (128, 128, 128)
FRAME_RGB = (200, 200, 200)
WHITE = (255, 255, 255)
RGB = tuple[int, int, int]


class Swatch(NamedTuple):
    """One entry of a key: a name and the sRGB colour it is drawn in."""

    name: str
    rgb: RGB


class KeyRow(NamedTuple):
    """A heading and its swatches, laid in one or more lines."""

    heading: str
    swatches: Sequence[Swatch]


def caption_font(size_px: int = CAPTION_PX) -> ImageFont.FreeTypeFont | ImageFont.ImageFont:
    """Return the previews' font at ``size_px`` pixels (Pillow's bundled sans-serif)."""
    return ImageFont.load_default(size=size_px)


def line_height(font: ImageFont.FreeTypeFont | ImageFont.ImageFont) -> int:
    """Return the height of a line of text in ``font``, pixels (ascent + descent + 2)."""
    if isinstance(font, ImageFont.FreeTypeFont):
        ascent, descent = font.getmetrics()
        return int(ascent + descent + 2)
    return int(font.getbbox("Ag")[3]) + 2


def wrap(text: str, width_px: int, font: ImageFont.FreeTypeFont | ImageFont.ImageFont) -> list[str]:
    """Break ``text`` into lines no wider than ``width_px`` (a longer word keeps its line)."""
    lines: list[str] = []
    for paragraph in text.split("\n"):
        line = ""
        for word in paragraph.split(" "):
            trial = f"{line} {word}" if line else word
            if line and font.getlength(trial) > width_px:
                lines.append(line)
                line = word
            else:
                line = trial
        lines.append(line)
    return lines


def labelled_grid(cells: Sequence[tuple[str, Image.Image]], columns: int) -> Image.Image:
    """Lay panels in rows of ``columns``, each framed under its label, :data:`GAP` apart.

    Parameters
    ----------
    cells : sequence of (str, PIL.Image.Image)
        Each panel's label and picture (RGB).
    columns : int
        Panels per row.

    Returns
    -------
    PIL.Image.Image
        The grid, no margin around it; a column is as wide as its widest panel, a row as
        tall as its tallest label and panel. Each panel is drawn unchanged inside a 1
        pixel frame (:data:`FRAME_RGB`), which shows its extent on white.
    """
    font = caption_font()
    cells = [(label, _with_frame(picture)) for label, picture in cells]
    line = line_height(font)
    rows = [cells[i : i + columns] for i in range(0, len(cells), columns)]
    widths = [max(c[1].width for c in column) for column in zip(*rows, strict=False)]
    labels = [[wrap(label, widths[i], font) for i, (label, _) in enumerate(row)] for row in rows]
    label_h = [max(len(lines) for lines in row) * line for row in labels]
    heights = [max(c[1].height for c in row) for row in rows]
    canvas = Image.new(
        "RGB",
        (sum(widths) + GAP * (len(widths) - 1),
         sum(heights) + sum(label_h) + GAP * (len(rows) - 1)),
        WHITE,
    )  # fmt: skip
    draw = ImageDraw.Draw(canvas)
    y = 0
    for row, row_labels, row_label_h, row_h in zip(rows, labels, label_h, heights, strict=True):
        x = 0
        for (_, picture), lines, width in zip(row, row_labels, widths, strict=False):
            for k, text in enumerate(lines):
                draw.text((x, y + k * line), text, fill=TEXT_RGB, font=font)
            canvas.paste(picture, (x, y + row_label_h))
            x += width + GAP
        y += row_label_h + row_h + GAP
    return canvas


def _with_frame(picture: Image.Image) -> Image.Image:
    """Return ``picture`` inside a 1 pixel frame of :data:`FRAME_RGB`."""
    out = Image.new("RGB", (picture.width + 2, picture.height + 2), FRAME_RGB)
    out.paste(picture, (1, 1))
    return out


def framed(
    body: Image.Image,
    *,
    title: str,
    key: Sequence[KeyRow] = (),
    notes: Sequence[str] = (),
    min_width: int = 560,
) -> Image.Image:
    """Return ``body`` with its title above and its key and notes below, in tight margins.

    Parameters
    ----------
    body : PIL.Image.Image
        The picture (RGB), drawn unchanged.
    title : str
        The caption above (wrapped to the picture's width).
    key : sequence of KeyRow
        The key's rows: a heading, then each swatch and its name.
    notes : sequence of str
        Lines under the key.
    min_width : int
        The text's least width, pixels (a narrow picture is centred over it).

    Returns
    -------
    PIL.Image.Image
        ``info["shellvox:key"]`` holds the key's box (JSON ``[left, top, width, height]``).
    """
    font = caption_font()
    line = line_height(font)
    width = max(body.width, min_width)
    title_lines = wrap(title, width, font)
    note_lines = [part for note in notes for part in wrap(note, width, font)]
    entries, key_h = _key_layout(key, width, font)
    top = MARGIN + len(title_lines) * line + GAP // 2
    key_top = top + body.height + (GAP if entries else 0)
    notes_top = key_top + key_h + (GAP // 2 if note_lines else 0)
    canvas = Image.new(
        "RGB", (width + 2 * MARGIN, notes_top + len(note_lines) * line + MARGIN), WHITE
    )
    draw = ImageDraw.Draw(canvas)
    for k, text in enumerate(title_lines):
        draw.text((MARGIN, MARGIN + k * line), text, fill=TEXT_RGB, font=font)
    canvas.paste(body, (MARGIN + (width - body.width) // 2, top))
    for x, y, item in entries:
        left, y = MARGIN + x, key_top + y
        if isinstance(item, Swatch):
            draw.rectangle((left, y, left + SWATCH_PX + 1, y + SWATCH_PX + 1), outline=OUTLINE_RGB)
            draw.rectangle((left + 1, y + 1, left + SWATCH_PX, y + SWATCH_PX), fill=item.rgb)
        else:
            draw.text((left, y), item, fill=TEXT_RGB, font=font)
    for k, text in enumerate(note_lines):
        draw.text((MARGIN, notes_top + k * line), text, fill=TEXT_RGB, font=font)
    canvas.info.update({k: v for k, v in body.info.items() if str(k).startswith("shellvox:")})
    canvas.info["shellvox:key"] = json.dumps([MARGIN, key_top, width, key_h])
    canvas.info["shellvox:caption_px"] = str(CAPTION_PX)
    return canvas


def _key_layout(
    key: Sequence[KeyRow], width: int, font: ImageFont.FreeTypeFont | ImageFont.ImageFont
) -> tuple[list[tuple[int, int, Swatch | str]], int]:
    """Place the key's headings, swatches and names: ``(x, y, item)`` from the key's corner.

    Returns the placed items and the key's height (pixels).
    """
    line = max(line_height(font), SWATCH_PX + 4)
    placed: list[tuple[int, int, Swatch | str]] = []
    y = 0
    for heading, swatches in key:
        x = 0
        if heading:
            placed.append((0, y, heading + ":"))
            x = int(font.getlength(heading + ":")) + GAP
        for swatch in swatches:
            name_w = int(font.getlength(swatch.name))
            entry_w = SWATCH_PX + 2 + 6 + name_w
            if x > 0 and x + entry_w > width:
                x, y = GAP, y + line
            placed.append((x, y, swatch))
            placed.append((x + SWATCH_PX + 8, y, swatch.name))
            x += entry_w + 2 * GAP
        y += line
    return placed, y
