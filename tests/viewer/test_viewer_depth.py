"""The viewer's probe names the face whose layers the build gave a voxel."""

from __future__ import annotations

import numpy as np
import trimesh

from shellvox.viewer._depth import Surface
from shellvox.voxel.geometry import SurfaceIndex


def _surface(box: trimesh.Trimesh) -> Surface:
    index = SurfaceIndex.build(np.asarray(box.vertices), np.asarray(box.faces, np.int64))
    n = len(box.faces)
    return Surface(index, np.ones((1, n)), np.ones(n))


def test_a_tie_goes_to_the_lowest_face_index_as_in_the_build_also_when_moved():
    box = trimesh.creation.box((4.0, 4.0, 4.0))
    point = np.array([1.0, 1.0, 0.3])  # 1 mm from the +x and the +y side alike
    points = np.repeat(point[None], len(box.faces), axis=0)
    each = np.linalg.norm(trimesh.triangles.closest_point(box.triangles, points) - point, axis=1)
    tied = np.flatnonzero(np.isclose(each, each.min(), rtol=1e-12, atol=0))
    assert len(tied) >= 2  # the case means something only with a tie
    distance, face = _surface(box).deciding_face(point)
    assert face == tied.min()
    assert abs(distance - each.min()) < 1e-12
    shift = np.array([123.456, -78.9, 0.1234])
    moved = box.copy()
    moved.apply_translation(shift)
    assert _surface(moved).deciding_face(point + shift)[1] == face
