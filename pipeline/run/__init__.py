"""Where the slabs run: the task, the runner and its executors, checkpoints.

- :mod:`~pipeline.run.task` the slab task and the vocabulary every executor shares;
- :mod:`~pipeline.run.runner` ``SlabRunner``: picks the executor, yields slabs in z order;
- :mod:`~pipeline.run.fork` forked workers, handing slabs back through
  :mod:`~pipeline.run.slots` (shared memory); :mod:`~pipeline.run.children` children that
  die with their parent;
- :mod:`~pipeline.run.cluster` a Dask cluster; :mod:`~pipeline.run.chunks` a slab as bytes;
- :mod:`~pipeline.run.checkpoints` the run folder that lets a killed build resume.

Nothing here imports :mod:`pipeline.build`.
"""
