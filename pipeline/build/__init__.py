"""One model's build: plan, estimate, shells, the stack, the colour check.

- :mod:`~pipeline.build._plan` grid, layers, slabs and workers, fixed before any work;
  :mod:`~pipeline.build._estimate` its cost;
- :mod:`~pipeline.build._shell_job` the offset shells (in a child process, beside the voxels);
- :mod:`~pipeline.build._stack` ``build_stack``: shells, then slabs streamed to the files;
- :mod:`~pipeline.build._colour_check` the colour report of the build.
"""

from __future__ import annotations

from pipeline.build._colour_check import ColourCheck, report_line, uniform_surroundings
from pipeline.build._estimate import (
    BuildEstimate,
    check_resources,
    estimate_build,
    resource_shortfall,
    store_buffer_rows,
)
from pipeline.build._plan import BuildPlan, check_depth, grid_for, slab_rows_for
from pipeline.build._running import run_job, settle_running
from pipeline.build._stack import build_stack, stack_model

__all__ = [
    "BuildEstimate",
    "BuildPlan",
    "ColourCheck",
    "build_stack",
    "check_depth",
    "check_resources",
    "estimate_build",
    "grid_for",
    "report_line",
    "resource_shortfall",
    "run_job",
    "settle_running",
    "slab_rows_for",
    "stack_model",
    "store_buffer_rows",
    "uniform_surroundings",
]
