"""A tray's models as one mesh in tray coordinates, for what sees the tray as one model.

The voxels of a tray are computed per model (:mod:`shellvox.voxel.tray_slab`); the colour report,
``thickness.ply`` and the manifest see one mesh: the models' faces concatenated in the
order of the tray, each moved to its place. Each model keeps its own colour source:
:meth:`TrayMesh.colour_at` hands every face to its model's.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from shellvox.model import ColouredMesh
from shellvox.thickness import FaceColour, FaceThickness, OpticalFaces
from shellvox.voxel.colour import SurfaceColour


@dataclass(frozen=True, eq=False)
class TrayMesh(ColouredMesh):
    """The models of a tray as one mesh (``colour_kind`` "none": the parts colour it).

    Parameters
    ----------
    parts : tuple of ColouredMesh
        Each placed model, in the order of its faces here (its own coordinates).
    face_starts : (N + 1,) int64
        First face of each part here, and the total.
    """

    parts: tuple[ColouredMesh, ...] = ()
    face_starts: NDArray[np.int64] = field(default_factory=lambda: np.zeros(1, np.int64))

    @classmethod
    def place(
        cls, parts: Sequence[ColouredMesh], shifts_mm: NDArray[np.float64], source: str
    ) -> TrayMesh:
        """Return the parts, each moved by its shift ``(N, 3) float64`` mm, as one mesh."""
        counts = np.array([len(p.vertices) for p in parts], dtype=np.int64)
        vertex_starts = np.r_[0, np.cumsum(counts)[:-1]]
        face_counts = np.array([p.n_faces for p in parts], dtype=np.int64)
        vertices = np.concatenate(
            [p.vertices + s for p, s in zip(parts, np.asarray(shifts_mm), strict=True)]
        )
        faces = np.concatenate(
            [p.faces + start for p, start in zip(parts, vertex_starts, strict=True)]
        )
        return cls(
            vertices,
            faces.astype(np.int64),
            source=source,
            parts=tuple(parts),
            face_starts=np.r_[0, np.cumsum(face_counts)].astype(np.int64),
        )

    def colour_at(
        self, face_ids: NDArray[np.integer[Any]], barycentric: NDArray[np.floating[Any]]
    ) -> NDArray[np.uint8]:
        """Return each point's colour from its model (see :meth:`ColouredMesh.colour_at`)."""
        face_ids = np.asarray(face_ids, dtype=np.int64)
        barycentric = np.asarray(barycentric, dtype=np.float64)
        part = np.searchsorted(self.face_starts, face_ids, side="right") - 1
        rgba = np.zeros((len(face_ids), 4), dtype=np.uint8)
        for index in np.unique(part):  # a loop over models, not faces
            chosen = part == index
            rgba[chosen] = self.parts[index].colour_at(
                face_ids[chosen] - self.face_starts[index], barycentric[chosen]
            )
        return rgba

    def surface_colour(self) -> SurfaceColour:
        """Refused: a tray's voxels take their colours from each model's own source."""
        raise TypeError("a tray has no single colour source; use each part's surface_colour()")


def concatenate_thickness(parts: Sequence[FaceThickness]) -> FaceThickness:
    """Return the per-face thickness of the parts, faces in order (the first part's rule)."""
    colour = FaceColour(
        lab=np.concatenate([p.colour.lab for p in parts]),
        alpha=np.concatenate([p.colour.alpha for p in parts]),
        spread_de00=np.concatenate([p.colour.spread_de00 for p in parts]),
        n_samples=np.concatenate([p.colour.n_samples for p in parts]),
    )
    return FaceThickness(
        thickness_mm=np.concatenate([p.thickness_mm for p in parts], axis=1),
        colour_layer_mm=np.concatenate([p.colour_layer_mm for p in parts]),
        unsmoothed_mm=np.concatenate([p.unsmoothed_mm for p in parts]),
        rule_mm=np.concatenate([p.rule_mm for p in parts]),
        colour=colour,
        normal_z=np.concatenate([p.normal_z for p in parts]),
        orientation=np.concatenate([p.orientation for p in parts]),
        mean_curvature=np.concatenate([p.mean_curvature for p in parts]),
        area_mm2=np.concatenate([p.area_mm2 for p in parts]),
        rule=parts[0].rule,
        optical=_concatenate_optical(parts),
    )


def _concatenate_optical(parts: Sequence[FaceThickness]) -> OpticalFaces | None:
    """Return the optical rule's findings of all parts (None unless every part has them)."""
    found = [p.optical for p in parts if p.optical is not None]
    if len(found) < len(parts):
        return None
    return OpticalFaces(
        thickness_mm=np.concatenate([f.thickness_mm for f in found]),
        shares=np.concatenate([f.shares for f in found]),
        settled=np.concatenate([f.settled for f in found]),
        deep_lab=np.concatenate([f.deep_lab for f in found]),
        roles=found[0].roles,
        robust_mm=np.concatenate([f.robust_mm for f in found]),
        deepest_rgba=np.concatenate([f.deepest_rgba for f in found]),
    )
