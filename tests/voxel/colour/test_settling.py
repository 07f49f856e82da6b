"""Settling depth, surface smoothing and the model's report against brute force and
analytic stacks."""

from __future__ import annotations

import colour
import numpy as np
import pytest
import trimesh

from shellvox.thickness import smooth_over_distance
from shellvox.voxel.colour import (
    ModelReport,
    assumed_optics,
    layer,
    mix,
    observer,
    over,
    r_infinity,
    reflectance_to_lab,
    saunderson,
    settling_depth,
    stack,
)
from shellvox.voxel.grid import GridSpec

NAMES = ("VeroCyan", "VeroMagenta", "VeroYellow", "VeroBlack", "VeroWhite", "VeroClear")
ROLES = ("cyan", "magenta", "yellow", "black", "white", "clear")
DISPLAY = [[0, 89, 158], [161, 35, 99], [213, 178, 0], [30, 30, 30], [220, 222, 216],
           [255, 255, 255]]  # fmt: skip
OPTICS = assumed_optics(NAMES, ROLES, DISPLAY)
SEEN = observer(OPTICS.wavelengths_nm)


def _lab(reflectance):
    return reflectance_to_lab(saunderson(reflectance, OPTICS.k1, OPTICS.k2), SEEN)


def test_settling_depth_is_the_last_crossing_on_a_fine_ladder():
    rng = np.random.default_rng(6)
    shares = rng.dirichlet(np.full(6, 0.6), 40)
    k, s = mix(shares, OPTICS.k_per_mm), mix(shares, OPTICS.s_per_mm)
    background = r_infinity(OPTICS.k_per_mm[4], OPTICS.s_per_mm[4])
    found = settling_depth(k, s, background, SEEN, k1=OPTICS.k1, k2=OPTICS.k2, max_mm=3.0)
    deep = _lab(r_infinity(k, s))
    ladder = np.linspace(0, 3.0, 3001)
    for i in range(len(shares)):  # brute force: every 1 um
        lab = _lab(over(layer(k[i], s[i], ladder[:, None]), background))
        far = colour.delta_E(lab, deep[i], method="CIE 2000") > 1.0
        if far[-1]:
            assert not found.settled[i] and found.depth_mm[i] == 3.0
            continue
        last_far = ladder[np.flatnonzero(far)[-1]] if far.any() else 0.0
        assert found.settled[i]
        assert last_far <= found.depth_mm[i] <= last_far + 1e-3 + 1e-9


def test_clear_dilution_does_not_settle_and_white_over_white_settles_at_once():
    background = r_infinity(OPTICS.k_per_mm[4], OPTICS.s_per_mm[4])
    cyan_in_clear = np.array([[0.2, 0, 0, 0, 0, 0.8]])
    white = np.array([[0, 0, 0, 0, 1.0, 0]])
    for shares, settled in ((cyan_in_clear, False), (white, True)):
        found = settling_depth(
            mix(shares, OPTICS.k_per_mm), mix(shares, OPTICS.s_per_mm), background, SEEN,
            k1=OPTICS.k1, k2=OPTICS.k2, max_mm=2.0,
        )  # fmt: skip
        assert bool(found.settled[0]) == settled
    assert found.depth_mm[0] < 1e-6


@pytest.mark.parametrize("subdivisions", [0, 3])
def test_smoothing_over_millimetres_ignores_the_triangulation(subdivisions):
    box = trimesh.creation.box((20, 20, 10))
    for _ in range(subdivisions):
        box = box.subdivide()
    normals = box.face_normals
    side = np.argmax(np.abs(normals), 1) * 2 + (normals.max(1) > 0.5)
    values = np.array([0.3, 0.5, 0.8, 1.0, 1.2, 0.6])[side]
    out = smooth_over_distance(box.triangles_center, normals, box.area_faces, values, 1.0)
    assert out == pytest.approx(values, abs=1e-12)  # sides meet at 90 degrees: kept
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=5)
    ramp = sphere.triangles_center[:, 2]
    smooth = smooth_over_distance(sphere.triangles_center, sphere.face_normals,
                                  sphere.area_faces, ramp, 1.0)  # fmt: skip
    assert ramp.min() <= smooth.min() and smooth.max() <= ramp.max()
    assert np.abs(smooth - ramp).max() > 0  # a curved surface is averaged


def test_the_report_reads_a_halftoned_layer_as_its_mix():
    # A flat part: 0.405 mm of a mix, halftoned with exact shares in every 4 x 5 tile,
    # over white; the prediction is the analytic stack of that mix over deep white.
    rng = np.random.default_rng(1)
    voxel = np.array([0.0423, 0.0846, 0.027])
    shape = (150, 70, 140)
    top, rows = 3.0, 15
    shares = np.array([0.05, 0.3, 0.1, 0.0, 0.55, 0.0])
    volume = np.zeros(shape, np.uint8)
    surface_row = int(np.rint(top / voxel[2]))
    volume[: surface_row - rows + 1] = 5
    tile = np.repeat(np.arange(1, 7), np.rint(shares * 20).astype(int))
    rng.shuffle(tile)
    tile = tile.reshape(4, 5)
    yy, xx = np.meshgrid(np.arange(shape[1]), np.arange(shape[2]), indexing="ij")
    layer_rows = np.arange(surface_row - rows + 1, surface_row + 1)
    volume[layer_rows] = tile[(yy + layer_rows[:, None, None] * 3) % 4,
                              (xx + layer_rows[:, None, None] * 2) % 5]  # fmt: skip
    points = np.column_stack([rng.uniform(1.5, 4.5, (100, 2)), np.full(100, top + voxel[2] / 2)])
    normals = np.tile([0, 0, 1.0], (100, 1))
    grid = GridSpec((0.0, 0.0, 0.0), (0.0423, 0.0846, 0.027), shape)  # voxel centres at i * size
    report = ModelReport(points, normals, grid, OPTICS, disc_radius_mm=1.0)
    for start in range(0, shape[0], 16):
        report.add_slab(start, volume[start : start + 16])
    white = r_infinity(OPTICS.k_per_mm[4], OPTICS.s_per_mm[4])
    expected = _lab(stack(mix(shares, OPTICS.k_per_mm)[None], mix(shares, OPTICS.s_per_mm)[None],
                          [rows * voxel[2]], white))  # fmt: skip
    error = colour.delta_E(report.predicted_lab(), expected, method="CIE 2000")
    # a ray per voxel column, the disc over many 4 x 5 tiles: only the tiles its rim cuts
    # keep the counts from the exact shares
    assert np.median(error) < 0.1 and error.max() < 0.2
