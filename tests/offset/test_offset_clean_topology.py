"""clean_shell when a cleaning changes the topology without a crossing to freeze around."""

from __future__ import annotations

import numpy as np
import trimesh

import shellvox.offset.reference.clean as clean
from shellvox.offset.reference.clean import CleanedMesh, clean_shell


def test_a_topology_change_without_crossings_keeps_the_input(monkeypatch):
    # The duck at --scale 5 (robust): a collapse changed the Euler characteristic, no pair
    # crossed and nothing folded, so there was nothing to freeze (empty concatenate).
    box = trimesh.creation.box((2.0, 2.0, 2.0))
    v, f = np.asarray(box.vertices), np.asarray(box.faces, dtype=np.int64)
    two_v = np.concatenate([v, v + 10.0])
    two_f = np.concatenate([f, f + len(v)])  # two boxes: Euler characteristic 4, not 2

    def changed_topology(v_in, f_in, tol, frozen):
        mesh = CleanedMesh(two_v, two_f, tol, 0, 0, 0.0, 0, 0)
        return mesh, np.arange(len(two_v)) % len(v_in)

    monkeypatch.setattr(clean, "_clean", changed_topology)
    out = clean_shell(v, f, tol=1e-3)
    np.testing.assert_array_equal(out.vertices, v)
    np.testing.assert_array_equal(out.faces, f)
