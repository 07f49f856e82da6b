"""Slab tasks on a Dask distributed cluster (``--scheduler ADDRESS`` or ``local``).

The same task as the local workers (:func:`shellvox.run._task.stack_slab`: voxels,
materials when the halftone is order-independent, VDB leaves) runs on the Dask workers.
The slab job (model, grid, material plan, VDB encoder) is scattered to every worker once
(``broadcast``), not sent with each task; each task returns its slab as chunk bytes
(:mod:`shellvox.run._chunks`: compressed on the worker, so the network carries a tenth of
the arrays), which this process decodes, checkpoints as they are when the build keeps a
run folder, and hands to the writers in z order. The runner keeps at most the cluster's
threads plus one slabs in flight.

Failures end the build with one line instead of hanging it: a scheduler that cannot be
reached, is lost or has no workers for :data:`NO_WORKERS_S` raises
:class:`ClusterError` (exit status 2: the ``--scheduler`` given); a slab whose workers
keep dying (Dask retries it on others first) raises
:class:`shellvox.errors.SlabWorkerDied` (exit status 4, as for local workers).
"""

from __future__ import annotations

import contextlib
import logging
import time
import uuid
from concurrent.futures import CancelledError
from typing import TYPE_CHECKING

from shellvox.errors import ClusterError, SlabWorkerDied, opt
from shellvox.faults import raise_if_interrupted
from shellvox.run._chunks import decode_chunk, encode_chunk
from shellvox.run._task import Rows, SlabJob, StackSlab

if TYPE_CHECKING:
    from distributed import Client, Future, LocalCluster

    from shellvox.run._checkpoints import RunFolder

#: Seconds to reach the scheduler, and to wait while it has no worker (or is lost).
CONNECT_S = 30.0
NO_WORKERS_S = 60.0
#: Seconds between health checks while waiting for a slab.
POLL_S = 1.0
#: Losses of the slab job (or cancelled slabs, per slab in flight) a build survives.
RESCATTERS = 3


