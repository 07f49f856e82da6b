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

from __future__ import annotations

from pipeline.run._checkpoints import (
    CHECKPOINT_AFTER_S,
    JOURNAL,
    RUN_FOLDER,
    RunFolder,
    RunSettings,
    check_resumable,
    checkpoints,
    model_key,
    run_key,
)
from pipeline.run._children import ChildCall, ChildDied
from pipeline.run._chunks import decode_chunk, encode_chunk
from pipeline.run._runner import SlabRunner
from pipeline.run._slots import EXTRA_SLOTS, SlabSlots
from pipeline.run._task import (
    SLAB_ARRAYS,
    SlabJob,
    StackSlab,
    material_tally,
    resolve_workers,
    stack_slab,
)

__all__ = [
    "CHECKPOINT_AFTER_S",
    "EXTRA_SLOTS",
    "JOURNAL",
    "RUN_FOLDER",
    "SLAB_ARRAYS",
    "ChildCall",
    "ChildDied",
    "RunFolder",
    "RunSettings",
    "SlabJob",
    "SlabRunner",
    "SlabSlots",
    "StackSlab",
    "check_resumable",
    "checkpoints",
    "decode_chunk",
    "encode_chunk",
    "material_tally",
    "model_key",
    "resolve_workers",
    "run_key",
    "stack_slab",
]
