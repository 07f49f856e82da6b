from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh
from PIL import Image
from scipy import ndimage

from shellvox.cli import main
from shellvox.offset.field.step import BYTES_PER_FIELD_TRIANGLE, SECONDS_PER_FIELD_TRIANGLE


@pytest.fixture
def model(tmp_path):
    path = tmp_path / "ball.obj"
    trimesh.creation.icosphere(subdivisions=2, radius=2.0).export(path)
    return path


def test_build_then_inspect(tmp_path, model, capsys):
    out = tmp_path / "out"
    status = main(
        [
            "build",
            str(model),
            "-o",
            str(out),
            "--voxel-size",
            "0.1,0.12,0.08",
            "--thickness",
            "0.3,0.4",
            "--colour",
            "200,30,30",
            "--no-progress",
        ]
    )
    assert status == 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["grid"]["voxel_size_mm"] == [0.1, 0.12, 0.08]
    # the printer's materials are used on any grid, its job only on its own grid
    assert manifest["config"]["printer"] == "j750"
    assert "materials.tif" in manifest["files"]
    assert "job.gcvf" not in manifest["files"]
    assert "layers.tif" in capsys.readouterr().out
    assert main(["inspect", str(out)]) == 0
    text = capsys.readouterr().out
    assert "layer 1 colour_1" in text
    names = ("section_xy.png", "section_xz.png", "section_yz.png", "outer_views.png")
    for name in (*names, "layer_depth_histogram.png"):
        with Image.open(out / "preview" / name) as image:
            assert image.size[0] > 10
    # sections at true aspect: a ball's section is a disc (on anisotropic voxels); its
    # colour ring in the whole section (the leftmost red component; the zoom is right of it)
    for name in names[:3]:
        with Image.open(out / "preview" / name) as image:
            pixels = np.asarray(image.convert("RGB")).astype(int)
        red = (np.abs(pixels - (200, 30, 30)) <= 12).all(axis=2)
        labels, _ = ndimage.label(red, structure=np.ones((3, 3)))
        rows, cols = np.nonzero(red)
        leftmost = labels[rows[np.argmin(cols)], cols.min()]
        rows, cols = np.nonzero(labels == leftmost)
        assert (np.ptp(cols) + 1) / (np.ptp(rows) + 1) == pytest.approx(1.0, abs=0.05), name


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--voxel-size", "1,0,1"], "--voxel-size"),
        (["--thickness", "0.5,-1"], "--thickness"),
        (["--colour-layers", "4"], "--colour-layers"),
    ],
)
def test_bad_options_exit_2(tmp_path, model, capsys, extra, message):
    assert main(["build", str(model), "-o", str(tmp_path / "o"), *extra]) == 2
    assert message in capsys.readouterr().err


def test_inspect_refuses_unfinished(tmp_path, capsys):
    assert main(["inspect", str(tmp_path)]) == 2
    assert "manifest.json" in capsys.readouterr().err


def test_shell_meshes_only_when_asked_and_estimated(tmp_path, model, capsys):
    common = ["--voxel-size", "0.2,0.2,0.15", "--thickness", "0.3,0.4", "--colour", "200,30,30"]
    out = tmp_path / "plain"
    assert main(["build", str(model), "-o", str(out), *common, "--no-progress"]) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert not any(name.startswith("shells/") for name in manifest["files"])
    assert manifest["estimate"]["shell_seconds"] == 0
    assert "shell meshes" not in capsys.readouterr().err

    out = tmp_path / "shells"
    argv = ["build", str(model), "-o", str(out), *common, "--shell-meshes", "--progress"]
    assert main(argv) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert {"shells/shell_1.ply", "shells/shell_2.ply"} <= set(manifest["files"])
    # the estimate counts the triangles the field method (the default) marches, within the
    # estimate's factor of two, and their memory is part of the build's
    assert manifest["config"]["shell_method"] == "field"
    estimate = manifest["estimate"]
    triangles = estimate["shell_seconds"] / SECONDS_PER_FIELD_TRIANGLE
    marched = sum(manifest["shell_meshes"]["marched_faces"])
    assert 0.5 < triangles / marched < 2.0
    assert estimate["shell_memory_bytes"] == pytest.approx(triangles * BYTES_PER_FIELD_TRIANGLE)
    assert estimate["memory_bytes"] > estimate["shell_memory_bytes"]
    err = capsys.readouterr().err
    assert "for the shell meshes" in err  # the up-front estimate line
    assert "shell meshes:" in err  # the progress bar


def test_shell_meshes_past_the_memory_are_refused_naming_them(tmp_path, model, capsys, monkeypatch):
    # an 80 mm ball: its two field shells march about 36 M triangles (some 11 GB), the
    # voxels at 0.2 mm far less; with 4 GiB available the shells are what does not fit
    monkeypatch.setattr("shellvox.stack._estimate.available_memory_bytes", lambda: 4 << 30)
    out = tmp_path / "out"
    argv = ["build", str(model), "-o", str(out), "--scale", "40", "--shell-meshes"]
    argv += ["--voxel-size", "0.2,0.2,0.15", "--colour", "200,30,30", "--no-progress"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "--shell-meshes:" in err and "the shell meshes" in err and "leave out" in err
    assert not out.exists()
