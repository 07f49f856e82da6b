"""Depth steps: where neighbouring faces take different depths, the shell steps sharply.

Each face's prism goes to its own depth, as the voxel layers take the depth of the
nearest face (shellvox.offset.reference.robust, "Depth steps"). Truths: the analytic profile of a
step on a flat top, and the voxel rule's depth (the nearest face's) read off the same geometry. Also
the defect guard: a step is no defect (before, the guard's one-ring rule flagged the step's wall as
too deep and the shells were recomputed in every union order).
"""

from __future__ import annotations

import numpy as np
import trimesh

from shellvox.offset import offset_shells
from shellvox.offset.crossing.intersections import intersecting_pairs
from shellvox.offset.reference.pieces import GROW_FRACTION


def test_a_step_on_a_flat_top_is_sharp_and_no_defect():
    box = trimesh.creation.box((10.0, 10.0, 6.0))
    for _ in range(3):
        box = box.subdivide()
    v, f = np.asarray(box.vertices), np.asarray(box.faces, dtype=np.int64)
    top = box.face_normals[:, 2] > 0.9
    deep = top & (v[f].mean(axis=1)[:, 0] < 0)
    d_deep, d_shallow = 1.0, 0.3
    depth = np.where(deep, d_deep, d_shallow)
    (shell,) = offset_shells(v, f, [depth], method="robust")  # a ShellDefectWarning fails the test
    mesh = trimesh.Trimesh(shell.vertices, shell.faces, process=False)
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert len(intersecting_pairs(shell.vertices, shell.faces)) == 0
    # Under the top, away from the box's sides, the shell lies at the nearest face's
    # depth: D1 over the deep half, D2 over the shallow half, with the step's wall at
    # the edge moved out by the deeper prism's growth.
    x, y, z = shell.vertices.T
    under = (np.abs(y) < 3.0) & (np.abs(x) < 3.0) & (z > 3.0 - 1.5 * d_deep)
    s, got = x[under], 3.0 - z[under]
    g = GROW_FRACTION * d_deep
    floor = np.abs(got - d_shallow) < 1e-9
    bottom = np.abs(got - d_deep) < 1e-9
    assert np.all(floor | bottom | (np.abs(s - g) < 1e-6))  # floor, bottom or the wall
    assert np.all(s[bottom] <= g + 1e-9) and np.all(s[floor] >= g - 1e-9)
    assert floor.any() and bottom.any()
