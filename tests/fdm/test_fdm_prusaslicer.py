"""The PrusaSlicer project, sliced by the real PrusaSlicer 2.5 and read back as G-code."""

from __future__ import annotations

import json

import numpy as np
import pytest
from fdm_gcode import read_extrusion
from fdm_slicer import BOX_FILAMENTS, coloured_box, slice_with_prusa

from shellvox.cli import main
from shellvox.fdm import FdmSettings, make_project, parse_filaments, write_projects
from shellvox.fdm._prusa import PER_FILAMENT

SKIN_MM = 1.2


@pytest.fixture(scope="module")
def box_gcode(tmp_path_factory):
    folder = tmp_path_factory.mktemp("box")
    mesh = coloured_box()
    project = make_project(
        mesh, np.full(mesh.n_faces, SKIN_MM), parse_filaments(BOX_FILAMENTS), name="box"
    )
    (path,) = write_projects(folder, "box", project, ["prusa"])
    slice_with_prusa(path, folder / "box.gcode")
    centre = project.placement_mm[:2]
    return read_extrusion(folder / "box.gcode"), centre


def test_box_skin_and_core_filaments_at_mid_height(box_gcode, capsys):
    ex, centre = box_gcode
    z = min(set(ex.z.tolist()), key=lambda q: abs(q - 5.0))
    here = ex.z == z
    p = ex.xy[here] - centre
    inside = (np.abs(p) < 10.5).all(axis=1)  # the object, not the wipe tower
    p, tool, e = p[inside], ex.tool[here][inside], ex.e[here][inside]
    # distance to the +x, -x, +y, -y side; their filaments are T1..T4
    distance = np.stack([10 - p[:, 0], 10 + p[:, 0], 10 - p[:, 1], 10 + p[:, 1]], axis=1)
    side, depth = distance.argmin(axis=1), distance.min(axis=1)
    half_line = 0.45 / 2  # the lines at the skin's inner edge are on both sides of it
    skin, core = depth < SKIN_MM - half_line, depth > SKIN_MM + half_line
    skin_share = e[skin][tool[skin] == side[skin] + 1].sum() / e[skin].sum()
    core_share = e[core][tool[core] == 0].sum() / e[core].sum()
    with capsys.disabled():
        print(f"\nbox at z {z}: skin {skin_share:.1%} nearest side, core {core_share:.1%} T0")
    assert skin_share >= 0.95
    assert core_share >= 0.95


def test_box_every_side_filament_is_used(box_gcode):
    ex, _ = box_gcode
    assert set(np.unique(ex.tool).tolist()) == {0, 1, 2, 3, 4}


@pytest.mark.slow
@pytest.mark.parametrize(
    ("model", "sizing"),
    [
        ("default", ("--scale", "1")),
        ("spot/spot_triangulated.obj", ("--scale", "40")),
        ("duck/Duck.glb", ("--size", "50")),  # 1.65 m long in its file (glTF: metres)
    ],
)
def test_real_models_slice(shared_mesh, tmp_path, capsys, model, sizing):
    path = "data/colour_target/colour_target.obj" if model == "default" else str(shared_mesh(model))
    out = tmp_path / "out"
    status = main(
        [
            "fdm",
            path,
            "-o",
            str(out),
            *sizing,
            "--thickness",
            "1.2",
            "--filaments",
            "#FFFFFF,#000000,#FF0000,#0000FF,#FFD000,#00A000",
            "--slicer",
            "prusa",
        ]
    )
    assert status == 0
    (project,) = out.glob("*_prusa.3mf")
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["shell_method"] == "field"  # the default of every command
    assert manifest["files"] == [project.name]
    slice_with_prusa(project, tmp_path / "model.gcode")
    ex = read_extrusion(tmp_path / "model.gcode")  # fails at a move off the bed
    # PrusaSlicer took one value per filament of every per-filament option (its footer)
    footer = dict(
        line[2:].split(" = ", 1)
        for line in (tmp_path / "model.gcode").read_text().splitlines()
        if line.startswith("; ") and " = " in line
    )
    for key in PER_FILAMENT:
        assert len(footer[key].split(",")) == 6, (key, footer[key])
    changes = np.array(list(ex.tool_changes.values()))
    with capsys.disabled():
        print(
            f"\n{model}: {len(changes)} layers, tools {sorted(set(ex.tool.tolist()))}, "
            f"tool changes per layer median {np.median(changes):.0f}, max {changes.max()}"
        )
    assert len(set(ex.tool.tolist())) >= 2


def test_settings_reach_the_gcode(tmp_path):
    mesh = coloured_box((10.0, 10.0, 4.0))
    settings = FdmSettings(layer_height_mm=0.15, nozzle_mm=0.4)
    project = make_project(
        mesh, np.full(mesh.n_faces, 1.0), parse_filaments(BOX_FILAMENTS), settings=settings
    )
    (path,) = write_projects(tmp_path, "small", project, ["prusa"])
    slice_with_prusa(path, tmp_path / "small.gcode")
    text = (tmp_path / "small.gcode").read_text()
    assert "; extruder_colour = #FFFFFF;#FF0000;#00FF00;#0000FF;#FFFF00" in text
    assert "; layer_height = 0.15" in text


def test_box_skin_depth_per_face(tmp_path, capsys):
    # +x side 2.0 mm deep, the others 1.2 mm: PrusaSlicer prints each side's own depth
    mesh = coloured_box()
    deep = mesh.vertices[mesh.faces].mean(axis=1)[:, 0] > 9.9
    depth = np.where(deep, 2.0, SKIN_MM)
    project = make_project(mesh, depth, parse_filaments(BOX_FILAMENTS), name="box")
    (path,) = write_projects(tmp_path, "box", project, ["prusa"])
    slice_with_prusa(path, tmp_path / "box.gcode")
    ex = read_extrusion(tmp_path / "box.gcode")
    z = min(set(ex.z.tolist()), key=lambda q: abs(q - 5.0))
    p = ex.xy[ex.z == z] - project.placement_mm[:2]
    tool, e = ex.tool[ex.z == z], ex.e[ex.z == z]
    middle = (np.abs(p[:, 1]) < 6.0) & (np.abs(p[:, 0]) < 10.5)  # away from the corners
    half_line = 0.45 / 2
    shares = {}
    for name, distance, skin_mm, filament in (
        ("+x", 10 - p[:, 0], 2.0, 1),
        ("-x", 10 + p[:, 0], SKIN_MM, 2),
    ):
        skin = middle & (distance < skin_mm - half_line)
        core = middle & (distance > skin_mm + half_line) & (distance < 5.0)
        shares[name] = (
            e[skin][tool[skin] == filament].sum() / e[skin].sum(),
            e[core][tool[core] == 0].sum() / e[core].sum(),
        )
    with capsys.disabled():
        print(f"\nbox, +x 2.0 mm / -x 1.2 mm: (skin, core) shares {shares}")
    for skin_share, core_share in shares.values():
        assert skin_share >= 0.95 and core_share >= 0.95
