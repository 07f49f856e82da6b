"""Tray files, refusals before any work, and ``--dry-run``.

Truths: the messages name the file, the entry and the models; a refused or dry run
leaves no output folder; a tile's arrays are :func:`shellvox.voxel.slab.compute_slab`'s.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import trimesh

from shellvox.cli import main
from shellvox.errors import InputError
from shellvox.run import stack_slab
from shellvox.tray import load_tray
from shellvox.voxel.geometry import SurfaceIndex
from shellvox.voxel.grid import GridSpec
from shellvox.voxel.slab import StackModel, compute_slab
from shellvox.voxel.tray_slab import TrayError, TrayStack, compute_tray_slab


@pytest.fixture
def box(tmp_path):
    """A 10 x 8 x 6 mm box, uncoloured."""
    path = tmp_path / "box.ply"
    trimesh.creation.box(extents=(10.0, 8.0, 6.0)).export(path)
    return path


def _tray(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "tray.toml"
    path.write_text(text)
    return path


def _refused(argv: list[str], capsys) -> str:
    """Run the CLI, expect exit 2 with one line on stderr; return that line."""
    assert main(argv) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1
    return lines[0]


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("[[model]\nfile = 'a'", ["not valid TOML"]),
        ("name = 'x'", ["unknown top-level key", "[[model]]"]),
        ("[[model]]\nposition = [1, 2]", ["model[1].file", 'file = "model.glb"']),
        ("[[model]]\nfile = 'box.ply'\nposition = [1]", ["model[1].position", "[x, y]"]),
        ("[[model]]\nfile = 'box.ply'\n[[model]]\nfile = 'box.ply'\nscale = -2",
         ["model[2].scale", "positive"]),
        ("[[model]]\nfile = 'box.ply'\nrotation = [0, 90]", ["model[1].rotation", "degrees"]),
        ("[[model]]\nfile = 'box.ply'\nthickness = [0.5, 0]", ["model[1].thickness"]),
        ("[[model]]\nfile = 'box.ply'\nthickness = [0.5]\nthickness_rule = 'r.toml'",
         ["model[1]", "keep one"]),
        ("[[model]]\nfile = 'box.ply'\ncopies = 2\nposition = [0, 0]", ["copies = 2"]),
        ("[[model]]\nfile = 'box.ply'\ncolour = 'red'", ["model[1]", "unknown key", "colour"]),
    ],
)  # fmt: skip
def test_bad_tray_files_name_file_entry_and_fix(tmp_path, text, words):
    path = _tray(tmp_path, text)
    with pytest.raises(InputError) as caught:
        load_tray(path)
    message = str(caught.value)
    assert str(path) in message
    for word in words:
        assert word in message


def test_tray_file_paths_are_relative_to_it(tmp_path, box):
    path = _tray(
        tmp_path,
        "[[model]]\nfile = 'box.ply'\nposition = [1, 2]\nrotation = [0, 0, 90]\n"
        "thickness_rule = 'rule.toml'\n",
    )
    spec = load_tray(path)
    (model,) = spec.models
    assert model.file == box
    assert model.thickness_rule == tmp_path / "rule.toml"
    assert model.position_mm == (1.0, 2.0, 0.0)
    assert model.rotation_deg == (0.0, 0.0, 90.0)


def test_different_layer_counts_are_refused(tmp_path, box, capsys):
    path = _tray(
        tmp_path,
        "[[model]]\nfile = 'box.ply'\nposition = [0, 0]\nthickness = [0.5, 0.5]\n"
        "[[model]]\nfile = 'box.ply'\nposition = [50, 0]\nthickness = [0.3, 0.3, 0.3]\n",
    )
    out = tmp_path / "out"
    line = _refused(["build", "--tray", str(path), "-o", str(out), "--dry-run"], capsys)
    assert "3 layers" in line and "2" in line and "same number of layers" in line
    assert not out.exists()


def test_overlapping_and_outside_positions_are_refused_naming_the_models(tmp_path, box, capsys):
    (tmp_path / "ball.ply").write_bytes(box.read_bytes())
    (tmp_path / "cube.ply").write_bytes(box.read_bytes())
    path = _tray(
        tmp_path,
        "[[model]]\nfile = 'box.ply'\nposition = [0, 0]\n"
        "[[model]]\nfile = 'ball.ply'\nposition = [5, 3]\n"
        "[[model]]\nfile = 'cube.ply'\nposition = [485, 100]\n",
    )
    out = tmp_path / "out"
    line = _refused(["build", "--tray", str(path), "-o", str(out), "--thickness", "0.5"], capsys)
    assert "box.ply and ball.ply are closer than" in line
    assert "cube.ply (at 485 x 100 x 0" in line and "leaves the" in line
    assert "box.ply and cube.ply" not in line
    assert not out.exists()


def test_models_that_do_not_fit_are_refused_by_name(tmp_path, box, capsys):
    out = tmp_path / "out"
    argv = ["build", str(box), "--scale", "10", "--copies", "40", "-o", str(out)]
    line = _refused(argv, capsys)
    # 100 x 80 mm boxes with a 5 mm gap: 4 x 4 on the 490 x 390 mm J750 tray
    assert "holds 16 of the 40 models" in line
    assert "box.ply#17" in line and "box.ply#40" in line and "box.ply#16," not in line
    assert "fewer copies" in line
    assert not out.exists()


def test_dry_run_prints_layout_and_estimate_and_writes_nothing(tmp_path, box, capsys):
    out = tmp_path / "out"
    argv = ["build", str(box), "--copies", "3", "-o", str(out), "--dry-run"]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "tray of 3 model(s), layout auto" in text
    assert "box.ply#3: x" in text
    assert "estimate: grid" in text and "voxels" in text and "on disk" in text
    assert not out.exists()


def test_full_j750_tray_of_spot_dry_run(tmp_path, shared_mesh, capsys):
    spot = shared_mesh("spot/spot_triangulated.obj")
    out = tmp_path / "out"
    argv = ["build", str(spot), "--scale", "60", "--copies", "24", "-o", str(out), "--dry-run"]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "tray of 24 model(s)" in text
    assert "spot_triangulated.obj#24: x" in text
    assert "estimate: grid" in text
    assert not out.exists()


def _ball_model(radius: float, voxel: float) -> tuple[StackModel, GridSpec]:
    ball = trimesh.creation.icosphere(subdivisions=2, radius=radius)
    vertices, faces = np.asarray(ball.vertices), np.asarray(ball.faces, dtype=np.int64)
    model = StackModel(
        surfaces=((vertices, faces),),
        surface=SurfaceIndex.build(vertices, faces),
        colour_at=lambda f, b: np.full((len(f), 4), 200, np.uint8),
        sdf_half_width_mm=2 * voxel,
        depth_mm=np.full((2, len(faces)), 0.4) * np.array([[1.0], [2.0]]),
        layer_rule="distance",
    )
    grid = GridSpec.from_bounds(vertices.min(0), vertices.max(0), (voxel,) * 3, margin_mm=0.5)
    return model, grid


def test_tray_slab_rows_are_each_models_rows():
    big, big_grid = _ball_model(3.0, 0.25)
    small, small_grid = _ball_model(1.5, 0.25)
    offsets = ((0, 0, 0), (5, 2, big_grid.shape_zyx[2] + 3))
    tray = TrayStack((big, small), (big_grid, small_grid), offsets)
    shape = tuple(max(o[i] + g.shape_zyx[i] for o, g in zip(offsets, tray.grids, strict=True))
                  for i in range(3))  # fmt: skip
    grid = GridSpec((0.0, 0.0, 0.0), (0.25,) * 3, shape)
    rows = (3, shape[0] - 2)
    slab = compute_tray_slab(tray, grid, *rows)
    assert stack_slab(tray, grid, None, *rows).slab.layers.tobytes() == slab.layers.tobytes()
    for model, model_grid, (z, y, x) in zip(tray.models, tray.grids, offsets, strict=True):
        low, high = max(rows[0], z), min(rows[1], z + model_grid.shape_zyx[0])
        alone = compute_slab(model, model_grid, low - z, high - z)
        ny, nx = model_grid.shape_zyx[1:]
        tile = (slice(low - rows[0], high - rows[0]), slice(y, y + ny), slice(x, x + nx))
        assert np.array_equal(slab.layers[tile], alone.layers)
        assert np.array_equal(slab.rgba[tile], alone.rgba)
        assert np.array_equal(slab.sdf[tile], alone.sdf)
    assert slab.layer_counts.sum() == slab.layers.size
    assert np.array_equal(np.bincount(slab.layers.ravel(), minlength=4), slab.layer_counts)


def test_overlapping_tiles_are_refused():
    model, grid = _ball_model(1.5, 0.25)
    with pytest.raises(TrayError, match="tiles of models 0 and 1 overlap"):
        TrayStack((model, model), (grid, grid), ((0, 0, 0), (0, 0, grid.shape_zyx[2] - 1)))


def test_rotation_is_extrinsic_xyz_before_placement(tmp_path, box, capsys):
    # the 10 x 8 x 6 box turned 90 degrees about x (10 x 6 x 8), then about z (6 x 10 x 8);
    # intrinsic angles (z first, then x) would give 8 x 6 x 10
    path = _tray(
        tmp_path, "[[model]]\nfile = 'box.ply'\nposition = [20, 30, 1]\nrotation = [90, 0, 90]\n"
    )
    argv = ["build", "--tray", str(path), "-o", str(tmp_path / "out"), "--dry-run"]
    assert main(argv) == 0
    line = next(s for s in capsys.readouterr().out.splitlines() if "box.ply:" in s)
    low = np.array([20.0, 30.0, 1.0])
    high = low + np.array([6.0, 10.0, 8.0])
    ranges = re.findall(r"([xyz]) (-?[\d.]+)\.\.(-?[\d.]+)", line)
    assert [axis for axis, _, _ in ranges] == ["x", "y", "z"]
    numbers = np.array([(float(a), float(b)) for _, a, b in ranges])
    voxel = np.array([0.0423, 0.0847, 0.027])  # snapped to the J750 grid
    assert np.allclose(numbers[:, 0], low, atol=voxel.max())
    assert np.allclose(numbers[:, 1], high, atol=voxel.max())


def test_a_tray_past_the_memory_is_refused_with_its_estimate(tmp_path, box, capsys):
    # 0.5 um voxels: one row of the two boxes' tray grid is about 1e9 voxels, tens of GB
    out = tmp_path / "out"
    argv = ["build", str(box), "--copies", "2", "-o", str(out), "--voxel-size", "5e-4,5e-4,5e-4",
            "--workers", "1"]  # fmt: skip
    line = _refused(argv, capsys)
    assert "--voxel-size" in line and "of memory" in line
    assert "(estimate: grid" in line
    assert not out.exists()
