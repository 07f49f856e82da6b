"""3MF ``<multiproperties>``: layered colour groups, materials and textures, blended.

Materials and Properties Extension 1.2, chapter 5. Each ``<multi>`` element names one
property per layer (``pids``); the layers are blended in linear light, in order, with
``blendmethods`` ``mix`` (``rgb = new.rgb * new.a + acc.rgb * (1 - new.a)``, ``a = new.a
+ acc.a * (1 - new.a)``) or ``multiply`` (``rgb = new.rgb * acc.rgb``, ``a = new.a *
acc.a``). A material first layer (``<basematerials>`` or ``<compositematerials>``) is
skipped as the specification asks: the other layers are accumulated from the second
one on and the result is laid over the material's display colour with its accumulated
opacity (the spec's ``printColor``). Otherwise the first layer starts the
accumulation, opaque.

Layers without a texture give one colour per ``<multi>`` element: they become a colour
table like a ``<colorgroup>``. A texture layer makes the colour vary inside a triangle,
which a :class:`~shellvox.model._mesh.ColouredMesh` holds as a texture: the blend is *baked*
into a copy of the texture for each distinct combination of the other layers' colours
(:func:`bake`), exact at the texels. A triangle whose corners name different colours in
the other layers gets their mean (linear light), with a warning; a second texture layer
is not read, with a warning. Baked copies count against the texture pixel budget.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel.colour import decode_uint8, encode_uint8

Blend = Literal["mix", "multiply"]

#: Texture rows blended at a time while baking (bounds the float64 working memory).
BAKE_ROWS = 256


@dataclass(frozen=True)
class Layered:
    """A ``<multiproperties>`` group with one texture layer.

    Parameters
    ----------
    uv : (N, 2) float64
        Texture coordinates of each ``<multi>`` element (its texture layer's index).
    texture : int
        Index of the source texture in the model's material list.
    constants : (N, L, 4) float64
        Linear RGBA of every layer of each element (zeros in the texture layer's slot).
    texture_layer : int
        Which of the ``L`` layers is the texture.
    methods : tuple of Blend
        Blend method of layers ``1 .. L-1``.
    material_first : bool
        Layer 0 is a material (laid under the accumulated colour, see the module docstring).
    """

    uv: NDArray[np.float64]
    texture: int
    constants: NDArray[np.float64]
    texture_layer: int
    methods: tuple[Blend, ...]
    material_first: bool


def blend(
    layers: list[NDArray[np.float64]], methods: tuple[Blend, ...], *, material_first: bool
) -> NDArray[np.float64]:
    """Blend layers of linear RGBA as the 3MF Materials extension specifies.

    Parameters
    ----------
    layers : list of (..., 4) float64
        Linear RGB + alpha in ``[0, 1]`` of each layer, bottom first; shapes broadcast
        (a constant ``(4,)`` layer blends with a texture ``(H, W, 4)``).
    methods : tuple of {"mix", "multiply"}
        Method of layers ``1 .. L-1`` (``len(layers) - 1`` entries).
    material_first : bool
        Layer 0 is a material: it is skipped and the accumulated colour is laid over its
        colour with the accumulated opacity.

    Returns
    -------
    (..., 4) float64
        Linear RGB + alpha.

    Examples
    --------
    >>> import numpy as np
    >>> red, half_blue = np.array([1.0, 0, 0, 1]), np.array([0, 0, 1.0, 0.5])
    >>> blend([red, half_blue], ("mix",), material_first=False).tolist()
    [0.5, 0.0, 0.5, 1.0]
    """
    if len(methods) != len(layers) - 1:
        raise ValueError(f"need {len(layers) - 1} blend methods, got {len(methods)}")
    if material_first and len(layers) == 1:
        return np.asarray(layers[0], dtype=np.float64)
    first = 1 if material_first else 0
    rgb: NDArray[Any] = layers[first][..., :3]
    alpha: NDArray[Any] = layers[first][..., 3:]
    if not material_first:
        alpha = np.ones_like(alpha)
    for layer, method in zip(layers[first + 1 :], methods[first:], strict=True):
        new_rgb, new_alpha = layer[..., :3], layer[..., 3:]
        if method == "multiply":
            rgb, alpha = new_rgb * rgb, new_alpha * alpha
        else:
            rgb = new_rgb * new_alpha + rgb * (1.0 - new_alpha)
            alpha = new_alpha + alpha * (1.0 - new_alpha)
    if material_first:
        base = layers[0]
        rgb = rgb * alpha + base[..., :3] * (1.0 - alpha)
        alpha = np.broadcast_to(base[..., 3:], alpha.shape)
    out = np.empty((*np.broadcast_shapes(rgb.shape[:-1], alpha.shape[:-1]), 4))
    out[..., :3], out[..., 3:] = rgb, alpha
    return out


def bake(
    image: NDArray[np.uint8],
    constants: NDArray[np.float64],
    texture_layer: int,
    methods: tuple[Blend, ...],
    *,
    material_first: bool,
) -> NDArray[np.uint8]:
    """Blend a texture with constant layers, texel by texel, into a new texture.

    Parameters
    ----------
    image : (H, W, 4) uint8
        sRGB + alpha texture of the texture layer.
    constants : (L, 4) float64
        Linear RGBA of every layer (the texture layer's row is ignored).
    texture_layer : int
        Index of the texture layer.
    methods : tuple of Blend
        As for :func:`blend`.
    material_first : bool
        As for :func:`blend`.

    Returns
    -------
    (H, W, 4) uint8
        The blended colour as sRGB + alpha.
    """
    out = np.empty_like(image)
    for start in range(0, len(image), BAKE_ROWS):  # rows in blocks, to bound memory
        texels = decode_uint8(image[start : start + BAKE_ROWS])
        layers = [texels if k == texture_layer else row for k, row in enumerate(constants)]
        out[start : start + BAKE_ROWS] = encode_uint8(
            blend(layers, methods, material_first=material_first)
        )
    return out


def blend_methods(text: str | None, n_layers: int) -> tuple[Blend, ...] | None:
    """Parse ``blendmethods`` (missing entries are ``mix``); None if malformed."""
    words = (text or "").split()
    if len(words) > n_layers - 1 or any(w not in ("mix", "multiply") for w in words):
        return None
    methods: list[Any] = words + ["mix"] * (n_layers - 1 - len(words))
    return tuple(methods)


def colour_table(
    tables: list[NDArray[np.uint8]],
    indices: NDArray[np.int64],
    methods: tuple[Blend, ...],
    *,
    material_first: bool,
) -> NDArray[np.uint8]:
    """Blend colour-only layers into one sRGBA colour per ``<multi>`` element.

    Parameters
    ----------
    tables : list of (n_k, 4) uint8
        sRGB + alpha colour table of each layer.
    indices : (N, L) int64
        Index into each layer's table per element (checked by the caller).
    methods, material_first
        As for :func:`blend`.

    Returns
    -------
    (N, 4) uint8
    """
    layers = [decode_uint8(table[indices[:, k]]) for k, table in enumerate(tables)]
    return encode_uint8(blend(layers, methods, material_first=material_first))
