"""One model's build: plan, estimate, shells, the stack, the colour check.

- :mod:`~shellvox.stack._plan` grid, layers, slabs and workers, fixed before any work;
  :mod:`~shellvox.stack._estimate` its cost;
- :mod:`~shellvox.stack._shell_job` the offset shells (in a child process, beside the voxels);
- :mod:`~shellvox.stack._stack` ``build_stack``: shells, then slabs streamed to the files;
- :mod:`~shellvox.stack._colour_check` the colour report of the build.
"""

from __future__ import annotations

from shellvox.stack._colour_check import ColourCheck, report_line, uniform_surroundings
from shellvox.stack._estimate import (
    BuildEstimate,
    check_resources,
    estimate_build,
    report_sample_count,
    resource_shortfall,
    store_buffer_rows,
)
from shellvox.stack._plan import BuildPlan, check_depth, grid_for, slab_rows_for
from shellvox.stack._running import run_job, settle_running
from shellvox.stack._stack import build_stack, stack_model

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
    "report_sample_count",
    "resource_shortfall",
    "run_job",
    "settle_running",
    "slab_rows_for",
    "stack_model",
    "store_buffer_rows",
    "uniform_surroundings",
]
