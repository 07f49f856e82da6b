"""The calibration chart and ``shellvox calibrate`` (issue 24, item 5).

The done-when: the chart printed and measured with hidden optics (the j750's assumed K
and S times smooth lognormal factors) and 0.2 % reflectance noise; the fitted profile
predicts 300 unseen stacks within CIEDE2000 median 0.5, p95 1.5 of the hidden truth.
"""

from __future__ import annotations

import io
import json
import tomllib
import zipfile

import numpy as np
import pytest
from calibration_sim import hidden_truth, measure, random_stacks, write_argyll, write_i1profiler
from PIL import Image

from shellvox.cli import main
from shellvox.printer import (
    chart_json,
    chart_layout,
    chart_readings,
    chart_slab,
    load_profile,
    profile_text,
    profile_with_optics,
    read_chart,
)
from shellvox.voxel.colour import delta_e_of_readings, predict


@pytest.fixture(scope="module")
def chart_file(tmp_path_factory):
    """chart.json of the j750 chart (written from the pure functions, no job)."""
    profile = load_profile("j750")
    path = tmp_path_factory.mktemp("chart") / "chart.json"
    content = chart_json(chart_layout(profile), profile, profile_text("j750"))
    path.write_text(json.dumps(content), encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def measured(chart_file):
    """The chart's ids, wavelengths and noisy readings under the hidden truth."""
    chart = read_chart(chart_file)
    truth = hidden_truth(chart.optics)
    ids = [p.patch_id for p in chart.patches]
    return chart, truth, ids, measure(truth, chart.patches)


def _refused(capsys, argv, *needles):
    status = main(argv)
    err = capsys.readouterr().err
    assert status == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("shellvox: error: ")
    for needle in needles:
        assert needle in lines[0], lines[0]
    return lines[0]


@pytest.mark.slow
def test_calibrate_recovers_hidden_optics(tmp_path, chart_file, measured, capsys):
    chart, truth, ids, values = measured
    cgats = tmp_path / "chart.txt"
    write_i1profiler(cgats, ids, chart.optics.wavelengths_nm, values)
    out = tmp_path / "calibrated.toml"
    assert main(["calibrate", str(chart_file), str(cgats), "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "residual reflectance: RMS" in printed
    assert "cross-validated CIEDE2000" in printed
    profile = load_profile(out)
    assert not profile.optics.assumed
    assert profile.optics.names == chart.optics.names
    stacks = random_stacks(chart.optics.roles, 300)
    errors = delta_e_of_readings(truth, predict(profile.optics, stacks), predict(truth, stacks))
    print(
        f"unseen stacks CIEDE2000: median {np.median(errors):.3f}, "
        f"p95 {np.percentile(errors, 95):.3f}, max {errors.max():.3f}"
    )
    assert np.median(errors) < 0.5
    assert np.percentile(errors, 95) < 1.5
    # the start (assumed optics) was far from the truth: the fit did the work
    before = delta_e_of_readings(truth, predict(chart.optics, stacks), predict(truth, stacks))
    assert np.median(before) > 5 * np.median(errors)


@pytest.mark.parametrize("style", ["i1profiler", "argyll"])
def test_readings_matched_by_id_in_either_style(tmp_path, measured, style):
    chart, _, ids, values = measured
    path = tmp_path / "m.txt"
    order = np.random.default_rng(0).permutation(len(ids))  # any row order
    writer = write_i1profiler if style == "i1profiler" else write_argyll
    writer(path, [ids[i] for i in order], chart.optics.wavelengths_nm, values[order])
    got = chart_readings(chart, path)
    np.testing.assert_allclose(got, values, atol=6e-7)


def _missing(ids, values):
    return ids[:5] + ids[6:], np.delete(values, 5, axis=0), ids[5]


def _duplicate(ids, values):
    return [*ids[:7], ids[6], *ids[8:]], values, ids[6]


def _unknown(ids, values):
    return [*ids[:3], "P999-nothing", *ids[4:]], values, "P999-nothing"


def _nan(ids, values):
    values = values.copy()
    values[4, 10] = np.nan
    return ids, values, ids[4]


def _too_bright(ids, values):
    values = values.copy()
    values[9, 3] = 1.2
    return ids, values, ids[9]


@pytest.mark.parametrize(
    ("edit", "needle"),
    [
        (_missing, "has no reading"),
        (_duplicate, "given twice"),
        (_unknown, "not a patch"),
        (_nan, "NaN or outside"),
        (_too_bright, "outside [0, 1.05]"),
    ],
    ids=["missing", "duplicate", "unknown", "nan", "too-bright"],
)
def test_refused_readings(tmp_path, chart_file, measured, capsys, edit, needle):
    chart, _, ids, values = measured
    ids, values, name = edit(list(ids), values)
    path = tmp_path / "m.txt"
    write_argyll(path, ids, chart.optics.wavelengths_nm, values)
    out = tmp_path / "p.toml"
    line = _refused(capsys, ["calibrate", str(chart_file), str(path), "-o", str(out)], needle, name)
    assert "m.txt" in line
    assert not out.exists()


def test_refused_malformed_row(tmp_path, chart_file, measured, capsys):
    chart, _, ids, values = measured
    path = tmp_path / "m.txt"
    write_argyll(path, ids, chart.optics.wavelengths_nm, values)
    lines = path.read_text().splitlines()
    row = next(i for i, line in enumerate(lines) if line.startswith(ids[2] + " "))
    lines[row] = " ".join(lines[row].split()[:-3])  # three values short
    path.write_text("\n".join(lines) + "\n")
    out = tmp_path / "p.toml"
    _refused(capsys, ["calibrate", str(chart_file), str(path), "-o", str(out)], ids[2], "values")
    lines[row] = lines[row] + " x y z"  # non-numeric
    path.write_text("\n".join(lines) + "\n")
    _refused(
        capsys, ["calibrate", str(chart_file), str(path), "-o", str(out)], ids[2], "non-numeric"
    )
    assert not out.exists()


def _chart_edits():
    def layer_sum(data):
        data["patches"][3]["layers"][0]["fractions"] = {"VeroCyan-V": 0.5}
        return data["patches"][3]["id"]

    def twice(data):
        data["patches"][4]["id"] = data["patches"][2]["id"]
        return data["patches"][2]["id"]

    def thickness(data):
        data["patches"][1]["layers"][0]["thickness_mm"] = -1
        return data["patches"][1]["id"]

    def material(data):
        data["patches"][6]["layers"][0]["fractions"] = {"Unobtainium": 1.0}
        return "Unobtainium"

    def optics(data):
        data["optics"]["materials"][0]["k_per_mm"] = [1.0]
        return "optics.materials[0]"

    return [layer_sum, twice, thickness, material, optics]


@pytest.mark.parametrize("edit", _chart_edits(), ids=lambda f: f.__name__)
def test_refused_malformed_chart(tmp_path, chart_file, measured, capsys, edit):
    data = json.loads(chart_file.read_text())
    needle = edit(data)
    bad = tmp_path / "chart.json"
    bad.write_text(json.dumps(data))
    cgats = tmp_path / "m.txt"
    chart, _, ids, values = measured
    write_argyll(cgats, ids, chart.optics.wavelengths_nm, values)
    out = tmp_path / "p.toml"
    _refused(capsys, ["calibrate", str(bad), str(cgats), "-o", str(out)], "chart.json", needle)
    assert not out.exists()


def test_refused_chart_not_json(tmp_path, capsys):
    bad = tmp_path / "chart.json"
    bad.write_text("{not json")
    cgats = tmp_path / "m.txt"
    cgats.write_text("")
    out = tmp_path / "p.toml"
    _refused(capsys, ["calibrate", str(bad), str(cgats), "-o", str(out)], "chart.json", "not JSON")
    assert not out.exists()


def test_profile_with_optics_keeps_every_key():
    original = profile_text("j750")
    profile = load_profile("j750")
    text = profile_with_optics(original, profile.optics, header="a test")
    before, after = tomllib.loads(original), tomllib.loads(text)
    assert {k: v for k, v in after.items() if k != "optics"} | {"materials": None} == {
        **before,
        "materials": None,
    }
    for old, new in zip(before["materials"], after["materials"], strict=True):
        assert {k: v for k, v in new.items() if not k.startswith("km_")} == old
    assert "km_k_per_mm" not in after["materials"][0]
    np.testing.assert_allclose(
        [m["km_s_per_mm"] for m in after["materials"][1:]], profile.optics.s_per_mm, rtol=1e-5
    )


def test_chart_patches_printable():
    profile = load_profile("j750")
    layout = chart_layout(profile)
    vz = profile.voxel_mm[2]
    roles = profile.optics.roles
    for patch, slices in zip(layout.patches, layout.slices, strict=True):
        np.testing.assert_allclose(patch.fractions.sum(axis=1), 1.0)
        np.testing.assert_allclose(patch.thickness_mm, slices * vz)
        last = patch.fractions[-1]
        assert last[roles.index("white")] == 1 or last[roles.index("black")] == 1
        assert patch.thickness_mm[-1] >= 1.0 - vz
    # a patch's column, slice by slice from its top: each layer's voxels as its fractions
    i = next(i for i, p in enumerate(layout.patches) if p.fractions[0].max() < 0.9)
    x0, y0, x1, y1 = layout.boxes[i]
    top = int(layout.slices[i].sum())
    first = int(layout.slices[i][0])
    slab = chart_slab(layout, top - first, top)[:, y0:y1, x0:x1]
    counts = np.bincount(slab.ravel(), minlength=256)[layout.material_indices]
    np.testing.assert_allclose(counts / slab.size, layout.patches[i].fractions[0], atol=0.01)
    above = chart_slab(layout, top, top + 1)[:, y0:y1, x0:x1]
    assert not above.any()


@pytest.mark.slow
def test_chart_command_writes_job(tmp_path, capsys):
    out = tmp_path / "chart"
    assert main(["chart", "-o", str(out), "--printer", "j750"]) == 0
    assert "78 patches" in capsys.readouterr().out
    data = json.loads((out / "chart.json").read_text())
    ids = [p["id"] for p in data["patches"]]
    assert len(set(ids)) == len(ids)
    for patch in data["patches"]:
        for layer in patch["layers"]:
            assert sum(layer["fractions"].values()) == pytest.approx(1.0, abs=1e-5)
            assert layer["thickness_mm"] > 0
        last = patch["layers"][-1]
        assert list(last["fractions"].values()) == [1.0]
        backing = {load_profile("j750").material(role).name for role in ("white", "black")}
        assert next(iter(last["fractions"])) in backing
        assert last["thickness_mm"] >= 0.99
    chart = read_chart(out / "chart.json")
    assert [p.patch_id for p in chart.patches] == ids
    assert chart.optics.assumed
    assert {m["name"] for m in data["optics"]["materials"]} == set(chart.optics.names)
    profile = load_profile("j750")
    layout = chart_layout(profile)
    keys = {m.rgba_key: m.index for m in profile.materials}
    with zipfile.ZipFile(out / "job.gcvf") as job:
        names = job.namelist()
        assert "ConfigFile.xml" in names
        assert sum(n.startswith("layer_") for n in names) == max(30, layout.grid.shape_zyx[0])
        # the first mixed patch, its top layer: voxels as its fractions
        i = next(i for i, p in enumerate(layout.patches) if p.fractions[0].max() < 0.9)
        x0, y0, x1, y1 = layout.boxes[i]
        top = int(layout.slices[i].sum())
        counts = np.zeros(256, np.int64)
        n_y = layout.grid.shape_zyx[1]
        for z in range(top - int(layout.slices[i][0]), top):
            with Image.open(io.BytesIO(job.read(f"layer_{z}.png"))) as png:
                image = np.asarray(png.convert("RGBA"))
            region = image[n_y - y1 : n_y - y0, x0:x1].reshape(-1, 4)  # row 0: max y
            colours, inverse = np.unique(region, axis=0, return_inverse=True)
            index = np.array([keys[tuple(int(c) for c in px)] for px in colours])
            np.add.at(counts, index[inverse.ravel()], 1)
    share = counts[layout.material_indices] / counts.sum()
    np.testing.assert_allclose(share, layout.patches[i].fractions[0], atol=0.01)
    with Image.open(out / "preview" / "chart.png") as preview:
        assert preview.size[0] > 300


@pytest.mark.slow
def test_chart_command_png_printer(tmp_path, capsys):
    out = tmp_path / "chart"
    assert main(["chart", "-o", str(out), "--printer", "generic-cmykw"]) == 0
    assert str(out / "slices") in capsys.readouterr().out
    layout = chart_layout(load_profile("generic-cmykw"))
    slices = sorted((out / "slices").glob("slice_*.png"))
    assert len(slices) == layout.grid.shape_zyx[0]
    assert not (out / "job.gcvf").exists()
    assert read_chart(out / "chart.json").patches[0].patch_id == layout.patches[0].patch_id
