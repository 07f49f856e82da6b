"""Texture image reading: any Pillow-readable file to ``(H, W, 4) uint8`` sRGB + alpha."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from PIL import Image, UnidentifiedImageError

from pipeline.errors import InputError

#: Largest texture accepted (pixels); larger images are refused rather than decompressed.
MAX_TEXTURE_PIXELS = 16384 * 16384


def read_texture(source: Path | bytes, model: Path, name: str = "") -> NDArray[np.uint8]:
    """Read a texture image as RGBA.

    Parameters
    ----------
    source : Path or bytes
        Image file, or encoded image bytes (embedded in glTF/3MF).
    model : Path
        The model file the texture belongs to (named in error messages).
    name : str
        Name of an embedded image, for messages.

    Returns
    -------
    (H, W, 4) uint8
        sRGB + alpha, row 0 at the top of the picture. Palette, grey and 16-bit images
        are converted (palette PNGs are common in glTF samples).
    """
    label = str(source) if isinstance(source, Path) else f"{model} ({name or 'embedded image'})"
    try:
        handle = io.BytesIO(source) if isinstance(source, bytes) else source.open("rb")
        with handle, Image.open(handle) as image:
            if image.width * image.height > MAX_TEXTURE_PIXELS:
                raise InputError(
                    label,
                    f"texture of {image.width}x{image.height} pixels is too large",
                    "downscale the texture below 16384x16384",
                )
            if image.mode in ("I;16", "I;16B", "I;16L", "I"):
                grey = np.asarray(image, dtype=np.float64) / 257.0
                rgb = np.repeat(np.clip(np.rint(grey), 0, 255).astype(np.uint8)[..., None], 3, 2)
                alpha = np.full((*rgb.shape[:2], 1), 255, np.uint8)
                return np.concatenate([rgb, alpha], axis=2)
            return np.ascontiguousarray(np.asarray(image.convert("RGBA"), dtype=np.uint8))
    except FileNotFoundError:
        raise InputError(
            label, "texture file is missing", "put it where the model says, or pass --texture FILE"
        ) from None
    except (UnidentifiedImageError, OSError, ValueError, Image.DecompressionBombError) as error:
        if isinstance(error, InputError):
            raise
        raise InputError(
            label,
            f"texture is unreadable ({type(error).__name__}: {error})",
            "re-save it as PNG or JPEG, or pass --texture FILE",
        ) from None
