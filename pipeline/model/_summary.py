"""What ``shellvox info`` reports about a loaded model."""

from __future__ import annotations

from typing import Any

import numpy as np

from shellvox.model._mesh import ColouredMesh
from shellvox.model._topology import edge_report, signed_volume


def summarise(mesh: ColouredMesh) -> dict[str, Any]:
    """Return a JSON-serialisable summary of a loaded mesh.

    Keys: ``path``, ``faces``, ``vertices``, ``bounds_mm`` ``[[xmin, ymin, zmin], [xmax,
    ymax, zmax]]``, ``size_mm``, ``closed``, ``oriented``, ``volume_mm3``, ``colour``
    (``texture``, ``vertex``, ``face`` or ``none``), ``textures`` (``[width, height]`` per
    material image), ``materials`` and ``distinct_colours`` (distinct sRGBA values among
    vertex/face colours or texture pixels).
    """
    report = edge_report(mesh.faces)
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
        "closed": bool(report.closed),
        "oriented": bool(report.oriented),
        "volume_mm3": signed_volume(mesh.vertices, mesh.faces),
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
