"""Sphinx configuration of shellvox's documentation (``make docs``; warnings are errors).

The tutorials are MyST notebooks executed at every build (myst-nb), so their commands and
pictures cannot drift from the code; the CLI reference is generated from the argument
parser (sphinx-argparse), the Python reference from the docstrings (autodoc), and the
performance tables from ``benchmarks/results/*.json`` (:mod:`docs._generate`).
"""

from __future__ import annotations

import doctest
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from _generate import write_generated  # noqa: E402

import shellvox  # noqa: E402

project = "shellvox"
author = "the shellvox developers"
copyright = "the shellvox developers, MIT licence"
version = release = shellvox.__version__

extensions = [
    "myst_nb",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.doctest",
    "sphinxarg.ext",
]
source_suffix = {".rst": "restructuredtext", ".md": "myst-nb"}
exclude_patterns = ["_build", "jupyter_execute", "**/.ipynb_checkpoints"]
myst_enable_extensions = ["colon_fence", "deflist"]
myst_heading_anchors = 3

# Every notebook runs at every build; an error in one fails the build.
nb_execution_mode = "force"
nb_execution_timeout = 900
nb_execution_raise_on_error = True
nb_execution_in_temp = True  # each notebook writes its builds into a folder of its own
nb_execution_show_tb = True
nb_merge_streams = True

autodoc_typehints = "none"
autodoc_member_order = "bysource"
autodoc_default_options = {"members": False}
napoleon_google_docstring = False
napoleon_numpy_docstring = True
napoleon_use_rtype = False

# The docstring examples also run here (``sphinx-build -b doctest``, in ``make docs``).
doctest_default_flags = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
# Each group runs in a fresh temporary folder: the examples write builds where they run.
doctest_global_setup = """
import os, shutil, tempfile
import numpy as np
import shellvox
_doctest_home = os.getcwd()
_doctest_work = tempfile.mkdtemp(prefix="shellvox-doctest-")
os.chdir(_doctest_work)
"""
doctest_global_cleanup = """
os.chdir(_doctest_home)
shutil.rmtree(_doctest_work, ignore_errors=True)
"""

html_theme = "pydata_sphinx_theme"
html_title = f"shellvox {version}"
html_static_path = ["_static"]
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
}
html_last_updated_fmt = None


def setup(app):  # type: ignore[no-untyped-def]
    """Write the generated pages before the sources are read."""
    app.connect("builder-inited", lambda app: write_generated(HERE))
