"""Units and axes by format, ``--size`` and ``--up``.

Truths independent of the loader: trimesh's own reading of the shared glTF files (metres,
+Y up) turned by Blender's import convention, scipy's rotations, and sizes computed by
hand from the files written here.
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
import trimesh
from conftest import shared_path
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from shellvox import BuildOptions, plan_tray_build
from shellvox.cli import main, parser
from shellvox.cli.loadargs import load_options
from shellvox.config import UP_AXES, LoadOptions
from shellvox.errors import InputError, ShellvoxWarning
from shellvox.loading import PLAUSIBLE_MM, TURNS, load_model
from shellvox.tray import load_tray

# A closed, outward tetrahedron (mm) with sides of different lengths: 2 x 3 x 4.
TET = np.array([[0, 0, 0], [2, 0, 0], [0, 3, 0], [0, 0, 4]], dtype=np.float64)
TET_FACES = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])

#: Each up axis and the scipy rotation that turns it to +Z (a turn about a fixed axis).
SCIPY_TURNS = {
    "z": Rotation.identity(),
    "y": Rotation.from_euler("x", 90, degrees=True),  # Blender: (x, y, z) -> (x, -z, y)
    "x": Rotation.from_euler("y", -90, degrees=True),
    "-z": Rotation.from_euler("x", 180, degrees=True),
    "-y": Rotation.from_euler("x", -90, degrees=True),
    "-x": Rotation.from_euler("y", 90, degrees=True),
}


def _obj(path, vertices, faces=TET_FACES):
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")
    return path


def _signed_volume(mesh) -> float:
    a, b, c = (mesh.vertices[mesh.faces[:, k]] for k in range(3))
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6)


def _quiet_load(path, options=None):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return load_model(path, options)


@pytest.mark.parametrize(
    ("relative", "size_mm"),
    [
        ("box-textured/BoxTextured.glb", [1000.0, 1000.0, 1000.0]),
        ("duck/Duck.glb", None),
    ],
)
def test_shared_gltf_is_read_in_metres_with_z_up(relative, size_mm):
    path = shared_path(relative)
    scene = trimesh.load(path)  # metres, +Y up, node transforms applied by dump
    metres = np.concatenate([g.vertices for g in scene.dump()])
    x, y, z = metres.T
    expected = np.column_stack([x, -z, y]) * 1000.0  # Blender's import, in mm
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = load_model(path)
    np.testing.assert_allclose(mesh.vertices.min(0), expected.min(0), atol=1e-6)
    np.testing.assert_allclose(mesh.vertices.max(0), expected.max(0), atol=1e-6)
    if size_mm is not None:
        np.testing.assert_allclose(np.ptp(mesh.vertices, axis=0), size_mm, atol=1e-6)
    # every vertex shellvox keeps is one of trimesh's, turned and in mm
    distance, _ = cKDTree(expected).query(mesh.vertices)
    assert distance.max() < 1e-6
    assert _signed_volume(mesh) > 0  # a rotation keeps the faces outward
    assert mesh.loaded["unit"] == "m" and mesh.loaded["up"] == "y"
    longest = float(np.ptp(expected, axis=0).max())
    implausible = not PLAUSIBLE_MM[0] <= longest <= PLAUSIBLE_MM[1]
    said = [str(w.message) for w in caught if issubclass(w.category, ShellvoxWarning)]
    assert len(said) == int(implausible), said  # the duck is 1.65 m long: said in one line
    if implausible:
        assert "LoadOptions(size_mm=50)" in said[0] and "\n" not in said[0]


def test_box_volume_in_cubic_millimetres():
    mesh = _quiet_load(shared_path("box-textured/BoxTextured.glb"))
    assert _signed_volume(mesh) == pytest.approx(1e9, rel=1e-9)  # a 1 m cube


def test_duck_scaled_to_fit_has_its_longest_side_exactly():
    path = shared_path("duck/Duck.glb")
    mesh = _quiet_load(path, LoadOptions(size_mm=50))
    size = np.ptp(mesh.vertices, axis=0)
    assert size.max() == pytest.approx(50.0, rel=1e-12)
    x, y, z = np.ptp(np.concatenate([g.vertices for g in trimesh.load(path).dump()]), axis=0)
    np.testing.assert_allclose(size, np.array([x, z, y]) * 50 / max(x, y, z), rtol=1e-9)
    assert mesh.loaded["size_mm"] == 50 and mesh.loaded["mm_per_file_unit"] == pytest.approx(
        50 / max(x, y, z)
    )


@pytest.mark.parametrize("up", UP_AXES)
def test_every_up_axis_is_a_proper_rotation_turning_that_axis_to_z(tmp_path, up):
    axis, sign = TURNS[up]
    matrix = np.zeros((3, 3))
    matrix[np.arange(3), list(axis)] = sign  # new[i] = sign[i] * old[axis[i]]
    assert np.linalg.det(matrix) == pytest.approx(1.0)
    named = np.zeros(3)
    named["xyz".index(up[-1])] = -1.0 if up.startswith("-") else 1.0
    np.testing.assert_allclose(matrix @ named, [0, 0, 1])
    np.testing.assert_allclose(matrix, SCIPY_TURNS[up].as_matrix(), atol=1e-12)
    mesh = _quiet_load(_obj(tmp_path / "t.obj", TET * 10), LoadOptions(up=up))
    expected = SCIPY_TURNS[up].apply(TET * 10)
    distance, _ = cKDTree(expected).query(mesh.vertices)
    assert distance.max() < 1e-9
    assert _signed_volume(mesh) == pytest.approx(2 * 3 * 4 * 1000 / 6)  # outward, same size
    assert mesh.loaded["up"] == up and mesh.loaded["up_from"] == "option"


def test_up_z_keeps_a_gltf_as_written(tmp_path):
    path = shared_path("box-textured/BoxTextured.glb")
    turned = _quiet_load(path)
    kept = _quiet_load(path, LoadOptions(up="z"))
    np.testing.assert_allclose(
        np.sort(kept.vertices, axis=0), np.sort(turned.vertices[:, [0, 2, 1]], axis=0), atol=1e-9
    )


def test_size_scales_uniformly_after_units(tmp_path):
    path = _obj(tmp_path / "t.obj", TET)
    for options in (LoadOptions(size_mm=50), LoadOptions(size_mm=50, units="inch")):
        mesh = _quiet_load(path, options)
        np.testing.assert_allclose(np.ptp(mesh.vertices, axis=0), [25.0, 37.5, 50.0])


@pytest.mark.parametrize(("side_mm", "warned"), [(0.5, True), (2000.0, True), (50.0, False)])
def test_implausible_size_warns_in_one_line(tmp_path, side_mm, warned):
    path = _obj(tmp_path / "t.obj", TET * side_mm / 4)  # longest side side_mm
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_model(path)
    said = [w.message for w in caught if issubclass(w.category, ShellvoxWarning)]
    assert len(said) == int(warned)
    if warned:
        cli = said[0].words("cli")
        assert "--units" in cli and "--size 50" in cli and "\n" not in cli
        assert f"{side_mm:.3g} mm" in cli and str(path) in cli
        _quiet_load(path, LoadOptions(size_mm=50))  # the fix it names: no warning


def test_implausible_gltf_names_size_not_units(tmp_path):
    path = shared_path("duck/Duck.glb")
    with pytest.warns(ShellvoxWarning) as caught:
        load_model(path)
    cli = caught[0].message.words("cli")
    assert "--size 50" in cli and "--units" not in cli and "GLB" in cli


@pytest.mark.parametrize(
    ("options", "named"),
    [
        ({"size_mm": 0}, "LoadOptions(size_mm=...)"),
        ({"size_mm": -5.0}, "LoadOptions(size_mm=...)"),
        ({"size_mm": "50"}, "LoadOptions(size_mm=...)"),
        ({"size_mm": float("nan")}, "LoadOptions(size_mm=...)"),
        ({"size_mm": 50, "scale": 2.0}, "LoadOptions(scale=...)"),
        ({"up": "w"}, "LoadOptions(up=...)"),
        ({"up": "Y"}, "LoadOptions(up=...)"),
    ],
)
def test_bad_size_and_up_are_refused_naming_the_option(options, named):
    with pytest.raises(InputError) as caught:
        LoadOptions(**options)
    assert named in str(caught.value) and "\n" not in str(caught.value)


@pytest.mark.parametrize(
    "command",
    [["info"], ["build", "-o", "o"], ["shells", "-o", "o"], ["thickness"],
     ["fdm", "-o", "o", "--filaments", "#FFFFFF,#000000"]],
)  # fmt: skip
def test_every_command_takes_size_and_up(command):
    args = parser().parse_args([*command, "m.obj", "--size", "30", "--up=-y"])
    assert load_options(args) == LoadOptions(size_mm=30.0, up="-y")


def test_info_size_and_up_from_the_command_line(tmp_path, capsys):
    path = _obj(tmp_path / "t.obj", TET)
    assert main(["info", "--json", str(path), "--size", "60", "--up", "x"]) == 0
    summary = json.loads(capsys.readouterr().out)
    # x up: the 2 mm side stands up, the 4 mm side lies along x (scaled 15x)
    assert summary["size_mm"] == pytest.approx([60.0, 45.0, 30.0])


def test_size_with_scale_is_refused_on_the_command_line(tmp_path, capsys):
    path = _obj(tmp_path / "t.obj", TET)
    assert main(["info", str(path), "--size", "60", "--scale", "2"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--size" in err[0] and "--scale 2.0" in err[0]


def test_build_with_size_records_it_in_the_manifest(tmp_path):
    path = _obj(tmp_path / "t.obj", TET)
    out = tmp_path / "out"
    argv = ["build", str(path), "-o", str(out), "--size", "12", "--voxel-size", "0.3",
            "--thickness", "0.6,0.6", "--format", "tiff", "--no-materials", "--no-progress",
            "--report-samples", "0"]  # fmt: skip
    assert main(argv) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    loaded = manifest["input"]["loaded"]
    assert loaded["size_mm"] == 12 and loaded["up"] == "z" and loaded["unit"] == "mm"
    assert loaded["mm_per_file_unit"] == pytest.approx(3.0)
    grid = manifest["grid"]
    extent = np.array(grid["shape_zyx"][::-1]) * np.array(grid["voxel_size_mm"])
    # the grid holds the 6 x 9 x 12 mm model and its margins, no more than a few voxels
    assert np.all(extent >= [6, 9, 12]) and np.all(extent <= np.array([6, 9, 12]) + 3)


def test_a_tray_model_takes_size_instead_of_scale(tmp_path):
    _obj(tmp_path / "a.obj", TET / 8)  # 0.5 mm long: sized by the tray, so no warning
    tray = tmp_path / "tray.toml"
    tray.write_text('[[model]]\nfile = "a.obj"\nsize = 40\n')
    assert load_tray(tray).models[0].size_mm == 40.0
    options = BuildOptions(voxel_size_mm=0.5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        plan = plan_tray_build(tray, tmp_path / "out", options, layout="auto").plan
    np.testing.assert_allclose(np.ptp(plan.parts[0].mesh.vertices, axis=0), [20, 30, 40])
    assert plan.manifest(np.array([0, 4]))["models"][0]["size_mm"] == 40.0
    tray.write_text('[[model]]\nfile = "a.obj"\nsize = 40\nscale = 2\n')
    with pytest.raises(InputError, match="both scale and size"):
        load_tray(tray)
    tray.write_text('[[model]]\nfile = "a.obj"\nsize = -1\n')
    with pytest.raises(InputError, match=r"model\[1\]\.size"):
        load_tray(tray)
