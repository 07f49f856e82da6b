from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh
from PIL import Image

from pipeline.cli import main


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
    for name, axes in (("xy_mid.png", (0, 1)), ("xz_mid.png", (0, 2)), ("yz_mid.png", (1, 2))):
        _check_ball_section(out / "preview" / name, manifest["grid"], axes)
    with Image.open(out / "preview" / "layer_depth_histogram.png") as image:
        assert len(image.convert("RGB").getcolors(2**16)) > 2  # drawn, not blank


def _check_ball_section(path, grid, axes):
    """A mid-grid section of the ball of radius 2 about the origin (the analytic truth).

    Pictures are at true aspect, the plane's first axis to the right and its second up;
    the 0.3 mm colour layer in the surface colour (200, 30, 30) lies within a voxel
    diagonal of the 2 mm sphere's shell from 1.7 to 2 mm, outside is white.
    """
    origin = np.asarray(grid["origin_mm"], float)
    voxel = np.asarray(grid["voxel_size_mm"], float)
    shape = np.asarray(grid["shape_zyx"])[::-1]  # (x, y, z)
    with Image.open(path) as image:
        pixels = np.asarray(image.convert("RGB"))
    height, width = pixels.shape[:2]
    u, v = axes
    extent = shape * voxel
    assert width / height == pytest.approx(extent[u] / extent[v], rel=0.01)
    cols, rows = np.meshgrid(np.arange(width), np.arange(height))
    point = np.zeros((height, width, 3))
    point[..., u] = origin[u] - voxel[u] / 2 + (cols + 0.5) * extent[u] / width
    point[..., v] = origin[v] - voxel[v] / 2 + extent[v] - (rows + 0.5) * extent[v] / height
    fixed = 3 - u - v
    point[..., fixed] = origin[fixed] + (shape[fixed] // 2) * voxel[fixed]
    radius = np.linalg.norm(point, axis=2)
    slack = float(np.linalg.norm(voxel)) + float(np.max(extent[[u, v]] / (width, height)))
    red = np.all(pixels == (200, 30, 30), axis=2)
    white = np.all(pixels == 255, axis=2)
    assert red.any()
    assert radius[red].min() >= 2.0 - 0.3 - slack and radius[red].max() <= 2.0 + slack
    assert white[radius > 2.0 + slack].all()
    assert not (white | red)[radius < 2.0 - 0.3 - slack].any()


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
