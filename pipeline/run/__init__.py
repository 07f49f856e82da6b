"""Where the slabs run: the task, the runner and its executors, checkpoints.

- :mod:`~pipeline.run._task` the slab task and the vocabulary every executor shares;
- :mod:`~pipeline.run._runner` ``SlabRunner``: picks the executor, yields slabs in z order;
- :mod:`~pipeline.run._fork` forked workers, handing slabs back through
  :mod:`~pipeline.run._slots` (shared memory); :mod:`~pipeline.run._children` children that
  die with their parent;
- :mod:`~pipeline.run._cluster` a Dask cluster; :mod:`~pipeline.run._chunks` a slab as bytes;
- :mod:`~pipeline.run._checkpoints` the run folder that lets a killed build resume.

Nothing here imports :mod:`pipeline.build`.
"""
