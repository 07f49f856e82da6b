"""The optical rule in the voxels: a box whose sides settle at different depths.

The issue's box (20 x 20 x 10 mm), each side a colour whose mix settles at its own
depth under the J750's optics; as 12 triangles and subdivided, the colour layer under
the middle of each side, read back from ``layers.tif`` with tifffile, is the rule's own
value for that colour, within one voxel.
"""

from __future__ import annotations

import numpy as np
import pytest
import tifffile
import trimesh
from builders import j750_layer_model

from shellvox.config import BuildConfig
from shellvox.model import ColouredMesh
from shellvox.stack import build_stack
from shellvox.thickness import DEFAULT_RULE, face_thickness

VOXEL = 0.1
#: +x, -x, +y, -y, +z, -z: light cyan, skin, yellow, grey, red, black.
SIDES = np.array(
    [[150, 220, 240, 255], [220, 170, 140, 255], [230, 200, 20, 255], [128, 128, 128, 255],
     [200, 30, 30, 255], [0, 0, 0, 255]],
    np.uint8,
)  # fmt: skip


def _box(subdivisions: int) -> tuple[ColouredMesh, np.ndarray]:
    box = trimesh.creation.box((20.0, 20.0, 10.0))
    for _ in range(subdivisions):
        box = box.subdivide()
    axis = np.argmax(np.abs(box.face_normals), axis=1)
    side = axis * 2 + (box.face_normals[np.arange(len(axis)), axis] < 0)
    mesh = ColouredMesh(
        np.asarray(box.vertices), np.asarray(box.faces, np.int64), "face",
        face_rgba=SIDES[side], source="box",
    )  # fmt: skip
    return mesh, side


def _depths(tmp_path, subdivisions):
    mesh, side = _box(subdivisions)
    faces = face_thickness(mesh, DEFAULT_RULE, model=j750_layer_model())
    config = BuildConfig(
        voxel_mm=(VOXEL,) * 3,
        thickness_mm=tuple(float(np.median(t)) for t in faces.thickness_mm),
        thickness_source="default rule",
        formats=("tiff",),
        material=None,
    )
    out = tmp_path / f"box{subdivisions}"
    manifest = build_stack(mesh, config, out, thickness=faces.thickness_mm, faces=faces)
    layers = tifffile.imread(out / "layers.tif")
    grid = manifest["grid"]
    origin, voxel = np.array(grid["origin_mm"]), np.array(grid["voxel_size_mm"])
    centre = np.rint((0.0 - origin) / voxel).astype(int)  # (x, y, z) index of the centre
    measured = []
    half = (10.0, 10.0, 5.0)
    for axis in range(3):
        line: list[int | slice] = [centre[2], centre[1], centre[0]]
        line[2 - axis] = slice(None)
        row = layers[tuple(line)]
        coordinate = origin[axis] + voxel[axis] * np.arange(len(row))
        colour = row == 1
        plus = half[axis] - coordinate[colour & (coordinate > 0)].min() + voxel[axis] / 2
        minus = coordinate[colour & (coordinate < 0)].max() + half[axis] + voxel[axis] / 2
        measured += [plus, minus]
    own = [float(np.median(faces.rule_mm[side == k])) for k in range(6)]
    limited = [float(np.median(faces.unsmoothed_mm[side == k])) for k in range(6)]
    return np.array(measured), np.array(own), np.array(limited)


@pytest.mark.slow
def test_each_side_gets_its_colours_depth_however_triangulated(tmp_path):
    coarse, own, limited = _depths(tmp_path, 0)
    fine, own_fine, limited_fine = _depths(tmp_path, 3)
    np.testing.assert_allclose(own, own_fine, atol=1e-9)  # the rule sees the same colours
    np.testing.assert_allclose(limited, limited_fine, atol=1e-9)
    assert len(set(np.round(limited, 2))) >= 4  # the sides really differ
    np.testing.assert_allclose(coarse, limited, atol=VOXEL)
    np.testing.assert_allclose(fine, limited, atol=VOXEL)
