"""`shellvox shells`: shell PLYs and report.json, read back with trimesh and json."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh

from shellvox.cli import main


def test_shells_of_a_box_are_exact_inner_boxes(tmp_path, capsys):
    box = trimesh.creation.box(extents=(10.0, 8.0, 6.0))
    box.export(tmp_path / "box.stl")
    out = tmp_path / "out"
    status = main(
        [
            "shells",
            str(tmp_path / "box.stl"),
            "-o",
            str(out),
            "--thickness",
            "0.5,1",
            "--no-baselines",
            "--method",
            "robust",
        ]
    )
    assert status == 0
    assert sorted(p.name for p in out.iterdir()) == ["report.json", "shell_1.ply", "shell_2.ply"]
    for layer, depth in ((1, 0.5), (2, 1.5)):
        shell = trimesh.load(out / f"shell_{layer}.ply", process=False)
        shell.merge_vertices()
        assert shell.is_watertight
        assert shell.is_winding_consistent
        np.testing.assert_allclose(
            shell.bounds,
            [[-5 + depth, -4 + depth, -3 + depth], [5 - depth, 4 - depth, 3 - depth]],
            atol=1e-9,
        )
        expected = (10 - 2 * depth) * (8 - 2 * depth) * (6 - 2 * depth)
        assert abs(shell.volume - expected) < 1e-6
    report = json.loads((out / "report.json").read_text())
    assert report["config"]["thickness_mm"] == [0.5, 1.0]
    assert report["input"]["sha256"]
    assert "shell_1.ply" in capsys.readouterr().out


def test_bad_thickness_is_refused(tmp_path, capsys):
    box = trimesh.creation.box(extents=(10.0, 8.0, 6.0))
    box.export(tmp_path / "box.stl")
    status = main(
        ["shells", str(tmp_path / "box.stl"), "-o", str(tmp_path / "o"), "--thickness", "0.5,-1"]
    )
    err = capsys.readouterr().err
    assert status == 2
    assert "--thickness" in err and "positive" in err
    assert not (tmp_path / "o").exists()


def test_the_field_shells_of_a_box_are_its_inner_boxes(tmp_path):
    box = trimesh.creation.box(extents=(10.0, 8.0, 6.0))
    box.export(tmp_path / "box.stl")
    out = tmp_path / "out"
    argv = ["shells", str(tmp_path / "box.stl"), "-o", str(out), "--thickness", "0.5,1"]
    assert main([*argv, "--no-baselines", "--method", "field", "--shell-step", "0.25"]) == 0
    report = json.loads((out / "report.json").read_text())
    assert report["config"]["method"] == "field"
    assert report["method"]["step_mm"] == 0.25
    for layer, depth in ((1, 0.5), (2, 1.5)):
        shell = trimesh.load(out / f"shell_{layer}.ply", process=False)
        assert shell.is_watertight and shell.is_winding_consistent
        # The grid's nodes lie on the offset planes here: the symbolic tie keeps it closed.
        half = np.array([5.0, 4.0, 3.0]) - depth
        np.testing.assert_allclose(shell.bounds, [-half, half], atol=1e-6)
        assert shell.volume == pytest.approx(np.prod(2 * half), rel=1e-5)
        assert report["layers"][layer - 1]["shell"]["self_intersections"] == 0
        assert report["layers"][layer - 1]["shell"]["nested"]


def test_a_bad_shell_step_is_refused(tmp_path, capsys):
    trimesh.creation.box(extents=(4.0, 4.0, 4.0)).export(tmp_path / "box.stl")
    argv = ["shells", str(tmp_path / "box.stl"), "-o", str(tmp_path / "o"), "--shell-step", "0"]
    assert main(argv) == 2
    assert "--shell-step" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()
