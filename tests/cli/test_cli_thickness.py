"""`shellvox thickness` and the thickness rule in `shellvox shells`: files read back with
Pillow, trimesh and json."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh
from builders import j750_layer_model
from matplotlib import colormaps
from matplotlib.colors import Normalize
from PIL import Image

from shellvox.cli import main
from shellvox.loading import load_model
from shellvox.report import COLOUR_MAP
from shellvox.thickness import DEFAULT_RULE, face_thickness

#: A yellow of transparent colourant settles deep (about 2.2 mm) under the J750's optics;
#: black settles at once (the 0.3 mm minimum).
YELLOW = [230, 200, 20, 255]


@pytest.fixture
def two_colour_box(tmp_path):
    """A 20 mm cube PLY: the top (+z) faces yellow, every other face black."""
    box = trimesh.creation.box((20.0, 20.0, 20.0))
    top = box.face_normals[:, 2] > 0.5
    box.visual.face_colors = np.where(top[:, None], YELLOW, [0, 0, 0, 255])
    path = tmp_path / "box.ply"
    box.export(path)
    return path


def test_thickness_writes_a_readable_picture_ply_and_summary(tmp_path, two_colour_box, capsys):
    out = tmp_path / "out"
    assert main(["thickness", str(two_colour_box), "-o", str(out)]) == 0
    table = capsys.readouterr().out
    for word in ("upper", "side", "lower", "all", "L* 80-100", "backing"):
        assert word in table

    mesh = load_model(two_colour_box)
    expected = face_thickness(mesh, DEFAULT_RULE, model=j750_layer_model())

    ply = trimesh.load(out / "thickness.ply", process=False)
    assert ply.vertices.dtype == np.float64
    np.testing.assert_array_equal(ply.vertices, mesh.vertices)  # float64, exactly
    np.testing.assert_array_equal(ply.faces, mesh.faces)
    face_data = ply.metadata["_ply_raw"]["face"]["data"]
    np.testing.assert_array_equal(face_data["thickness"], expected.colour_layer_mm)
    np.testing.assert_array_equal(face_data["thickness_2"], 0.5)
    assert ply.is_watertight

    summary = json.loads((out / "thickness.json").read_text())
    assert summary["source"] == "default rule"
    assert summary["n_faces"] == 12
    yellow_group = summary["colour_layer"]["by_lightness"][-1]
    black_group = summary["colour_layer"]["by_lightness"][0]
    assert yellow_group["faces"] == 2 and black_group["faces"] == 10
    assert yellow_group["min_mm"] > black_group["max_mm"]

    picture = Image.open(out / "thickness.png")
    picture.load()
    assert picture.format == "PNG" and picture.size == (1200, 1000)
    pixels = np.asarray(picture.convert("RGB")).reshape(-1, 3).astype(int)
    layer = DEFAULT_RULE.colour_layer
    norm = Normalize(layer.min_mm, layer.max_mm)
    # Faces are drawn flat in the colour map's colour of their thickness: the yellow top's
    # and a black side's colours are in the picture.
    top = int(np.argmax(expected.colour_layer_mm))
    side = int(np.argmin(expected.colour_layer_mm))
    for face in (top, side):
        rgb = np.rint(
            np.asarray(colormaps[COLOUR_MAP](norm(expected.colour_layer_mm[face]))[:3]) * 255
        )
        assert np.count_nonzero(np.abs(pixels - rgb).max(axis=1) <= 2) > 500


def test_thickness_with_a_rule_file_and_max_edge(tmp_path, two_colour_box, capsys):
    rule = tmp_path / "rule.toml"
    rule.write_text("[colour_layer]\nmin_mm = 0.2\nmax_mm = 2.0\n[split]\nmin_spread_de00 = 0\n")
    out = tmp_path / "out"
    status = main(
        [
            "thickness",
            str(two_colour_box),
            "--thickness-rule",
            str(rule),
            "--max-edge",
            "4",
            "-o",
            str(out),
            "--json",
        ]
    )
    assert status == 0
    summary = json.loads(capsys.readouterr().out.split("\n" + str(out))[0])
    assert summary["source"] == str(rule)
    assert summary["rule"]["colour_layer"]["max_mm"] == 2.0
    ply = trimesh.load(out / "thickness.ply", process=False)
    assert len(ply.faces) == summary["n_faces"] > 12  # face colours: split only by spread 0
    corners = ply.triangles
    assert np.linalg.norm(corners - np.roll(corners, -1, axis=1), axis=2).max() <= 4.0
    assert ply.is_watertight and ply.is_winding_consistent


def test_a_bad_rule_file_is_one_line_and_exit_2(tmp_path, two_colour_box, capsys):
    rule = tmp_path / "rule.toml"
    rule.write_text("[colour_layer]\nmax_mm = -1\n")
    out = tmp_path / "out"
    status = main(["thickness", str(two_colour_box), "--thickness-rule", str(rule), "-o", str(out)])
    err = capsys.readouterr().err
    assert status == 2
    assert err.count("\n") == 1
    assert str(rule) in err and "colour_layer.max_mm" in err
    assert not out.exists()


def test_shells_uses_the_default_rule_without_thickness(tmp_path, capsys):
    """A yellow cube's colour shell lies deeper than a black cube's, as the rule says."""
    volumes = {}
    for name, rgba in (("yellow", YELLOW), ("black", [0, 0, 0, 255])):
        box = trimesh.creation.box((20.0, 20.0, 20.0))
        box.visual.face_colors = np.tile(rgba, (12, 1))
        box.export(tmp_path / f"{name}.ply")
        out = tmp_path / name
        assert (
            main(
                # --method robust: exact inner cubes (the field shells' edges are chamfered)
                [
                    "shells",
                    str(tmp_path / f"{name}.ply"),
                    "-o",
                    str(out),
                    "--no-baselines",
                    "--method",
                    "robust",
                ]
            )
            == 0
        )
        report = json.loads((out / "report.json").read_text())
        assert report["config"]["thickness_mm"] == []
        assert report["thickness"]["source"] == "default rule"
        shell = trimesh.load(out / "shell_1.ply", process=False)
        shell.merge_vertices()
        assert shell.is_watertight
        volumes[name] = shell.volume
        mesh = load_model(tmp_path / f"{name}.ply")
        expected = face_thickness(mesh, model=j750_layer_model()).colour_layer_mm
        layer = report["layers"][0]["depth_mm"]
        assert layer["min"] == pytest.approx(expected.min())
        assert layer["max"] == pytest.approx(expected.max())
        ply = trimesh.load(out / "thickness.ply", process=False)
        face_data = ply.metadata["_ply_raw"]["face"]["data"]
        np.testing.assert_array_equal(face_data["thickness"], expected)
    # Yellow: about 2.2 mm deep, black: 0.3 mm; the cube's inner shell is smaller.
    assert volumes["yellow"] < (20 - 2 * 2.0) ** 3 < (20 - 2 * 0.3) ** 3 <= volumes["black"] + 1e-6


@pytest.mark.parametrize("option", [["--thickness-rule", "r.toml"], ["--max-edge", "1"]])
def test_shells_refuses_a_rule_option_with_constant_thickness(
    tmp_path, two_colour_box, capsys, option
):
    status = main(
        [
            "shells",
            str(two_colour_box),
            "-o",
            str(tmp_path / "o"),
            "--thickness",
            "0.5,0.5",
            *option,
        ]
    )
    err = capsys.readouterr().err
    assert status == 2
    assert option[0] in err and "--thickness" in err
    assert not (tmp_path / "o").exists()
