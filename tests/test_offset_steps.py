"""Depth steps: where neighbouring faces take different depths, the shell follows the deeper.

The layer's core is the set of points at least ``D_f`` from every face ``f``; next to a
deeper face the boundary is rounded about its edge (and corners), reaching under the
shallower neighbour. Truths: the analytic profile of such a step on a flat top, and the
definition itself, evaluated with trimesh's exact point-triangle distances to every face.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from offset import offset_shells
from offset.band import ARC_STEP_RAD, CAP_STEP_RAD
from offset.intersections import intersecting_pairs
from offset.pieces import GROW_FRACTION


def _margin_to_bands(vertices, faces, depth, points):
    """Return ``min_f dist(p, T_f) - D_f`` for every point (exact, all faces)."""
    tri = vertices[faces]
    out = np.full(len(points), np.inf)
    for start in range(0, len(points), 200):
        p = points[start : start + 200]
        rep = np.repeat(p, len(faces), axis=0)
        foot = trimesh.triangles.closest_point(np.tile(tri, (len(p), 1, 1)), rep)
        dist = np.linalg.norm(foot - rep, axis=1).reshape(len(p), len(faces))
        out[start : start + 200] = (dist - depth[None, :]).min(axis=1)
    return out


def test_a_step_on_a_flat_top_is_the_deep_side_rounded():
    box = trimesh.creation.box((10.0, 10.0, 6.0))
    for _ in range(3):
        box = box.subdivide()
    v, f = np.asarray(box.vertices), np.asarray(box.faces, dtype=np.int64)
    top = box.face_normals[:, 2] > 0.9
    deep = top & (v[f].mean(axis=1)[:, 0] < 0)
    d_deep, d_shallow = 1.0, 0.3
    depth = np.where(deep, d_deep, d_shallow)
    (shell,) = offset_shells(v, f, [depth])
    mesh = trimesh.Trimesh(shell.vertices, shell.faces, process=False)
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert len(intersecting_pairs(shell.vertices, shell.faces)) == 0
    # Under the top, away from the box's sides: depth below the top face, analytically
    # D1 over the deep half and max(D2, sqrt(D1^2 - s^2)) at s from the step.
    x, y, z = shell.vertices.T
    under_top = (np.abs(y) < 3.0) & (np.abs(x) < 3.0) & (z > 3.0 - 1.5 * d_deep)
    s = x[under_top]
    got = 3.0 - z[under_top]

    def profile(s):
        rounded = np.sqrt(np.clip(d_deep**2 - np.clip(s, 0, None) ** 2, 0, None))
        return np.where(s <= 0, d_deep, np.maximum(d_shallow, rounded))

    g = GROW_FRACTION * d_deep
    assert np.all(got <= profile(s - g) + 1e-9)  # never deeper than the pieces reach
    # Shallower only by the arc's chords: radially, from the step's edge.
    assert np.all(got >= d_shallow - 1e-9)
    assert np.all(got[s <= 0] >= d_deep - 1e-9)
    radial = np.hypot(np.clip(s, 0, None), got)
    assert np.all(radial >= d_deep * np.cos(ARC_STEP_RAD / 2) - 1e-9)
    # The rounding is there: at 0.5 mm from the step the shell is sqrt(0.75) deep.
    near = np.abs(s - 0.5) < 0.05
    assert near.any()
    assert np.allclose(got[near], profile(s[near]), atol=0.01)


@pytest.mark.parametrize("seed", [0, 1])
def test_shell_points_lie_on_the_boundary_of_the_union_of_bands(seed):
    notch = trimesh.creation.box((4.0, 4.0, 8.0))
    notch.apply_translation([3.0, 3.0, 0.0])
    solid = trimesh.creation.box((10.0, 10.0, 6.0)).difference(notch).subdivide()
    v, f = np.asarray(solid.vertices), np.asarray(solid.faces, dtype=np.int64)
    rng = np.random.default_rng(seed)
    depth = rng.choice([0.4, 0.9], size=len(f))
    (shell,) = offset_shells(v, f, [depth])
    mesh = trimesh.Trimesh(shell.vertices, shell.faces, process=False)
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert len(intersecting_pairs(shell.vertices, shell.faces)) == 0
    some = rng.choice(len(shell.faces), size=min(1500, len(shell.faces)), replace=False)
    centroid = shell.vertices[shell.faces[some]].mean(axis=1)
    margin = _margin_to_bands(v, f, depth, centroid)
    # Never deeper than some face asks (pieces are inscribed; they overlap by 5e-5 D) ...
    assert margin.max() <= 5e-5 * depth.max() + 1e-12
    # ... and shallower only by the facets of the rounded pieces (caps: 1.1 % D).
    assert margin.min() >= -(1 - np.cos(CAP_STEP_RAD / np.sqrt(2))) * depth.max() - 1e-9
