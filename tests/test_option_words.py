"""Options named in each front end's words, checked where they are made (issue 50, 2, 3, 7).

The same bad input gives, from Python, the parameter (``LoadOptions(repair=True)``) and
no command-line flag, and from the command line the flag. Every field of the public
option dataclasses refuses a bad value with an ``InputError`` naming it. Warnings point
at the caller's line, and a library's own prints never reach the terminal.
"""

from __future__ import annotations

import dataclasses
import re
import warnings
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
import trimesh

from shellvox import (
    BuildOptions,
    FdmSettings,
    InputError,
    LoadOptions,
    MaterialSettings,
    RunSettings,
    ShellConfig,
    ShellvoxWarning,
    load_model,
    load_profile,
)
from shellvox.cli import main
from shellvox.errors import OPTIONS, opt, worded

#: A command-line flag in running text ("--scale", "-o DIR").
FLAG = re.compile(r"(^|[\s(])(--[a-z]|-o DIR)")

#: The public option dataclasses (shellvox.__init__.pyi) and their fields.
OPTION_TYPES = (LoadOptions, BuildOptions, MaterialSettings, ShellConfig, RunSettings, FdmSettings)


@pytest.fixture
def open_box(tmp_path: Path) -> Path:
    """A 10 mm box missing one face (open: refused without repair), as a PLY file."""
    box = trimesh.creation.box((10.0, 10.0, 10.0))
    path = tmp_path / "open.ply"
    trimesh.Trimesh(box.vertices, box.faces[1:], process=False).export(path)
    return path


