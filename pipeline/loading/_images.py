"""Texture images: any Pillow-readable file to ``(H, W, 4) uint8`` sRGB + alpha, within limits.

All textures of one model are read together by :func:`read_textures`: first every
image's header (size only, nothing decoded), then the pixel budget is checked, then the
images are decoded. The budget, :data:`MAX_TEXTURE_PIXELS` pixels over all textures of a
model (one 8192 x 8192 texture: 256 MB as RGBA, a measured peak of about 0.6 GB while it
is decoded), keeps a 13000 x 13000 texture from taking gigabytes without a word;
``--force`` lifts it. Pillow's own decompression-bomb limit is replaced by this check
while shellvox opens an image.

A texture that is missing or unreadable is refused, or, when the user gave ``--colour``,
replaced by that colour with a warning: whatever colour a file declares reaches the
voxels, or the user is told.
"""

from __future__ import annotations

import io
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from PIL import Image, UnidentifiedImageError

from shellvox.errors import InputError, opt, warn
from shellvox.loading._references import is_file

#: Most texture pixels accepted over all textures of one model without ``--force``.
MAX_TEXTURE_PIXELS = 8192 * 8192

#: Pixels converted to RGBA at a time while a texture is decoded.
STRIP_PIXELS = 1 << 22

#: The usual fix for a texture that cannot be used.
COLOUR_FIX = f"or pass {opt('colour')} to print its faces in that colour instead"


@dataclass(frozen=True)
class TextureRef:
    """One texture a model declares.

    Parameters
    ----------
    declared_in : Path
        The file that names the texture (MTL, model), named in messages.
    label : str
        What the texture is, e.g. ``"texture 'skin.png' of material 'skin'"``.
    source : Path or bytes or None
        The image file, its encoded bytes (embedded in glTF or 3MF), or None when it
        is missing.
    fix : str
        First part of the fix for a missing or unreadable texture.
    """

    declared_in: Path
    label: str
    source: Path | bytes | None
    fix: str = "put the image where the file says"


def read_textures(
    refs: Sequence[TextureRef],
    *,
    colour: tuple[int, int, int, int] | None,
    force: bool,
) -> list[NDArray[np.uint8] | None]:
    """Read the textures of one model, headers and pixel budget first.

    Parameters
    ----------
    refs : sequence of TextureRef
        Every texture the model uses.
    colour : tuple of 4 int or None
        ``--colour``: when given, a missing or unreadable texture gives None (the caller
        uses this colour) with a warning instead of an error.
    force : bool
        Accept more than :data:`MAX_TEXTURE_PIXELS` pixels in total.

    Returns
    -------
    list of ((H, W, 4) uint8 or None)
        sRGB + alpha per texture, row 0 at the top of the picture; None where a
        missing or unreadable texture is replaced by ``colour``.

    Raises
    ------
    InputError
        A texture is missing or unreadable and ``colour`` is None, or the textures hold
        more than :data:`MAX_TEXTURE_PIXELS` pixels and ``force`` is false.
    """
    sizes: list[tuple[int, int] | None] = []
    for ref in refs:
        try:
            sizes.append(_probe(ref))
        except _Unusable as problem:
            _fall_back(ref, str(problem), colour)
            sizes.append(None)
    total = sum(w * h for w, h in (s for s in sizes if s is not None))
    if total > MAX_TEXTURE_PIXELS and not force:
        listed = ", ".join(f"{w}x{h}" for w, h in (s for s in sizes if s is not None))
        first = next(ref for ref, s in zip(refs, sizes, strict=True) if s is not None)
        raise InputError(
            first.declared_in,
            f"its textures ({listed}) hold {total:,} pixels, more than the limit of "
            f"{MAX_TEXTURE_PIXELS:,} (8192 x 8192; about {9 * total / 1e9:.1f} GB to decode)",
            f"downscale the textures, or pass {opt('force')}",
        )
    images: list[NDArray[np.uint8] | None] = []
    for ref, size in zip(refs, sizes, strict=True):
        if size is None:
            images.append(None)
            continue
        try:
            images.append(_decode(ref))
        except _Unusable as problem:
            _fall_back(ref, str(problem), colour)
            images.append(None)
    return images


class _Unusable(Exception):
    """A texture is missing or cannot be decoded (the reason is the message)."""


def _fall_back(ref: TextureRef, problem: str, colour: tuple[int, int, int, int] | None) -> None:
    if colour is None:
        raise InputError(ref.declared_in, f"{ref.label} {problem}", f"{ref.fix}, {COLOUR_FIX}")
    warn(
        f"{ref.declared_in}: {ref.label} {problem}; its faces get "
        f"{opt('colour', tuple(colour))} instead",
    )


@contextmanager
def _open(ref: TextureRef) -> Iterator[Image.Image]:
    """Open an image (header only) with Pillow's own pixel limit replaced by ours."""
    source = ref.source
    if source is None or (isinstance(source, Path) and not is_file(source)):
        raise _Unusable("is missing")
    saved = Image.MAX_IMAGE_PIXELS
    Image.MAX_IMAGE_PIXELS = None  # the budget of read_textures is checked instead
    try:
        handle = io.BytesIO(source) if isinstance(source, bytes) else source.open("rb")
        with handle, Image.open(handle) as image:
            yield image
    except _Unusable:
        raise
    except UnidentifiedImageError:
        raise _Unusable("is unreadable (not an image format Pillow knows)") from None
    except (OSError, ValueError, SyntaxError, Image.DecompressionBombError) as error:
        # Pillow raises UnidentifiedImageError (an OSError) for unknown formats, OSError
        # for truncated data, ValueError and SyntaxError for malformed headers.
        raise _Unusable(f"is unreadable ({type(error).__name__}: {error})") from None
    finally:
        Image.MAX_IMAGE_PIXELS = saved


def _probe(ref: TextureRef) -> tuple[int, int]:
    with _open(ref) as image:
        width, height = image.size
    if width <= 0 or height <= 0:
        raise _Unusable(f"is unreadable (size {width}x{height})")
    return width, height


def _decode(ref: TextureRef) -> NDArray[np.uint8]:
    with _open(ref) as image:
        if image.mode in ("I;16", "I;16B", "I;16L", "I"):
            grey = np.asarray(image, dtype=np.float64) / 257.0
            rgb = np.repeat(np.clip(np.rint(grey), 0, 255).astype(np.uint8)[..., None], 3, 2)
            alpha = np.full((*rgb.shape[:2], 1), 255, np.uint8)
            return np.concatenate([rgb, alpha], axis=2)
        # Converted in strips of rows, so that the peak is the decoded image plus the
        # result (8 bytes per pixel), not three whole-image copies.
        width, height = image.size
        rgba = np.empty((height, width, 4), dtype=np.uint8)
        rows = max(1, STRIP_PIXELS // width)
        for top in range(0, height, rows):  # a loop over strips, not pixels
            strip = image.crop((0, top, width, min(top + rows, height))).convert("RGBA")
            rgba[top : top + strip.height] = np.asarray(strip, dtype=np.uint8)
        return rgba
