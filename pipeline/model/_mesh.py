"""The coloured mesh every stage works on, and the one function that colours the surface."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal, NamedTuple

import numpy as np
from numpy.typing import NDArray

from shellvox.model._texture import Material
from shellvox.voxel.colour import (
    CONSTANT,
    FACE,
    FILTER_CODES,
    TEXTURE,
    VERTEX,
    WRAP_CODES,
    SurfaceColour,
    decode_uint8,
    encode_uint8,
)

ColourKind = Literal["texture", "vertex", "face", "none"]

#: Colour of a surface without colour: the printer's white base material.
DEFAULT_RGBA = np.array([255, 255, 255, 255], dtype=np.uint8)


class Solid(NamedTuple):
    """The faces whose winding number is a mesh's inside, where they are not its faces.

    A mesh as it comes (open, of overlapping parts, with buried faces) keeps as its
    faces the visible ones; its solid is all its faces, oriented
    (:func:`shellvox.model.solid_model`).

    Attributes
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
        Counter-clockwise seen from outside, where a face has an outside.
    closed : bool
        Every edge joins two faces running opposite ways: the exact row crossings give
        the inside; otherwise the generalised winding number does.
    partly : (F_mesh,) bool
        Per face of the mesh: visible only in part (it crosses another part; its buried
        piece must not decide a voxel's depth).
    """

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    closed: bool
    partly: NDArray[np.bool_]


@dataclass(frozen=True, eq=False)
class ColouredMesh:
    """A closed, outward-oriented triangle mesh in millimetres with one colour source.

    Exactly one colour source is set, as ``colour_kind`` says. Vertices are merged by
    position (seams do not split topology); attributes that differ across seams (UVs,
    vertex colours) are kept per face corner.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
        Vertex positions ``(x, y, z)``.
    faces : (F, 3) int64
        Vertex indices, counter-clockwise seen from outside.
    colour_kind : {"texture", "vertex", "face", "none"}
        Which colour source is set.
    corner_rgba : (F, 3, 4) uint8, optional
        sRGB + alpha per face corner (``colour_kind == "vertex"``).
    face_rgba : (F, 4) uint8, optional
        sRGB + alpha per face (``colour_kind == "face"``).
    corner_uv : (F, 3, 2) float64, optional
        Texture coordinates per face corner, ``v`` up (``colour_kind == "texture"``).
    face_material : (F,) int64, optional
        Index into ``materials`` per face (``colour_kind == "texture"``).
    materials : tuple of Material
        Materials referenced by ``face_material``.
    source : str
        Where the mesh came from (path), for messages and manifests.
    default_rgba : (4,) uint8
        Colour returned when ``colour_kind == "none"``.
    solid : Solid, optional
        The faces whose winding number is the inside, where the mesh's own faces are only
        its visible ones (a mesh as it comes); None: the mesh is a closed oriented surface.
    loaded : dict
        How the file was read into mm and +Z up (:func:`shellvox.load_model`): format,
        unit, up axis, ``scale``, ``size_mm`` and the millimetres per file unit applied;
        recorded in the manifests. Empty for a mesh made in code.
    """

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    colour_kind: ColourKind = "none"
    corner_rgba: NDArray[np.uint8] | None = None
    face_rgba: NDArray[np.uint8] | None = None
    corner_uv: NDArray[np.float64] | None = None
    face_material: NDArray[np.int64] | None = None
    materials: tuple[Material, ...] = ()
    source: str = ""
    default_rgba: NDArray[np.uint8] = field(default_factory=lambda: DEFAULT_RGBA.copy())
    loaded: dict[str, Any] = field(default_factory=dict)
    solid: Solid | None = None

    def __post_init__(self) -> None:
        n_faces = len(self.faces)
        expected: dict[ColourKind, tuple[str, ...]] = {
            "vertex": ("corner_rgba",),
            "face": ("face_rgba",),
            "texture": ("corner_uv", "face_material"),
            "none": (),
        }
        for name in ("corner_rgba", "face_rgba", "corner_uv", "face_material"):
            value = getattr(self, name)
            wanted = name in expected[self.colour_kind]
            if wanted and value is None:
                raise ValueError(f"colour_kind={self.colour_kind!r} needs {name}, got None")
            if not wanted and value is not None:
                raise ValueError(f"colour_kind={self.colour_kind!r} takes no {name}")
            if value is not None and len(value) != n_faces:
                raise ValueError(
                    f"{name} must have {n_faces} rows (one per face), got {len(value)}"
                )
        if self.solid is not None and len(self.solid.partly) != n_faces:
            raise ValueError(
                f"solid.partly must have {n_faces} rows (one per face), "
                f"got {len(self.solid.partly)}"
            )
        if self.colour_kind == "texture" and self.face_material is not None and n_faces:
            top = int(self.face_material.max())
            if top >= len(self.materials) or int(self.face_material.min()) < 0:
                raise ValueError(
                    f"face_material indexes {len(self.materials)} materials, got index {top}"
                )

    def __repr__(self) -> str:
        """One line: faces, vertices, colour, size and source (not the arrays)."""
        size = np.ptp(self.vertices, axis=0) if len(self.vertices) else np.zeros(3)
        return (
            f"ColouredMesh({len(self.faces)} faces, {len(self.vertices)} vertices, "
            f"colour_kind={self.colour_kind!r}, size_mm=({', '.join(f'{s:.4g}' for s in size)}), "
            f"source={self.source!r})"
        )

    @property
    def n_faces(self) -> int:
        """Number of faces."""
        return len(self.faces)

    @property
    def triangles(self) -> NDArray[np.float64]:
        """Corner positions, ``(F, 3, 3) float64`` mm."""
        triangles: NDArray[np.float64] = self.vertices[self.faces]
        return triangles

    def colour_at(
        self, face_ids: NDArray[np.integer[Any]], barycentric: NDArray[np.floating[Any]]
    ) -> NDArray[np.uint8]:
        """Return the surface colour at points given by face and barycentric coordinates.

        Parameters
        ----------
        face_ids : (N,) int
            Face index of each point.
        barycentric : (N, 3) float
            Barycentric coordinates of each point in its face (rows sum to 1).

        Returns
        -------
        (N, 4) uint8
            sRGB + alpha. Textures are sampled bilinearly (or nearest, as the file asks)
            with the format's wrap rule; vertex colours are interpolated in linear light;
            face colours are constant per face.

        Examples
        --------
        >>> import numpy as np
        >>> from shellvox import ColouredMesh
        >>> mesh = ColouredMesh(
        ...     np.eye(3),
        ...     np.array([[0, 1, 2]]),
        ...     "face",
        ...     face_rgba=np.array([[200, 10, 10, 255]], np.uint8),
        ... )
        >>> mesh.colour_at(np.array([0]), np.array([[0.2, 0.3, 0.5]]))
        array([[200,  10,  10, 255]], dtype=uint8)
        """
        face_ids = np.asarray(face_ids, dtype=np.int64)
        barycentric = np.asarray(barycentric, dtype=np.float64)
        if face_ids.ndim != 1 or barycentric.shape != (len(face_ids), 3):
            raise ValueError(
                f"face_ids must be (N,) and barycentric (N, 3), got {face_ids.shape} "
                f"and {barycentric.shape}"
            )
        if self.colour_kind == "face":
            assert self.face_rgba is not None
            face_rgba: NDArray[np.uint8] = self.face_rgba[face_ids]
            return face_rgba
        if self.colour_kind == "vertex":
            assert self.corner_rgba is not None
            linear = np.einsum("nc,nck->nk", barycentric, decode_uint8(self.corner_rgba[face_ids]))
            return encode_uint8(linear)
        if self.colour_kind == "texture":
            assert self.corner_uv is not None and self.face_material is not None
            uv = np.einsum("nc,nck->nk", barycentric, self.corner_uv[face_ids])
            material = self.face_material[face_ids]
            linear = np.empty((len(face_ids), 4), dtype=np.float64)
            for index in np.unique(material):  # loop over materials, not faces
                chosen = material == index
                linear[chosen] = self.materials[index].sample(uv[chosen])
            return encode_uint8(linear)
        return np.broadcast_to(self.default_rgba, (len(face_ids), 4)).copy()

    def surface_colour(self) -> SurfaceColour:
        """Return the colour source as arrays, for the compiled voxel colour kernel.

        :func:`shellvox.voxel.colour._surface_colour.voxel_colours` gives the same colours as
        :meth:`colour_at` at the exact nearest points.
        """
        n_faces = self.n_faces
        no_uv = np.zeros((0, 3, 2))
        no_material = np.zeros(0, dtype=np.int64)
        pixels = np.zeros(0, dtype=np.uint8)
        image = np.zeros((0, 3), dtype=np.int64)
        wrap = np.zeros((0, 2), dtype=np.int64)
        filters = np.zeros(0, dtype=np.int64)
        factor = np.zeros((0, 4))
        if self.colour_kind == "face":
            assert self.face_rgba is not None
            rgba = np.repeat(self.face_rgba[:, None, :], 3, axis=1)
            return SurfaceColour(
                FACE, rgba, no_uv, no_material, pixels, image, wrap, filters, factor
            )
        if self.colour_kind == "vertex":
            assert self.corner_rgba is not None
            return SurfaceColour(
                VERTEX,
                np.ascontiguousarray(self.corner_rgba, dtype=np.uint8),
                no_uv,
                no_material,
                pixels,
                image,
                wrap,
                filters,
                factor,
            )
        if self.colour_kind == "texture":
            assert self.corner_uv is not None and self.face_material is not None
            images = [m.image for m in self.materials]
            sizes = [0 if im is None else im.size for im in images]
            offsets = np.r_[0, np.cumsum(sizes)[:-1]].astype(np.int64)
            image = np.array(
                [
                    (offset, 0, 0) if im is None else (offset, im.shape[0], im.shape[1])
                    for offset, im in zip(offsets, images, strict=True)
                ],
                dtype=np.int64,
            ).reshape(-1, 3)
            parts = [im.reshape(-1) for im in images if im is not None]
            pixels = np.concatenate(parts).astype(np.uint8) if parts else pixels
            wrap = np.array(
                [[WRAP_CODES[m.wrap[0]], WRAP_CODES[m.wrap[1]]] for m in self.materials],
                dtype=np.int64,
            ).reshape(-1, 2)
            filters = np.array([FILTER_CODES[m.filter] for m in self.materials], dtype=np.int64)
            factor = np.array([m.factor for m in self.materials], dtype=np.float64).reshape(-1, 4)
            return SurfaceColour(
                TEXTURE,
                np.zeros((n_faces, 3, 4), np.uint8)[:0],
                np.ascontiguousarray(self.corner_uv, dtype=np.float64),
                np.ascontiguousarray(self.face_material, dtype=np.int64),
                pixels,
                image,
                wrap,
                filters,
                factor,
            )
        rgba = np.asarray(self.default_rgba, dtype=np.uint8).reshape(1, 1, 4).repeat(3, axis=1)
        return SurfaceColour(
            CONSTANT, rgba, no_uv, no_material, pixels, image, wrap, filters, factor
        )
