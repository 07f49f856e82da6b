"""The models the colour benchmarks build: the default model and shared meshes at 30 mm."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "meshes"

#: name -> (path, largest side in mm or None for the model's own size)
MODELS = {
    "default": (ROOT / "data" / "colour_target" / "colour_target.obj", None),
    "spot_30mm": (SHARED / "spot" / "spot_triangulated.obj", 30.0),
    "duck_30mm": (SHARED / "duck" / "Duck.glb", 30.0),
    "airplane_30mm": (SHARED / "airplane" / "colored_airplane.ply", 30.0),
}
