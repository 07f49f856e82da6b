"""What ``shellvox info`` reports about a loaded model."""

from __future__ import annotations

from typing import Any

import numpy as np

from shellvox.model._mesh import ColouredMesh
from shellvox.model._soup import HOLES_LISTED, inspect_soup
from shellvox.model._topology import signed_volume


def summarise(mesh: ColouredMesh) -> dict[str, Any]:
    """Return a JSON-serialisable summary of a loaded mesh.

    The mesh may be open, non-manifold or made of overlapping parts (as
    ``prepare(..., check="report")`` returns it); :func:`~shellvox.model.inspect_soup`
    reports on it. Parts are numbered from 1 here.

    Keys: ``path``, ``faces``, ``vertices``, ``bounds_mm`` ``[[xmin, ymin, zmin], [xmax,
    ymax, zmax]]``, ``size_mm``, ``closed`` (no boundary and no non-manifold edges),
    ``oriented`` (every edge of two faces run both ways), ``boundary_edges``, ``holes``
    (loops of boundary edges), ``holes_at_mm`` (``[[x, y, z], boundary edges]`` of the
    largest holes, at most :data:`~shellvox.model._soup.HOLES_LISTED`),
    ``non_manifold_edges``, ``non_manifold_at_mm`` (``[x, y, z]`` or None),
    ``misoriented_edges``, ``parts``, ``open_parts``, ``overlapping_parts`` (``[i, j]``
    pairs of closed parts that intersect or nest), ``buried_faces``, ``inside_out_parts``
    (part numbers), ``encloses_volume``, ``volume_mm3`` (signed, divergence theorem),
    ``unit`` and ``up`` (as the loader read them, None for a mesh made in code),
    ``colour`` (``texture``, ``vertex``, ``face`` or ``none``), ``textures``
    (``[width, height]`` per material image), ``materials`` and ``distinct_colours``
    (distinct sRGBA values among vertex/face colours or texture pixels).
    """
    soup = inspect_soup(mesh)
    loaded = getattr(mesh, "loaded", None) or {}
    lower = mesh.vertices.min(axis=0)
    upper = mesh.vertices.max(axis=0)
    textures = [
        [int(m.image.shape[1]), int(m.image.shape[0])]
        for m in mesh.materials
        if m.image is not None
    ]
    return {
        "path": mesh.source,
        "faces": len(mesh.faces),
        "vertices": len(mesh.vertices),
        "bounds_mm": [lower.tolist(), upper.tolist()],
        "size_mm": (upper - lower).tolist(),
        "closed": soup.boundary_edges == 0 and soup.non_manifold_edges == 0,
        "oriented": soup.misoriented_edges == 0,
        "boundary_edges": soup.boundary_edges,
        "holes": len(soup.hole_edges),
        "holes_at_mm": [
            [centre.tolist(), int(edges)]
            for centre, edges in zip(
                soup.hole_centres[:HOLES_LISTED], soup.hole_edges[:HOLES_LISTED], strict=True
            )
        ],
        "non_manifold_edges": soup.non_manifold_edges,
        "non_manifold_at_mm": (
            None if soup.non_manifold_at is None else soup.non_manifold_at.tolist()
        ),
        "misoriented_edges": soup.misoriented_edges,
        "parts": len(soup.part_faces),
        "open_parts": int((~soup.part_closed).sum()),
        "overlapping_parts": (soup.overlapping + 1).tolist(),
        "buried_faces": soup.buried_faces,
        "inside_out_parts": (soup.inside_out + 1).tolist(),
        "encloses_volume": soup.encloses_volume,
        "volume_mm3": signed_volume(mesh.vertices, mesh.faces),
        "unit": loaded.get("unit"),
        "up": loaded.get("up"),
        "colour": mesh.colour_kind,
        "textures": textures,
        "materials": len(mesh.materials),
        "distinct_colours": _distinct_colours(mesh),
    }


def _distinct_colours(mesh: ColouredMesh) -> int:
    if mesh.colour_kind == "vertex" and mesh.corner_rgba is not None:
        values = mesh.corner_rgba.reshape(-1, 4)
    elif mesh.colour_kind == "face" and mesh.face_rgba is not None:
        values = mesh.face_rgba
    elif mesh.colour_kind == "texture":
        used = set() if mesh.face_material is None else set(np.unique(mesh.face_material).tolist())
        blocks = [
            m.image.reshape(-1, 4)
            if m.image is not None
            else np.rint(np.clip(m.factor, 0, 1) * 255).astype(np.uint8)[None]
            for i, m in enumerate(mesh.materials)
            if i in used
        ]
        values = np.concatenate(blocks) if blocks else np.zeros((0, 4), np.uint8)
    else:
        return 1
    # One uint32 per RGBA value: a 1-D unique instead of unique(axis=0).
    packed = np.ascontiguousarray(values, np.uint8).view(np.uint32).reshape(-1)
    return len(np.unique(packed))
