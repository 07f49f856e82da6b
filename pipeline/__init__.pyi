# The public names of shellvox, loaded on first use (lazy_loader reads this stub).
from . import data
from .api import (
    BuildOptions,
    BuildResult,
    Calibration,
    ChartResult,
    FdmResult,
    Inspection,
    ShellsResult,
    ThicknessChoice,
    TrayRequest,
    build,
    build_tray,
    calibrate,
    fdm_projects,
    inspect_build,
    layer_thickness,
    make_chart,
    offset_shells,
    plan_tray_build,
    write_shells,
)
from .config import LoadOptions, MaterialSettings, ShellConfig
from .errors import InputError, ShellvoxWarning
from .fdm import FdmSettings
from .loading import load_model
from .model import ColouredMesh
from .offset import Shell
from .printer import PrinterProfile, load_profile
from .reading import Build, Samples, open_build
from .run import RunSettings
from .thickness import DEFAULT_RULE, ThicknessRule, load_rule
from .voxel.colour import SoftProof
from .voxel.grid import GridSpec

__version__: str

__all__ = [
    "DEFAULT_RULE",
    "Build",
    "BuildOptions",
    "BuildResult",
    "Calibration",
    "ChartResult",
    "ColouredMesh",
    "FdmResult",
    "FdmSettings",
    "GridSpec",
    "InputError",
    "Inspection",
    "LoadOptions",
    "MaterialSettings",
    "PrinterProfile",
    "RunSettings",
    "Samples",
    "Shell",
    "ShellConfig",
    "ShellsResult",
    "ShellvoxWarning",
    "SoftProof",
    "ThicknessChoice",
    "ThicknessRule",
    "TrayRequest",
    "__version__",
    "build",
    "build_tray",
    "calibrate",
    "data",
    "fdm_projects",
    "inspect_build",
    "layer_thickness",
    "load_model",
    "load_profile",
    "load_rule",
    "make_chart",
    "offset_shells",
    "open_build",
    "plan_tray_build",
    "write_shells",
]
