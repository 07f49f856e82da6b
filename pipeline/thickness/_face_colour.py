"""A robust colour per face: what a face covers, in CIELAB, with its spread.

The thickness rule needs one colour per face. A face-coloured mesh has it; a
vertex-coloured face covers the blend of its corners; a textured face covers many
texels. For every face we take colour samples spread evenly over the face, convert
them from sRGB to CIELAB (colour-science, IEC 61966-2-1 sRGB, D65, CIE 1931 2 degree
observer) and keep:

- the **per-channel median** in CIELAB (the marginal median of ``L*``, ``a*``, ``b*``)
  and the median alpha: a minority of different texels (a thin line, a few noisy pixels)
  does not move it, unlike the mean;
- the **spread**: the 90th percentile of the CIEDE2000 difference between each sample and
  that median. A face whose spread is large covers visibly different colours, so one
  thickness cannot suit all of it (``--max-edge`` splits such faces).

Samples per source:

- ``"face"`` / ``"none"``: the face colour (spread 0);
- ``"vertex"``: the three corner colours (the extremes of what the face blends);
- ``"texture"``: :meth:`ColouredMesh.colour_at` at the centroids of the ``m x m``
  regular subdivision of the face (``m^2`` equal-area sub-triangles, so the unweighted
  median is the area-weighted one). ``m`` grows with the texels the face covers: ``m^2
  >= samples_per_texel x`` (UV area x image pixels), between ``2`` and ``max_side``
  (default 32: at most 1024 samples per face). A material without image is constant:
  ``m = 1``.

Faces are grouped by ``m`` and processed in chunks: loops run over sample-count classes
and chunks, never over faces.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import colour
import numpy as np
from numpy.typing import NDArray

from shellvox.model import ColouredMesh
from shellvox.voxel.colour import srgb8_to_lab

#: Samples per chunk of faces (bounds the working memory to a few hundred MB).
CHUNK_SAMPLES = 1 << 20


#: Decimals kept of a face's colour spread (CIEDE2000 units).
SPREAD_DECIMALS = 9


@dataclass(frozen=True, eq=False)
class FaceColour:
    """Robust colour of every face.

    Attributes
    ----------
    lab : (F, 3) float64
        Per-channel median ``L*`` in ``[0, 100]``, ``a*``, ``b*`` (D65).
    alpha : (F,) float64
        Median alpha in ``[0, 1]``.
    spread_de00 : (F,) float64
        90th percentile of the CIEDE2000 difference between the samples and ``lab``.
    n_samples : (F,) int64
        Colour samples taken per face.
    """

    lab: NDArray[np.float64]
    alpha: NDArray[np.float64]
    spread_de00: NDArray[np.float64]
    n_samples: NDArray[np.int64]

    @property
    def lightness(self) -> NDArray[np.float64]:
        """``L*``, ``(F,) float64`` in ``[0, 100]``."""
        lightness: NDArray[np.float64] = self.lab[:, 0]
        return lightness

    @property
    def chroma(self) -> NDArray[np.float64]:
        """``C*_ab = sqrt(a*^2 + b*^2)``, ``(F,) float64`` (0 for greys)."""
        chroma: NDArray[np.float64] = np.hypot(self.lab[:, 1], self.lab[:, 2])
        return chroma


def stratified_barycentric(m: int) -> NDArray[np.float64]:
    """Return the centroids of the ``m x m`` regular subdivision of a triangle.

    Parameters
    ----------
    m : int
        Subdivisions per edge (``>= 1``).

    Returns
    -------
    (m^2, 3) float64
        Barycentric coordinates; each point stands for ``1 / m^2`` of the face's area.

    Examples
    --------
    >>> bool(np.allclose(stratified_barycentric(1), 1 / 3))
    True
    >>> stratified_barycentric(2).shape
    (4, 3)
    """
    if m < 1:
        raise ValueError(f"m must be >= 1, got {m}")
    i, j = np.meshgrid(np.arange(m), np.arange(m), indexing="ij")
    up = i + j <= m - 1
    down = i + j <= m - 2
    s = np.concatenate([(i[up] + 1 / 3) / m, (i[down] + 2 / 3) / m])
    t = np.concatenate([(j[up] + 1 / 3) / m, (j[down] + 2 / 3) / m])
    return np.stack([1.0 - s - t, s, t], axis=1)


def face_colour(
    mesh: ColouredMesh, *, samples_per_texel: float = 1.0, max_side: int = 32
) -> FaceColour:
    """Return the robust colour (per-channel CIELAB median) and spread of every face.

    Parameters
    ----------
    mesh : ColouredMesh
        Any colour source.
    samples_per_texel : float, optional
        Texture samples per texel a face covers (``> 0``).
    max_side : int, optional
        Largest subdivision ``m`` of a textured face (``m^2`` samples; ``>= 2``).

    Returns
    -------
    FaceColour

    Examples
    --------
    >>> mesh = ColouredMesh(
    ...     np.eye(3),
    ...     np.array([[0, 1, 2]]),
    ...     "face",
    ...     face_rgba=np.array([[255, 255, 255, 128]], np.uint8),
    ... )
    >>> stats = face_colour(mesh)
    >>> round(float(stats.lightness[0]), 3), round(float(stats.alpha[0]), 3)
    (100.0, 0.502)
    """
    if not samples_per_texel > 0:
        raise ValueError(f"samples_per_texel must be > 0, got {samples_per_texel!r}")
    if max_side < 2:
        raise ValueError(f"max_side must be >= 2, got {max_side!r}")
    n_faces = mesh.n_faces
    if mesh.colour_kind == "vertex":
        assert mesh.corner_rgba is not None
        return _statistics(mesh.corner_rgba)
    if mesh.colour_kind == "texture":
        return _texture_colour(mesh, samples_per_texel, max_side)
    if mesh.colour_kind == "face":
        assert mesh.face_rgba is not None
        rgba = mesh.face_rgba
    else:
        rgba = np.broadcast_to(mesh.default_rgba, (n_faces, 4))
    return _statistics(np.asarray(rgba, dtype=np.uint8)[:, None, :])


def texture_sides(
    mesh: ColouredMesh, *, samples_per_texel: float = 1.0, max_side: int = 32
) -> NDArray[np.int64]:
    """Return the subdivision ``m`` of every face of a textured mesh (``m^2`` samples).

    Parameters
    ----------
    mesh : ColouredMesh
        ``colour_kind == "texture"``.
    samples_per_texel, max_side : see :func:`face_colour`.

    Returns
    -------
    (F,) int64
        ``1`` for faces of materials without image, else ``ceil(sqrt(samples_per_texel
        x texels))`` clipped to ``[2, max_side]``.
    """
    assert mesh.corner_uv is not None and mesh.face_material is not None
    pixels = np.array(
        [0 if m.image is None else m.image.shape[0] * m.image.shape[1] for m in mesh.materials],
        dtype=np.float64,
    )
    uv = mesh.corner_uv
    uv_area = 0.5 * np.abs(
        (uv[:, 1, 0] - uv[:, 0, 0]) * (uv[:, 2, 1] - uv[:, 0, 1])
        - (uv[:, 2, 0] - uv[:, 0, 0]) * (uv[:, 1, 1] - uv[:, 0, 1])
    )
    pixels_of_face = pixels[mesh.face_material]
    wanted = np.ceil(np.sqrt(samples_per_texel * uv_area * pixels_of_face))
    side: NDArray[np.int64] = np.clip(wanted, 2, max_side).astype(np.int64)
    side[pixels_of_face == 0] = 1
    return side


def face_samples(
    mesh: ColouredMesh, *, samples_per_texel: float = 1.0, max_side: int = 32
) -> Iterator[tuple[NDArray[np.int64], NDArray[np.uint8]]]:
    """Yield the colour samples of every face, in chunks (see the module for which).

    Parameters
    ----------
    mesh : ColouredMesh
        Any colour source.
    samples_per_texel, max_side : see :func:`face_colour`.

    Yields
    ------
    faces : (C,) int64
        The chunk's faces; every face is in exactly one chunk.
    rgba : (C, S, 4) uint8
        Their ``S`` samples each (``S`` is the same within a chunk).
    """
    if mesh.colour_kind == "vertex":
        assert mesh.corner_rgba is not None
        yield np.arange(mesh.n_faces, dtype=np.int64), np.asarray(mesh.corner_rgba, np.uint8)
        return
    if mesh.colour_kind != "texture":
        if mesh.colour_kind == "face":
            assert mesh.face_rgba is not None
            rgba = np.asarray(mesh.face_rgba, np.uint8)
        else:
            rgba = np.broadcast_to(np.asarray(mesh.default_rgba, np.uint8), (mesh.n_faces, 4))
        yield np.arange(mesh.n_faces, dtype=np.int64), rgba[:, None, :]
        return
    side = texture_sides(mesh, samples_per_texel=samples_per_texel, max_side=max_side)
    for m in np.unique(side):  # loop over sample-count classes, not faces
        pattern = stratified_barycentric(int(m))
        faces = np.flatnonzero(side == m)
        step = max(1, CHUNK_SAMPLES // len(pattern))
        for start in range(0, len(faces), step):
            chunk = faces[start : start + step]
            rgba = mesh.colour_at(
                np.repeat(chunk, len(pattern)), np.tile(pattern, (len(chunk), 1))
            ).reshape(len(chunk), len(pattern), 4)
            yield chunk, rgba


def _texture_colour(mesh: ColouredMesh, samples_per_texel: float, max_side: int) -> FaceColour:
    n_faces = mesh.n_faces
    lab = np.empty((n_faces, 3), dtype=np.float64)
    alpha = np.empty(n_faces, dtype=np.float64)
    spread = np.empty(n_faces, dtype=np.float64)
    count = np.empty(n_faces, dtype=np.int64)
    for chunk, rgba in face_samples(mesh, samples_per_texel=samples_per_texel, max_side=max_side):
        part = _statistics(rgba)
        lab[chunk], alpha[chunk], spread[chunk] = part.lab, part.alpha, part.spread_de00
        count[chunk] = rgba.shape[1]
    return FaceColour(lab=lab, alpha=alpha, spread_de00=spread, n_samples=count)


def _statistics(rgba: NDArray[np.uint8]) -> FaceColour:
    """Median CIELAB, median alpha and p90 CIEDE2000 spread of ``(F, S, 4) uint8`` samples."""
    n_faces, n_samples = rgba.shape[:2]
    samples = srgb8_to_lab(rgba[..., :3])
    median = np.median(samples, axis=1)
    if n_samples == 1:
        spread = np.zeros(n_faces, dtype=np.float64)
    else:
        difference: NDArray[Any] = colour.delta_E(samples, median[:, None, :], method="CIE 2000")
        # Rounded: numpy's vectorised trigonometry in CIEDE2000 may differ in the last
        # bits from run to run (memory alignment); equal inputs must give equal files.
        spread = np.round(np.percentile(difference, 90, axis=1), SPREAD_DECIMALS)
    return FaceColour(
        lab=np.asarray(median, dtype=np.float64),
        alpha=np.median(rgba[..., 3], axis=1) / 255.0,
        spread_de00=np.asarray(spread, dtype=np.float64),
        n_samples=np.full(n_faces, n_samples, dtype=np.int64),
    )