def _cli_error(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    status = main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1, err
    return err[0]


def test_an_open_mesh_is_refused_in_each_front_ends_words(open_box, capsys, tmp_path):
    with pytest.raises(InputError) as caught:
        load_model(open_box)
    message = str(caught.value)
    assert "boundary edges" in message and "LoadOptions(repair=True)" in message, message
    assert not FLAG.search(message), message
    assert caught.value.options == ("repair",)
    line = _cli_error(["thickness", str(open_box), "-o", str(tmp_path / "out")], capsys)
    assert "boundary edges" in line and "pass --repair" in line, line
    assert "LoadOptions" not in line


def test_a_bad_scale_is_named_as_the_parameter_or_the_flag(open_box, capsys):
    with pytest.raises(InputError) as caught:
        LoadOptions(scale=-2.0)
    assert str(caught.value).startswith("LoadOptions(scale=...): got -2.0"), caught.value
    assert not FLAG.search(str(caught.value))
    line = _cli_error(["info", str(open_box), "--scale", "-2"], capsys)
    assert line.startswith("shellvox: error: --scale: got -2.0"), line


def test_a_voxel_size_off_the_printer_grid_with_a_job_format(tmp_path):
    options = BuildOptions(voxel_size_mm=0.1, formats=("gcvf",))
    with pytest.raises(InputError) as caught:
        options.chosen_formats(load_profile("j750"))
    message = str(caught.value)
    assert "BuildOptions(voxel_size_mm=(0.1, 0.1, 0.1))" in message, message
    assert "BuildOptions(formats=...)" in message and not FLAG.search(message), message
    cli = caught.value.words("cli")
    assert "--voxel-size 0.1,0.1,0.1" in cli and cli.startswith("--format:"), cli


def test_the_profiles_named_from_python_are_the_installed_ones():
    with pytest.raises(InputError) as caught:
        load_profile("no-such-printer")
    named = re.search(r"\(see (.+)\)", str(caught.value))
    assert named is not None, caught.value
    folder = Path(named[1])
    assert folder == Path(str(resources.files("shellvox.printer") / "profiles"))
    assert folder.is_absolute() and (folder / "j750.toml").is_file()


def test_every_option_renders_in_both_front_ends():
    for name, option in OPTIONS.items():
        python, cli = worded(opt(name)), worded(opt(name), "cli")
        assert not FLAG.search(python), (name, python)
        if option.cli is None:  # not settable from the command line: its Python spelling
            assert cli == python
        else:
            assert cli == f"{option.cli} {option.cli_meta}".strip(), (name, cli)


#: Fields that take any text or path (a file, a profile name, an address): checked for
#: their type here, for the file's existence where it is read.
TEXT_FIELDS = {"texture", "printer", "thickness_rule", "scheduler", "icc"}


def _bad_values(kind: dataclasses.Field) -> list[object]:
    """Values wrong for the field: of no type it takes, and one of its type out of range."""
    bad: list[object] = [object()] if kind.name in TEXT_FIELDS else [object(), "?"]
    default = kind.default if kind.default is not dataclasses.MISSING else None
    if isinstance(default, bool):
        bad.append(1)
    elif isinstance(default, int | float):
        bad += [-1.5, float("nan"), True]
    elif isinstance(default, tuple):
        bad += [(), (-1.0,) * max(len(default), 1)]
    return bad


@pytest.mark.parametrize(
    ("cls", "field"),
    [(cls, field) for cls in OPTION_TYPES for field in dataclasses.fields(cls)],
    ids=lambda item: getattr(item, "__name__", getattr(item, "name", "")),
)
def test_every_option_field_refuses_a_bad_value_naming_it(cls, field):
    for value in _bad_values(field):
        if field.name == "thickness_mm" and cls is ShellConfig and value == ():
            continue  # empty: the thickness rule sets it per face
        with pytest.raises(InputError) as caught:
            cls(**{field.name: value})
        message = str(caught.value)
        assert f"{field.name}=" in message, (cls.__name__, field.name, value, message)
        assert not FLAG.search(message), message
        assert "--" in caught.value.words("cli") or OPTIONS[caught.value.options[0]].cli is None


def test_the_defaults_are_accepted_and_values_are_normalised():
    for cls in OPTION_TYPES:
        cls()
    assert BuildOptions(voxel_size_mm=0.5).voxel_size_mm == (0.5, 0.5, 0.5)
    assert BuildOptions(voxel_size_mm=[0.1, 0.2, 0.3]).voxel_size_mm == (0.1, 0.2, 0.3)
    assert BuildOptions(voxel_size_mm=np.float64(0.25)).voxel_size_mm == (0.25,) * 3
    assert LoadOptions(colour=(1, 2, 3)).colour == (1, 2, 3, 255)
    assert LoadOptions(texture="a.png").texture == Path("a.png")
    assert ShellConfig(thickness_mm=[0.5, 0.25]).thickness_mm == (0.5, 0.25)


@pytest.mark.parametrize(
    ("make", "needles"),
    [
        (
            lambda: LoadOptions(units="meter"),
            ["LoadOptions(units=...)", "'meter'", "'m'", "'inch'"],
        ),
        (lambda: BuildOptions(voxel_size_mm=(0.1, 0.2)), ["voxel_size_mm=", "3 positive"]),
        (lambda: BuildOptions(compression_level=10), ["compression_level=", "at most 9"]),
        (lambda: BuildOptions(workers=1.5), ["workers=", "an integer"]),
        (lambda: BuildOptions(formats=("tif",)), ["formats=", "'tiff'", "'zarr'"]),
        (lambda: MaterialSettings(halftone="dither"), ["halftone=", "'blue-noise'"]),
        (lambda: ShellConfig(method="fast"), ["method=", "'field'", "'robust'"]),
        (lambda: RunSettings(checkpoint="yes"), ["checkpoint=", "True, False or None"]),
    ],
)
def test_a_bad_value_names_the_allowed_ones(make, needles):
    with pytest.raises(InputError) as caught:
        make()
    for needle in needles:
        assert needle in str(caught.value), caught.value


def test_a_warning_points_at_the_callers_line(tmp_path, open_box):
    inside_out = tmp_path / "inside-out.ply"
    box = trimesh.creation.box((10.0, 10.0, 10.0))
    trimesh.Trimesh(box.vertices, box.faces[:, ::-1], process=False).export(inside_out)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_model(inside_out)
        line = _line_before()
        load_model(open_box, LoadOptions(repair=True))  # warned three calls deeper
        repair_line = _line_before()
    ours = [w for w in caught if issubclass(w.category, ShellvoxWarning)]
    assert [Path(w.filename) for w in ours] == [Path(__file__)] * 2, ours
    assert [w.lineno for w in ours] == [line, repair_line]
    assert "flipped all faces" in str(ours[0].message)
    assert "LoadOptions(repair=True) closed" in str(ours[1].message)


def _line_before() -> int:
    """Return the line number just before the caller's line."""
    import inspect

    frame = inspect.currentframe()
    assert frame is not None and frame.f_back is not None
    return frame.f_back.f_lineno - 1


def test_repair_prints_nothing_raw(shared_mesh, capfd):
    # The teapot is open with a separate lid: trimesh cannot close it, pymeshfix runs and
    # says "MeshFix could not fix everything" on its own.
    teapot = shared_mesh("teapot/teapot.obj")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = load_model(teapot, LoadOptions(repair=True))
    out, err = capfd.readouterr()
    assert (out, err) == ("", "")
    assert len(mesh.faces) > 0
    assert any("closed" in str(w.message) for w in caught)
    status = main(["info", str(teapot), "--repair"])
    out, err = capfd.readouterr()
    assert status == 0 and "MeshFix" not in out + err
    assert err.startswith("shellvox: warning: ") and "--repair closed" in err, err
