"""One registry of shell methods: every command, the config and the API offer the same ones.

Truths: the argparse parser as the user meets it, the functions' signatures, and the
analytic inner box of a box (field and robust put its inner faces on the offset planes;
the paper's construction is compared with robust in test_offset_analytic.py).
"""

from __future__ import annotations

import argparse
import inspect

import numpy as np
import pytest
import trimesh

import shellvox
from shellvox.cli import parser
from shellvox.config import ShellConfig
from shellvox.errors import InputError
from shellvox.offset import DEFAULT_METHOD, METHODS, method_shells, offset_shells


def _method_option(command: str) -> argparse.Action:
    top = parser()
    sub = next(a for a in top._actions if isinstance(a, argparse._SubParsersAction))
    return next(a for a in sub.choices[command]._actions if "--method" in a.option_strings)


@pytest.mark.parametrize("command", ["shells", "build", "fdm"])
def test_every_command_offers_the_registry_with_its_default(command):
    option = _method_option(command)
    assert tuple(option.choices) == tuple(METHODS)
    assert option.default == DEFAULT_METHOD == "field"


def test_the_api_defaults_to_the_registry_default():
    for function in (shellvox.offset_shells, shellvox.fdm_projects, offset_shells):
        assert inspect.signature(function).parameters["method"].default == DEFAULT_METHOD
    assert shellvox.BuildOptions().shell_method == DEFAULT_METHOD


def test_an_unknown_method_is_refused_everywhere():
    box = trimesh.creation.box((4.0, 4.0, 4.0))
    with pytest.raises(ValueError, match="method"):
        offset_shells(box.vertices, box.faces, [0.5], method="fast")  # type: ignore[arg-type]
    with pytest.raises(InputError, match=r"ShellConfig\(method="):
        ShellConfig(method="fast")  # type: ignore[arg-type]
    assert _method_option("shells").choices is not None
    assert "fast" not in _method_option("shells").choices


@pytest.mark.parametrize("method", [m for m in METHODS if m != "paper"])
def test_the_closed_methods_offset_a_box_to_its_planes(method):
    box = trimesh.creation.box((10.0, 8.0, 6.0))
    made = method_shells(box.vertices, box.faces, [0.5, 1.0], method=method, step_mm=0.25)
    assert made.record["method"] == method
    for shell, depth in zip(made.shells, (0.5, 1.5), strict=True):
        half = np.array([5.0, 4.0, 3.0]) - depth
        # the field's vertices lie on the planes to its patch tolerance (1e-6 mm)
        np.testing.assert_allclose(shell.vertices.max(axis=0), half, atol=1e-6)
        np.testing.assert_allclose(shell.vertices.min(axis=0), -half, atol=1e-6)
        inner = trimesh.Trimesh(shell.vertices, shell.faces)
        assert inner.is_watertight
        assert inner.volume == pytest.approx(float(np.prod(2 * half)), rel=1e-6)


def test_a_method_without_closed_shells_is_refused_where_files_need_them(tmp_path, capsys):
    from shellvox.cli import main

    assert not METHODS["paper"].closed
    box = tmp_path / "box.stl"
    trimesh.creation.box((10.0, 8.0, 6.0)).export(box)
    for command in (["shells", str(box)], ["build", str(box), "--shell-meshes"]):
        status = main([*command, "-o", str(tmp_path / "o"), "--method", "paper"])
        err = capsys.readouterr().err.strip().splitlines()
        assert status == 2 and len(err) == 1, err
        assert "--method" in err[0] and "not closed" in err[0] and "use --method field" in err[0]
        assert not (tmp_path / "o").exists()
