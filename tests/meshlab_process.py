"""The pytest side of MeshLab as the tests' independent reader: the skip marker.

MeshLab's checks themselves (each call in a spawned process of its own, a process that
dies twice failing the test) are :func:`shellvox.testing.meshlab_checks`,
:func:`~shellvox.testing.meshlab_crossing_faces` and :func:`~shellvox.testing.meshlab_read`.
"""

from __future__ import annotations

import pytest

from shellvox.testing import HAVE_PYMESHLAB

needs_meshlab = pytest.mark.skipif(not HAVE_PYMESHLAB, reason="pymeshlab is not installed")
