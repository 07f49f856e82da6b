"""The shell: one layer's inner boundary, as every method returns it."""

from __future__ import annotations

from dataclasses import dataclass

from shellvox.offset._validate import FloatArray, IntArray


@dataclass(frozen=True)
class Shell:
    """One inner shell: the inner boundary of a layer.

    Attributes
    ----------
    vertices : (n, 3) float64, mm
    faces : (m, 3) int64
        Outward-oriented triangles; ``m == 0`` when the layer fills the part (collapse).
        May hold several components.
    layer : int
        1-based layer index, outside in.
    depth_mm : (F,) float64, mm
        Cumulative depth ``D_k(f)`` for every original face.
    """

    vertices: FloatArray
    faces: IntArray
    layer: int
    depth_mm: FloatArray

    def __repr__(self) -> str:
        """One line: the layer, its faces and vertices, its depth range (not the arrays)."""
        depth = self.depth_mm
        span = f"{depth.min():.4g}-{depth.max():.4g}" if len(depth) else "-"
        return (
            f"Shell(layer={self.layer}, {len(self.faces)} faces, {len(self.vertices)} vertices, "
            f"depth {span} mm)"
        )
