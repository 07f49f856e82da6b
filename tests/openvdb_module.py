"""Import OpenVDB's own Python bindings, wherever the system put them.

OpenVDB 12+ ships a module named ``openvdb``; Debian/Ubuntu's ``python3-openvdb``
(OpenVDB 10) ships ``pyopenvdb`` in the system ``dist-packages``, which a virtual
environment does not see, and it is built against numpy 1.x (it crashes under numpy 2).
"""

from __future__ import annotations

import glob
import importlib
import importlib.util
import sys
from functools import cache
from types import ModuleType

import numpy as np

SYSTEM_DIST_PACKAGES = ("/usr/lib/python3/dist-packages",)


class OpenVDBUnavailableError(ImportError):
    """OpenVDB's Python module cannot be imported."""


@cache
def load_openvdb() -> ModuleType:
    """Return OpenVDB's Python module (``openvdb`` or ``pyopenvdb``).

    Returns
    -------
    module
        The bindings module; it has ``FloatGrid``, ``Vec3SGrid``, ``write``, ``read``.

    Raises
    ------
    OpenVDBUnavailableError
        With the fix, if neither module can be loaded.
    """
    for name in ("openvdb", "pyopenvdb"):
        try:
            return importlib.import_module(name)
        except ImportError:
            pass
    abi = f"cpython-{sys.version_info.major}{sys.version_info.minor}"
    for folder in SYSTEM_DIST_PACKAGES:
        for path in sorted(glob.glob(f"{folder}/pyopenvdb.{abi}*.so")):
            if int(np.__version__.split(".")[0]) >= 2:
                raise OpenVDBUnavailableError(
                    f"{path}: Debian's OpenVDB module needs numpy 1.x but numpy "
                    f"{np.__version__} is installed; install 'numpy<2' (make setup does)"
                )
            spec = importlib.util.spec_from_file_location("pyopenvdb", path)
            if spec is None or spec.loader is None:  # pragma: no cover - defensive
                continue
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
            sys.modules["pyopenvdb"] = module
            return module
    raise OpenVDBUnavailableError(
        "OpenVDB's Python module was not found: install it with "
        "'sudo apt-get install python3-openvdb' (or 'make setup')"
    )
