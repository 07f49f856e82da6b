"""Matching the faces of a changed mesh to the faces of the original
(shellvox.offset.reference.mesh_diff)."""

from __future__ import annotations

import numpy as np
import trimesh

from shellvox.offset.reference.mesh_diff import face_origin


def test_face_origin_follows_permutations_and_finds_changed_faces():
    # The truth is the permutation applied: vertices and faces reordered, corners
    # rotated; some faces flipped, some moved by one ulp, some removed, some added.
    rng = np.random.default_rng(7)
    mesh = trimesh.creation.icosphere(3, 10.0)
    v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces, dtype=np.int64)
    v_perm = rng.permutation(len(v))
    new_v = v[v_perm]
    old_to_new_vertex = np.argsort(v_perm)
    f_perm = rng.permutation(len(f))[: len(f) - 50]  # 50 faces removed
    new_f = old_to_new_vertex[f[f_perm]]
    shift = rng.integers(0, 3, len(new_f))[:, None]
    new_f = np.take_along_axis(new_f, (shift + np.arange(3)) % 3, axis=1)  # rotated
    expected = f_perm.copy()
    flipped = rng.random(len(new_f)) < 0.05
    new_f[flipped] = new_f[flipped][:, ::-1]
    expected[flipped] = -1
    # One vertex moved by one ulp: every face around it is new.
    moved = int(new_f[0, 0])
    new_v = new_v.copy()
    new_v[moved, 0] = np.nextafter(new_v[moved, 0], np.inf)
    expected[np.any(new_f == moved, axis=1)] = -1
    extra = np.array([[0, 1, 2]])  # a face the old mesh does not have
    assert not any(set(map(tuple, [(0, 1, 2), (1, 2, 0), (2, 0, 1)])) & set(map(tuple, new_f)))
    origin = face_origin(v, f, new_v, np.concatenate([new_f, extra]))
    np.testing.assert_array_equal(origin, np.r_[expected, -1])
    assert np.count_nonzero(expected >= 0) > 0.9 * len(f)


def test_face_origin_of_empty_meshes():
    v = np.eye(3)
    f = np.array([[0, 1, 2]])
    empty = np.zeros((0, 3), dtype=np.int64)
    assert face_origin(v, empty, v, f).tolist() == [-1]
    assert face_origin(v, f, v, empty).shape == (0,)
