"""The baselines of the shell report against analytic answers (offset/quality/baselines.py)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
import trimesh

from shellvox.offset.quality.baselines import slicer_thickness, vertex_normal_offset


def test_vertex_normal_offset_of_a_regular_icosahedron_is_a_smaller_icosahedron():
    # Every vertex has five equal faces: its area-weighted normal is radial, so a uniform
    # depth d moves each vertex from radius R to R - d.
    ico = trimesh.creation.icosahedron()
    vertices, faces = np.asarray(ico.vertices), np.asarray(ico.faces, np.int64)
    radius = float(np.linalg.norm(vertices[0]))
    (moved, moved_faces), (deeper, _) = vertex_normal_offset(
        vertices, faces, np.array([[0.1] * 20, [0.3] * 20])
    )
    np.testing.assert_array_equal(moved_faces, faces)
    np.testing.assert_allclose(np.linalg.norm(moved, axis=1), radius - 0.1, rtol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(deeper, axis=1), radius - 0.3, rtol=1e-12)
    np.testing.assert_allclose(moved / (radius - 0.1), vertices / radius, atol=1e-12)


def test_slicer_band_is_the_width_on_walls_and_nothing_under_a_flat_top():
    # A slicer offsets each slice's contour by the width: on a vertical wall the band is
    # the width along the normal; under a flat top the inset contour is reached at once
    # (the known weakness of 2D contour offsets that the per-face offset fixes).
    box = trimesh.creation.box((10.0, 10.0, 10.0))
    points = np.array([[5.0, 1.0, 0.3], [-2.0, -5.0, -1.7], [1.0, 2.0, 5.0]])
    normals = np.array([[1.0, 0, 0], [0, -1.0, 0], [0, 0, 1.0]])
    band = slicer_thickness(box, 0.5, points, normals, layer_height_mm=0.1)
    assert band[:2] == pytest.approx([0.5, 0.5], abs=1e-3)
    assert band[2] < 1e-3  # zero, to the bisection's resolution


def test_slicer_band_of_a_tube_fills_its_section_even_odd_without_rtree():
    # A square tube (10 mm outside, a 4 mm square hole through it): every slice is an annulus.
    # On the outer and inner walls the band is the width; rtree, which trimesh's nesting of
    # section loops needs, is no dependency of shellvox, so the check runs where it is absent.
    script = """
import sys
sys.modules["rtree"] = None
import subprocess
import sys

import numpy as np
import trimesh
from shellvox.offset.quality.baselines import slicer_thickness

outer = trimesh.creation.box((10.0, 10.0, 10.0))
hole = trimesh.creation.box((4.0, 4.0, 12.0))
tube = trimesh.boolean.difference([outer, hole], engine="manifold")
points = np.array([[5.0, 1.0, 0.3], [2.0, 0.5, -1.7], [-0.5, -2.0, 2.2], [3.5, 3.5, 5.0]])
normals = np.array([[1.0, 0, 0], [-1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]])
print(*slicer_thickness(tube, 0.5, points, normals, layer_height_mm=0.1))
"""
    run = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, check=False
    )
    assert run.returncode == 0, run.stderr
    band = np.array(run.stdout.split(), dtype=np.float64)
    # outer wall, inner wall (normal into the hole), inner wall, flat top (reached at once)
    assert band[:3] == pytest.approx([0.5, 0.5, 0.5], abs=1e-3)
    assert band[3] < 1e-3
