"""Shell guards (offset.guards) on shells whose defects are known by construction."""

from __future__ import annotations

import numpy as np
import trimesh

from offset.guards import Surface, crossing_count, too_deep_count


def _box(size: float) -> tuple[np.ndarray, np.ndarray]:
    box = trimesh.creation.box((size, size, size))
    return np.asarray(box.vertices, dtype=np.float64), np.asarray(box.faces, dtype=np.int64)


def test_exact_inner_box_is_neither_deep_nor_crossing():
    v, f = _box(10.0)
    shell_v, shell_f = _box(9.0)  # every face 0.5 mm inside
    surface = Surface(v, f)
    assert surface.n_crossing == 0
    assert too_deep_count(surface, np.full(len(f), 0.5), shell_v, shell_f) == 0
    assert crossing_count(shell_v, shell_f) == 0


def test_a_face_cut_deeper_than_asked_is_counted():
    v, f = _box(10.0)
    shell_v, shell_f = _box(9.0)
    shell_v = shell_v.copy()
    shell_v[shell_v[:, 2] > 0, 2] = 3.0  # the top face 2 mm deep instead of 0.5 mm
    normals = trimesh.Trimesh(shell_v, shell_f, process=False).face_normals
    deep = too_deep_count(Surface(v, f), np.full(len(f), 0.5), shell_v, shell_f)
    # The two top triangles' centroids are 2 mm deep; the side triangles touching the
    # top have centroids between 0.5 and 2 mm deep along z but 0.5 mm from their side.
    assert deep == int(np.count_nonzero(normals[:, 2] > 0.5))


def test_variable_depth_is_not_a_defect():
    v, f = _box(10.0)
    depth = np.full(len(f), 0.5)
    normals = trimesh.Trimesh(v, f, process=False).face_normals
    depth[normals[:, 2] > 0.5] = 2.0  # the top layer is thicker
    shell_v, shell_f = _box(9.0)
    shell_v = shell_v.copy()
    shell_v[shell_v[:, 2] > 0, 2] = 3.0
    assert too_deep_count(Surface(v, f), depth, shell_v, shell_f) == 0
