"""What the command line offers to choose from, known without importing the libraries.

The argument definitions and every ``--help`` read these names, so that ``shellvox
--help``, ``shellvox --version`` and ``shellvox COMMAND --help`` start in a fraction of a
second; the libraries behind a command (numba, colour-science, matplotlib, ...) load when
it runs. The printers are the profile files installed with shellvox; the other names
repeat their registries', and ``tests/cli/test_cli_start.py`` holds each equal to its
registry.
"""

from __future__ import annotations

from importlib import resources

#: The offset methods (:data:`shellvox.offset.METHODS`): name and summary; the default first.
METHODS: dict[str, str] = {
    "field": "the layer field meshed and simplified: closed, nested, no crossings, seconds",
    "robust": "reference: exact Booleans of per-face pieces, exact creases, minutes on a scan",
    "paper": "reference: Zhu and Chen's three-plane construction, for comparison only",
}
#: The default offset method (:data:`shellvox.offset.DEFAULT_METHOD`).
DEFAULT_METHOD = "field"
#: The halftones (:data:`shellvox.voxel.colour.HALFTONES`).
HALFTONES: tuple[str, ...] = ("blue-noise", "error-diffusion")
#: How a voxel's layer is found (:data:`shellvox.voxel.slab.LayerRule`).
LAYER_RULES: tuple[str, ...] = ("distance", "shells")
#: The files a build writes (:data:`shellvox.config.FORMATS`).
FORMATS: tuple[str, ...] = ("tiff", "vdb", "gcvf", "png", "zarr")
#: The units of a model's coordinates (:data:`shellvox.config.UNIT_MM`), sorted.
UNITS: tuple[str, ...] = ("cm", "foot", "inch", "m", "micron", "mm")
#: The up axes of a model (:data:`shellvox.config.UP_AXES`).
UP_AXES: tuple[str, ...] = ("x", "y", "z", "-x", "-y", "-z")
#: The loader's face limit (:attr:`shellvox.config.LoadOptions.max_faces`).
MAX_FACES = 5_000_000
#: The FDM slicers (:data:`shellvox.fdm.SLICERS`).
SLICERS: tuple[str, ...] = ("prusa", "bambu")
#: The field method's grid step, mm (:data:`shellvox.offset.SHELL_STEP_MM`).
SHELL_STEP_MM = 0.1
#: The field method's triangle budget (:data:`shellvox.offset.MAX_FIELD_TRIANGLES`).
MAX_FIELD_TRIANGLES = 36_000_000


def printers() -> list[str]:
    """Return the names of the installed printer profiles (``shellvox/printer/profiles``).

    The same names as :func:`shellvox.printer.shipped_profiles`, read from the installed
    files without importing :mod:`shellvox.printer`.
    """
    folder = resources.files("shellvox") / "printer" / "profiles"
    return sorted(p.name[: -len(".toml")] for p in folder.iterdir() if p.name.endswith(".toml"))
