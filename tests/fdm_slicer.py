"""Helpers of the FDM tests: a coloured box, and PrusaSlicer run on a project."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
import trimesh

from shellvox.model import ColouredMesh

PRUSA = shutil.which("prusa-slicer")
#: Side colours of the box (+x, -x, +y, -y) and its core (first) and top/bottom (white).
BOX_FILAMENTS = "#FFFFFF,#FF0000,#00FF00,#0000FF,#FFFF00"


def coloured_box(size=(20.0, 20.0, 10.0)) -> ColouredMesh:
    """Return a box whose sides are red (+x), green (-x), blue (+y), yellow (-y)."""
    box = trimesh.creation.box(size)
    normal = box.face_normals
    rgba = np.full((len(box.faces), 4), 255, np.uint8)
    for axis, sign, rgb in (
        (0, 1, (255, 0, 0)),
        (0, -1, (0, 255, 0)),
        (1, 1, (0, 0, 255)),
        (1, -1, (255, 255, 0)),
    ):
        rgba[sign * normal[:, axis] > 0.9, :3] = rgb
    return ColouredMesh(
        np.asarray(box.vertices, np.float64),
        np.asarray(box.faces, np.int64),
        "face",
        face_rgba=rgba,
    )


def slice_with_prusa(project: Path, gcode: Path) -> subprocess.CompletedProcess[str]:
    """Run ``prusa-slicer --export-gcode`` (skip without it, except in CI)."""
    if PRUSA is None:
        if os.environ.get("CI"):
            pytest.fail("prusa-slicer is missing (CI must slice: scripts/bootstrap.sh installs it)")
        pytest.skip("prusa-slicer is missing: apt-get install prusa-slicer")
    done = subprocess.run(
        [PRUSA, "--export-gcode", str(project), "--output", str(gcode)],
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert done.returncode == 0 and gcode.is_file(), done.stderr[-2000:]
    return done
