"""The public result objects print as one short line, which says what they hold.

``repr()`` of an opened build is the build's grid, voxel size, printer and files (not its
manifest, tens of KB); the same for the build's result and inspection, and each other
result (soft proof, mesh, thickness, shells, tray, calibration) says its own few facts.
Each line is checked against the object's own attributes.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import shellvox
from shellvox.api import Calibration, ShellsResult
from shellvox.printer import chart_json, chart_layout, load_profile, profile_text, read_chart

#: What "short" means here: one line a terminal shows whole, or nearly.
SHORT = 240

#: A small build with materials and a soft proof: the bundled model on a coarse grid.
OPTIONS = shellvox.BuildOptions(
    voxel_size_mm=(0.4, 0.4, 0.4), formats=("tiff",), report_samples=500, proof_density=0.0
)


def _one_short_line(text: str) -> str:
    assert "\n" not in text and len(text) <= SHORT, (len(text), text[:300])
    return text


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    folder = tmp_path_factory.mktemp("repr") / "out"
    return shellvox.build(shellvox.data.colour_target(), folder, OPTIONS, progress=False)


def test_an_opened_build_is_its_grid_voxel_printer_and_files(built):
    build = built.open()
    manifest = json.loads((built.folder / "manifest.json").read_text(encoding="utf-8"))
    assert len(repr(manifest)) > 5 * SHORT  # what the repr used to print whole
    for obj in (build, built, shellvox.inspect_build(built.folder, previews=False)):
        line = _one_short_line(repr(obj))
        assert str(build.shape_zyx) in line
        assert str(tuple(float(v) for v in manifest["grid"]["voxel_size_mm"])) in line
        assert f"printer={manifest['printer']!r}" in line
        for name in manifest["files"]:
            assert repr(name.split("/")[0]) in line or f"'{name.split('/')[0]}/'" in line
    assert repr(str(built.folder)) in repr(build) and repr(str(built.folder)) in repr(built)


def test_a_soft_proof_is_its_samples_and_median_error(built):
    proof = built.open().soft_proof()
    line = _one_short_line(repr(proof))
    assert f"{len(proof)} points" in line
    assert f"{int(proof.predicted.sum())} predicted" in line
    assert f"{np.median(proof.total_de[proof.predicted]):.2f}" in line
    assert repr(proof.optics) in line


def test_a_mesh_and_its_thickness_are_counts_not_arrays():
    mesh = shellvox.load_model(shellvox.data.colour_target())
    line = _one_short_line(repr(mesh))
    assert f"{mesh.n_faces} faces" in line and f"{len(mesh.vertices)} vertices" in line
    assert repr(mesh.colour_kind) in line
    choice = shellvox.layer_thickness(mesh, thickness_mm=(0.5, 0.7))
    line = _one_short_line(repr(choice))
    assert f"2 layers on {mesh.n_faces} faces" in line and "0.5-0.5 mm" in line
    assert repr(choice.source) in line


def test_shells_and_their_result_are_counts_not_arrays(tmp_path):
    vertices = np.array([[0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10]], dtype=np.float64)
    faces = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], dtype=np.int64)
    shell = shellvox.Shell(vertices, faces, 1, np.full(10_000, 0.5))
    line = _one_short_line(repr(shell))
    assert "layer=1, 4 faces, 4 vertices, depth 0.5-0.5 mm" in line
    files = (tmp_path / "shell_1.ply", tmp_path / "report.json")
    report = {"method": {"method": "field", "seconds": {"field": 1.0}}, "layers": [{}] * 500}
    line = _one_short_line(repr(ShellsResult(tmp_path, files, report, (shell,))))
    assert "method='field'" in line and "1 shells" in line
    assert "('shell_1.ply', 'report.json')" in line


def test_a_tray_request_is_its_models_grid_and_printer(tmp_path):
    target = shellvox.data.colour_target()
    request = shellvox.plan_tray_build([target, target], tmp_path / "tray", OPTIONS, gap_mm=2.0)
    line = _one_short_line(repr(request))
    assert f"{len(request.plan.placements)} models" in line
    assert str(request.plan.grid.shape_zyx) in line and "printer='j750'" in line


def test_a_calibration_is_its_profile_materials_and_fit(tmp_path):
    profile = load_profile("j750")
    path = tmp_path / "chart.json"
    path.write_text(json.dumps(chart_json(chart_layout(profile), profile, profile_text("j750"))))
    chart = read_chart(path)
    n, bands = len(chart.patches), len(chart.optics.wavelengths_nm)
    fit = np.linspace(0.0, 2.0, n)
    calibration = Calibration(
        tmp_path / "fitted.toml",
        chart,
        chart.optics,
        np.zeros((n, bands)),
        fit,
        {"folds": 5, "median": 0.75, "p95": 1.5, "max": 2.0},
    )
    line = _one_short_line(repr(calibration))
    assert f"{len(chart.optics.names)} materials, {n} patches" in line
    assert f"median {np.median(fit):.2f}" in line and "cross-validated median 0.75" in line
