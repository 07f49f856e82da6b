"""One model's build: plan, estimate, shells, the stack, the colour check.

- :mod:`~pipeline.build.plan` grid, layers, slabs and workers, fixed before any work;
  :mod:`~pipeline.build.estimate` its cost;
- :mod:`~pipeline.build.shell_job` the offset shells (in a child process, beside the voxels);
- :mod:`~pipeline.build.stack` ``build_stack``: shells, then slabs streamed to the files;
- :mod:`~pipeline.build.colour_check` the colour report of the build.
"""
