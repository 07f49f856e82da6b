from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from shellvox.cli.values import parse_voxel_size
from shellvox.errors import InputError
from shellvox.printer import load_profile
from shellvox.voxel.grid import GridSpec


def test_centre_convention_stated_in_voxel_init():
    grid = GridSpec((10.0, 20.0, 30.0), (0.5, 0.25, 0.1), (4, 5, 6))
    # voxel (z, y, x) = (3, 2, 1) has its centre at origin + (x*vx, y*vy, z*vz)
    centre = grid.index_to_world([[3, 2, 1]])[0]
    np.testing.assert_allclose(centre, [10.5, 20.5, 30.3])
    np.testing.assert_allclose(grid.world_to_index([centre])[0], [3, 2, 1])
    np.testing.assert_allclose(grid.axis_mm("x"), 10.0 + 0.5 * np.arange(6))
    assert grid.axis_mm("z").shape == (4,)


def test_from_bounds_covers_box_plus_margin():
    grid = GridSpec.from_bounds([0, 0, 0], [10, 5, 2], (0.3, 0.2, 0.1), margin_mm=1.0)
    for axis, lo, hi in (("x", 0, 10), ("y", 0, 5), ("z", 0, 2)):
        centres = grid.axis_mm(axis)
        assert centres[0] <= lo - 1.0 + 1e-9
        assert centres[-1] >= hi + 1.0 - 1e-9


@settings(max_examples=50, deadline=None)
@given(
    st.lists(st.floats(-100, 100), min_size=3, max_size=3),
    st.lists(st.floats(0.01, 2.0), min_size=3, max_size=3),
)
def test_round_trip_within_half_voxel(point, voxel):
    grid = GridSpec((-1.0, 2.0, 3.0), (voxel[0], voxel[1], voxel[2]), (1, 1, 1))
    index = np.rint(grid.world_to_index([point]))
    back = grid.index_to_world(index)[0]
    assert np.all(np.abs(back - point) <= 0.5 * np.asarray(voxel) + 1e-9)


def test_matrix_matches_index_to_world():
    grid = GridSpec((1.0, 2.0, 3.0), (0.1, 0.2, 0.3), (2, 2, 2))
    xyz1 = grid.index_to_world_matrix() @ np.array([4.0, 5.0, 6.0, 1.0])
    np.testing.assert_allclose(xyz1[:3], grid.index_to_world([[6, 5, 4]])[0])


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"origin_mm": (0.0, 0.0), "voxel_mm": (1.0, 1.0, 1.0), "shape_zyx": (1, 1, 1)}, "origin"),
        (
            {"origin_mm": (0.0, 0.0, 0.0), "voxel_mm": (1.0, 0.0, 1.0), "shape_zyx": (1, 1, 1)},
            "voxel_mm",
        ),
        (
            {"origin_mm": (0.0, 0.0, 0.0), "voxel_mm": (1.0, 1.0, 1.0), "shape_zyx": (0, 1, 1)},
            "shape_zyx",
        ),
    ],
)
def test_bad_grid_rejected(kwargs, match):
    with pytest.raises(ValueError, match=match):
        GridSpec(**kwargs)


def test_printer_profiles_and_voxel_size():
    np.testing.assert_allclose(load_profile("j750").voxel_mm, (25.4 / 600, 25.4 / 300, 0.027))
    assert parse_voxel_size("0.1, 0.2,0.3") == (0.1, 0.2, 0.3)
    assert parse_voxel_size("0.5") == (0.5, 0.5, 0.5)
    with pytest.raises(InputError, match="j750"):
        load_profile("nope")
    for bad in ("1,-1,1", "a,b,c", "1,1", "inf", "nan,1,1"):
        with pytest.raises(InputError, match="--voxel-size"):
            parse_voxel_size(bad)
