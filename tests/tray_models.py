"""Three small models of different colour sources, for tray tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

DEFAULT_MODEL = Path(__file__).resolve().parents[1] / "data" / "colour_target" / "colour_target.obj"


def tray_models(folder: Path) -> list[Path]:
    """The default model (texture), a vertex-coloured ball and a face-coloured box."""
    ball = trimesh.creation.icosphere(subdivisions=3, radius=6.0)
    rgb = (np.abs(ball.vertices) / 6 * 255).astype(np.uint8)
    ball.visual.vertex_colors = np.c_[rgb, np.full(len(rgb), 255, np.uint8)]
    ball.export(folder / "ball.ply")
    box = trimesh.creation.box(extents=(10.0, 8.0, 6.0))
    colours = np.zeros((12, 4), np.uint8)
    colours[:, 0], colours[:, 1], colours[:, 3] = np.arange(12) * 20, 200, 255
    box.visual.face_colors = colours
    box.export(folder / "box.ply")
    return [DEFAULT_MODEL, folder / "ball.ply", folder / "box.ply"]
