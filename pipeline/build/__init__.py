"""One model's build: plan, estimate, shells, the stack, the colour check.

- :mod:`~pipeline.build._plan` grid, layers, slabs and workers, fixed before any work;
  :mod:`~pipeline.build._estimate` its cost;
- :mod:`~pipeline.build._shell_job` the offset shells (in a child process, beside the voxels);
- :mod:`~pipeline.build._stack` ``build_stack``: shells, then slabs streamed to the files;
- :mod:`~pipeline.build._colour_check` the colour report of the build.
"""
