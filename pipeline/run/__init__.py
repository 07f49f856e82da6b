"""Where the slabs run: the task, the runner and its executors, checkpoints.

- :mod:`~shellvox.run._task` the slab task and the vocabulary every executor shares;
- :mod:`~shellvox.run._runner` ``SlabRunner``: picks the executor, yields slabs in z order;
- :mod:`~shellvox.run._fork` forked workers, handing slabs back through
  :mod:`~shellvox.run._slots` (shared memory); :mod:`~shellvox.run._children` children that
  die with their parent;
- :mod:`~shellvox.run._cluster` a Dask cluster; :mod:`~shellvox.run._chunks` a slab as bytes;
- :mod:`~shellvox.run._checkpoints` the run folder that lets a killed build resume.

Nothing here imports :mod:`shellvox.stack`.
"""

from __future__ import annotations

from shellvox.run._checkpoints import (
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
from shellvox.run._children import ChildCall, ChildDied
from shellvox.run._chunks import decode_chunk, encode_chunk
from shellvox.run._runner import SlabRunner
from shellvox.run._slots import EXTRA_SLOTS, SlabSlots
from shellvox.run._task import (
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
