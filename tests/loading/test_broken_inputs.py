"""The corpus of broken files: each ends in one InputError line or one warning line.

For every case of :data:`corpus.CASES` the API raises an ``InputError`` (or emits exactly
one ``ShellvoxWarning`` and loads), and ``shellvox info`` prints exactly one line on
stderr, exits 2 (or 0) and shows no traceback. The API's message names the options in
Python's words (no ``--flag``), the same message worded for the command line has the
case's needles.
"""

from __future__ import annotations

import argparse
import re

import pytest
from corpus import CASES, Case
from PIL import Image

from shellvox.cli import main
from shellvox.cli.loadargs import add_load_arguments, load_options
from shellvox.errors import OPTIONS, InputError, ShellvoxWarning, options_in
from shellvox.loading import load_model


def _options(case: Case, folder):
    return [option.replace("FOLDER", str(folder)) for option in case.options]


@pytest.mark.parametrize("case", CASES, ids=[case.name for case in CASES])
def test_api(case, tmp_path):
    path = case.build(tmp_path)
    parser = argparse.ArgumentParser()
    add_load_arguments(parser)
    options = load_options(parser.parse_args([*_options(case, tmp_path), str(path)]))
    if case.outcome == "error":
        with pytest.raises(InputError) as caught:
            load_model(path, options)
        message, cli = str(caught.value), caught.value.words("cli")
        named = caught.value.options
    else:
        with pytest.warns(ShellvoxWarning) as record:
            load_model(path, options)
        assert len(record) == 1, [str(w.message) for w in record]
        warning = record[0].message
        assert isinstance(warning, ShellvoxWarning)
        message, cli = str(warning), warning.words("cli")
        named = options_in(str(warning.args[0]))
    assert "\n" not in message
    assert not re.search(r"(^|[\s(])--[a-z]", message), message
    for name in named:
        assert OPTIONS[name].python.split("{")[0] in message, message
    for needle in case.needles:
        assert needle in cli, cli


@pytest.mark.parametrize("case", CASES, ids=[case.name for case in CASES])
def test_cli_one_line(case, tmp_path, capsys):
    path = case.build(tmp_path)
    status = main(["info", *_options(case, tmp_path), str(path)])
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err
    if case.outcome == "error":
        assert status == 2
        assert lines[0].startswith("shellvox: error: ")
    else:
        assert status == 0
        assert lines[0].startswith("shellvox: warning: ")
    for needle in case.needles:
        assert needle in lines[0], lines[0]


def test_pillow_limit_is_restored(tmp_path):
    saved = Image.MAX_IMAGE_PIXELS
    big = next(case for case in CASES if "13000" in case.name and "obj" in case.name)
    with pytest.raises(InputError):
        load_model(big.build(tmp_path))
    assert saved == Image.MAX_IMAGE_PIXELS
