"""The command line starts light: its parser and every ``--help`` import no heavy library.

How long the start takes is measured by ``benchmarks/bench_cli_start.py``, not here; this
checks what makes it fast (nothing heavy imported before a command runs) and that the
names the parser offers without the libraries are the registries' own.
"""

from __future__ import annotations

import json
import subprocess
import sys
from typing import get_args

import pytest

from shellvox.cli import choices, parser

#: Libraries that take seconds to import: none of them before a command runs.
HEAVY = ("numba", "matplotlib", "colour", "scipy", "skimage", "trimesh")

#: Builds the parser and every command's help, then lists the heavy modules imported.
PARSE_AND_HELP = """
import argparse, json, sys
import shellvox.cli

top = shellvox.cli.parser()
helps = [top.format_help()]
for action in top._actions:
    if isinstance(action, argparse._SubParsersAction):
        helps += [command.format_help() for command in action.choices.values()]
heavy = sorted(set(name.split(".")[0] for name in sys.modules) & set({heavy!r}))
print(json.dumps({{"helps": len(helps), "heavy": heavy}}))
"""


def test_the_parser_and_every_help_import_no_heavy_library():
    source = PARSE_AND_HELP.format(heavy=HEAVY)
    done = subprocess.run([sys.executable, "-c", source], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    found = json.loads(done.stdout)
    assert found["heavy"] == []
    commands = next(a for a in parser()._actions if a.dest == "command").choices
    assert found["helps"] == 1 + len(commands) and len(commands) >= 9


@pytest.mark.parametrize("argv", [["--version"], ["--help"], ["build", "--help"]])
def test_version_and_help_run_without_the_libraries(argv):
    source = (
        "import sys, json\nfrom shellvox.cli import main\n"
        f"try:\n    main({argv!r})\nexcept SystemExit as stop:\n    code = stop.code\n"
        f"print(json.dumps(sorted({{n.split('.')[0] for n in sys.modules}} & set({HEAVY!r}))))"
    )
    done = subprocess.run([sys.executable, "-c", source], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.strip().splitlines()
    assert json.loads(lines[-1]) == []
    assert "shellvox" in lines[0]  # the version, or the usage line


def test_the_offered_names_are_the_registries():
    from shellvox.config import FORMATS, UNIT_MM, UP_AXES, LoadOptions
    from shellvox.fdm import SLICERS
    from shellvox.offset import DEFAULT_METHOD, MAX_FIELD_TRIANGLES, METHODS, SHELL_STEP_MM
    from shellvox.printer import shipped_profiles
    from shellvox.voxel.colour import HALFTONES
    from shellvox.voxel.slab import LayerRule

    assert {name: m.summary for name, m in METHODS.items()} == choices.METHODS
    assert choices.DEFAULT_METHOD == DEFAULT_METHOD
    assert tuple(HALFTONES) == choices.HALFTONES
    assert get_args(LayerRule) == choices.LAYER_RULES
    assert tuple(FORMATS) == choices.FORMATS
    assert tuple(sorted(UNIT_MM)) == choices.UNITS
    assert UP_AXES == choices.UP_AXES
    assert LoadOptions().max_faces == choices.MAX_FACES
    assert tuple(SLICERS) == choices.SLICERS
    assert choices.SHELL_STEP_MM == SHELL_STEP_MM
    assert choices.MAX_FIELD_TRIANGLES == MAX_FIELD_TRIANGLES
    assert choices.printers() == shipped_profiles()