class DaskPool:
    """Slab tasks on a Dask cluster (a :class:`shellvox.run._task.SlabExecutor`).

    Parameters
    ----------
    job : SlabJob
        Scattered to every worker once.
    scheduler : str
        The scheduler's address (``tcp://host:8786``), or ``"local"``: a ``LocalCluster``
        of `workers` processes with one thread each, on this machine.
    workers : int
        Processes of the local cluster (ignored with an address).
    run : RunFolder, optional
        Checkpoint every slab there (the bytes the worker sent).
    """

    def __init__(self, job: SlabJob, scheduler: str, workers: int, run: RunFolder | None) -> None:
        try:
            from distributed import Client, LocalCluster
        except ImportError:
            raise ClusterError(
                opt("scheduler"),
                "needs Dask's distributed, which is not installed",
                "install the cluster extra: pip install 'shellvox[cluster]'",
            ) from None

        self.scheduler = scheduler
        self.run = run
        self._cluster: LocalCluster | None = None
        self._tag = uuid.uuid4().hex[:8]
        try:
            if scheduler == "local":
                self._cluster = LocalCluster(
                    n_workers=workers,
                    threads_per_worker=1,
                    processes=True,
                    dashboard_address=None,
                    silence_logs=logging.ERROR,
                )
                self.client: Client = Client(self._cluster, set_as_default=False)
            else:
                self.client = Client(scheduler, timeout=CONNECT_S, set_as_default=False)
            self.client.wait_for_workers(1, timeout=NO_WORKERS_S)
        except (OSError, TimeoutError) as error:
            self.close(failed=True)
            raise ClusterError(
                opt("scheduler"),
                f"cannot use the Dask scheduler at {scheduler} ({type(error).__name__}: "
                f"{error})".replace("\n", " "),
                "start it and its workers (dask scheduler; dask worker ADDRESS --nthreads 1) "
                "or check the address",
            ) from None
        self.capacity = sum(self.client.nthreads().values()) + 1
        self._slab_job = job
        self._job = self._scatter()
        self._retries = 0

    def submit(self, rows: Rows) -> tuple[Rows, Future]:
        """Send the slab's task to the cluster."""
        key = f"shellvox-slab-{self._tag}-{rows[0]}"
        return rows, self.client.submit(_dask_slab, self._job, *rows, key=key, pure=False)

    def result(self, handle: tuple[Rows, Future]) -> StackSlab:
        """Wait for the slab (checking the cluster's health meanwhile) and decode it."""
        from distributed import KilledWorker

        rows, future = handle
        alone_since: float | None = None
        while True:
            raise_if_interrupted()
            try:
                data: bytes = future.result(timeout=POLL_S)
                break
            except TimeoutError:
                alone_since = self._check_health(alone_since)
            except KilledWorker as error:
                raise SlabWorkerDied(
                    f"Dask workers died computing a slab ({error}; often: out of memory); "
                    f"rerun with a smaller {opt('slab_mb')} or on workers with more memory"
                ) from None
            except CancelledError:
                future = self._again(rows)
        if self.run is not None:
            self.run.save_bytes(rows, data)
        return decode_chunk(data)

    def _scatter(self) -> Future:
        """Send the slab job to every worker as one piece of data.

        In a list: a tuple's fields would each be scattered alone.
        """
        futures: list[Future] = self.client.scatter([self._slab_job], broadcast=True, hash=False)
        return futures[0]

    def _again(self, rows: Rows) -> Future:
        """Submit a cancelled slab again, after sending the job again if it was lost.

        The job is data on the workers, not a task Dask can recompute: when the workers
        holding it die (Dask's memory manager may keep one replica only), the scheduler
        cancels every slab that needs it. A cancelled slab is submitted again (the job
        sent again first when it was lost), up to :data:`RESCATTERS` times the slabs in
        flight in a build; a cluster that keeps cancelling is reported lost.
        """
        lost = self._job.status != "finished"  # the job's last copy died with its worker
        self._retries += 1  # each loss cancels the slabs in flight: capacity retries
        if self._retries > RESCATTERS * self.capacity or self.client.status != "running":
            why = "the workers holding the slab job died" if lost else "it cancelled the slab"
            raise self._lost(why)
        if lost:
            self._job = self._scatter()
        key = f"shellvox-slab-{self._tag}-{rows[0]}-again{self._retries}"
        again: Future = self.client.submit(_dask_slab, self._job, *rows, key=key, pure=False)
        return again

    def _check_health(self, alone_since: float | None) -> float | None:
        """Raise when the scheduler is lost or workerless for too long; return since when."""
        now = time.monotonic()
        if self.client.status in ("closed", "closing", "failed"):
            raise self._lost(f"the client's connection is {self.client.status}")
        workers = self.client.scheduler_info().get("workers", {})
        healthy = self.client.status == "running" and len(workers) > 0
        if healthy:
            return None
        if alone_since is None:
            return now
        if now - alone_since > NO_WORKERS_S:
            what = "no worker" if self.client.status == "running" else "no connection"
            raise self._lost(f"{what} for {NO_WORKERS_S:g} s")
        return alone_since

    def _lost(self, why: str) -> ClusterError:
        return ClusterError(
            opt("scheduler"),
            f"lost the Dask cluster at {self.scheduler} mid-build ({why})",
            f"restart the scheduler and its workers, then rerun with {opt('resume')}",
        )

    def close(self, failed: bool) -> None:
        """Close the client (cancelling what is pending) and the local cluster."""
        client = getattr(self, "client", None)
        if client is not None:
            with contextlib.suppress(Exception):  # closing a lost connection
                client.close(timeout=10)
        if self._cluster is not None:
            with contextlib.suppress(Exception):
                self._cluster.close(timeout=10)


def _dask_slab(job: SlabJob, z_start: int, z_stop: int) -> bytes:
    """Compute a slab on a Dask worker; return it as chunk bytes."""
    return encode_chunk(job.run((z_start, z_stop)), job.send)
