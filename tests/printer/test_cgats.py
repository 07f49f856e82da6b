"""CGATS.17 readings: i1Profiler and ArgyllCMS styles, the id field, percent or fraction."""

from __future__ import annotations

import numpy as np
import pytest
from calibration_sim import write_argyll, write_i1profiler

from shellvox.printer import CgatsError, Readings, read_cgats, write_cgats

BANDS = np.arange(400.0, 710.0, 10.0)


def _values(n):
    return np.random.default_rng(0).uniform(0.02, 0.95, (n, len(BANDS)))


def test_i1profiler_ids_from_sample_name_when_asked(tmp_path):
    path = tmp_path / "i1.txt"
    ids = ["P001-a", "P002-b", "P003-c"]
    values = _values(3)
    write_i1profiler(path, ids, BANDS, values)
    plain = read_cgats(path)  # no ids wanted: the first id field, SampleID's numbers
    assert plain.sample_ids == ("1", "2", "3")
    named = read_cgats(path, expected_ids=ids)
    assert named.sample_ids == tuple(ids)
    np.testing.assert_allclose(named.reflectance, values, atol=6e-7)  # percent read as fraction
    np.testing.assert_array_equal(named.wavelengths_nm, BANDS)


def test_argyll_fraction_and_own_writer_round_trip(tmp_path):
    ids = ["A1", "A2"]
    values = _values(2)
    write_argyll(tmp_path / "a.ti3", ids, BANDS, values)
    read = read_cgats(tmp_path / "a.ti3", expected_ids=ids)
    np.testing.assert_allclose(read.reflectance, values, atol=6e-7)
    write_cgats(tmp_path / "b.txt", read, percent=True)
    again = read_cgats(tmp_path / "b.txt")
    assert again.sample_ids == tuple(ids)
    np.testing.assert_allclose(again.reflectance, values, atol=6e-7)


def test_duplicate_in_the_matching_field_refused(tmp_path):
    path = tmp_path / "i1.txt"
    write_i1profiler(path, ["P1", "P2", "P1"], BANDS, _values(3))
    with pytest.raises(CgatsError, match="'P1' is given twice"):
        read_cgats(path, expected_ids=["P1", "P2"])


def test_interpolation_and_range(tmp_path):
    readings = Readings(("x",), np.array([380.0, 730.0]), np.array([[0.2, 0.9]]))
    np.testing.assert_allclose(readings.at([555.0], "f"), [[0.55]])
    with pytest.raises(CgatsError, match="380-730 nm"):
        readings.at([360.0, 700.0], "f")


def test_a_cgats_error_is_an_input_error_with_its_one_line(tmp_path):
    from shellvox.errors import InputError

    path = tmp_path / "i1.txt"
    write_i1profiler(path, ["P1", "P1"], BANDS, _values(2))
    with pytest.raises(InputError) as caught:
        read_cgats(path, expected_ids=["P1"])
    error = caught.value
    assert isinstance(error, CgatsError)
    assert str(error) == str(InputError(error.path, error.problem, error.fix))
    assert str(error).startswith(f"{path}: ")
    assert "\n" not in str(error)
