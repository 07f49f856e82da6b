"""The offset shells of a build (:func:`~shellvox.offset.offset_shells`), before or beside voxels.

With the ``"shells"`` layer rule the voxels are counted between the shells, so the shells
come first, in this process. With the ``"distance"`` rule and ``shell_meshes`` they are a
second realisation of the layers, and the voxels do not depend on them, so a failure there
is a warning, not an error. The ``field`` method's shells are meshed from the voxels' own
scan: each slab keeps the layer field at every few voxel centres
(:class:`shellvox.voxel.geometry.NodeLattice`), which this process marches as the slabs come
(:class:`shellvox.offset.field.layer_field.LatticeMesher`) and simplifies at the end; the
layer field is scanned once. The other methods run beside the voxels in a spawned process
(:class:`shellvox.run._children.ChildCall`: it dies with the build). The shells for the files are
cleaned and jittered here (:func:`shellvox.offset.reference.for_file.shell_for_file`; in the spawned
process when there is one); the voxels of the ``"shells"`` rule use them as computed.
"""

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Iterator, Mapping
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from shellvox.config import BuildConfig
from shellvox.errors import opt, warn
from shellvox.model import ColouredMesh
from shellvox.offset import (
    automatic_lattice,
    field_shells,
    method_shells,
    ready_for_file,
)
from shellvox.offset.field.layer_field import LatticeMesher
from shellvox.offset.methods import surface_area
from shellvox.offset.shells import Shell
from shellvox.run import ChildCall
from shellvox.stack._progress import progress_bar
from shellvox.voxel.geometry import FieldNodes, NodeLattice
from shellvox.voxel.grid import GridSpec
from shellvox.voxel.slab import SlabResult

#: Seconds between updates of the shells' progress bar.
TICK_S = 0.5


class ShellsDone(NamedTuple):
    """The shells for the files (None: none, or they failed) and the seconds of the wait."""

    shells: list[Shell] | None
    #: ``shells`` (computed beside the slabs) and ``shells_wait`` (after them); empty when
    #: computed first.
    seconds: dict[str, float]


class ShellJob:
    """Offset shells of a build and the seconds they took.

    With the "shells" rule the shells are computed when the job is made
    (:attr:`first_seconds`); otherwise :meth:`wait` returns them with its seconds.

    Parameters
    ----------
    mesh : ColouredMesh
        The model.
    thickness : (K, F) float64, mm
        Thickness of each layer per face.
    config : BuildConfig
        ``layer_rule``, ``shell_meshes`` and ``shell_method``.
    estimate_s : float
        Their estimated time (:attr:`shellvox.estimate.BuildEstimate.shell_seconds`),
        the length of their progress bar.
    progress : bool or None
        Show the progress bar; ``None``: where a person is watching
        (:func:`shellvox.stack._progress.watched`).
    grid : GridSpec, optional
        The voxel grid, whose scan gives the ``field`` shells their nodes (the distance
        rule with shell meshes).
    """

    def __init__(
        self,
        mesh: ColouredMesh,
        thickness: NDArray[np.float64],
        config: BuildConfig,
        *,
        estimate_s: float = 0.0,
        progress: bool | None = None,
        grid: GridSpec | None = None,
    ) -> None:
        self.mesh = mesh
        self.thickness = thickness
        self.config = config
        self.estimate_s = estimate_s
        self.progress = progress
        self._pending: ChildCall[tuple[list[Shell], float]] | None = None
        self._started = 0.0
        #: The shells, once computed (at once with the "shells" rule).
        self.shells: list[Shell] | None = None
        #: ``shells``: the seconds of the shells computed at once (the "shells" rule).
        self.first_seconds: Mapping[str, float] = {}
        #: The shell method's record (:attr:`shellvox.offset.MethodShells.record`), when
        #: the shells were made in this process.
        self.record: dict[str, Any] | None = None
        #: The voxel centres whose layer field the slabs keep for the ``field`` shells.
        self.lattice: NodeLattice | None = None
        self._mesher: LatticeMesher | None = None
        self._march_s = 0.0
        self._nodes_missing = False
        # The slabs' nodes are marched in a thread of their own, in z order (the kernels
        # release the GIL), while this thread writes the slabs.
        self._marcher: ThreadPoolExecutor | None = None
        self._marched: list[Future[None]] = []
        if self.meshes_voxels and grid is not None:
            self.lattice = automatic_lattice(
                grid, surface_area(mesh.vertices, mesh.faces), thickness.shape[0]
            )
            depth = np.cumsum(thickness, axis=0)
            self._mesher = LatticeMesher(mesh.vertices, mesh.faces, depth, grid, self.lattice)
        if config.layer_rule == "shells":
            with self._bar(time.perf_counter()):
                self.shells, shell_s = timed_shells(mesh.vertices, mesh.faces, thickness, config)
            self.first_seconds = {"shells": shell_s}

    @property
    def writes_meshes(self) -> bool:
        """The distance layers' build computes shell meshes beside the slabs."""
        return self.config.layer_rule == "distance" and self.config.shell_meshes

    @property
    def meshes_voxels(self) -> bool:
        """The shell meshes are the ``field`` method's, meshed from the voxels' scan."""
        return self.writes_meshes and self.config.shell_method == "field"

    def add_slab(self, slab: SlabResult) -> None:
        """March the layer field a slab kept at the lattice's nodes (slabs in z order).

        A slab without them (checkpointed by a build that did not keep them) leaves the
        shells to a scan of their own at the end.
        """
        if self._mesher is None:
            return
        if slab.nodes is None:
            self._mesher, self._nodes_missing = None, True
            return
        if self._marcher is None:
            self._marcher = ThreadPoolExecutor(1, thread_name_prefix="shellvox-march")
        self._marched.append(self._marcher.submit(self._march, self._mesher, slab.nodes))

    def _march(self, mesher: LatticeMesher, nodes: FieldNodes) -> None:
        tick = time.perf_counter()
        mesher.add_nodes(nodes)
        self._march_s += time.perf_counter() - tick

    def _stop_marching(self) -> None:
        """End the marching thread (at once: what it had left is not wanted)."""
        if self._marcher is not None:
            self._marcher.shutdown(wait=True, cancel_futures=True)
            self._marcher = None

    def start_beside(self, stack: contextlib.ExitStack) -> None:
        """Start the shells in another process, with the distance rule and shell meshes.

        Call after the slab workers are forked; `stack` stops the process if the build
        fails. The ``field`` shells need none: they are meshed here from the slabs (the
        marching thread is stopped with `stack`).
        """
        stack.callback(self._stop_marching)
        if self.writes_meshes and not self.meshes_voxels:
            call = ChildCall(  # a process that dies fails the call instead of hanging it
                timed_shells,
                self.mesh.vertices,
                self.mesh.faces,
                self.thickness,
                self.config,
                True,  # for_files: cleaned and jittered in that process
            )
            self._pending = stack.enter_context(call)
            self._started = time.perf_counter()

    def wait(self) -> ShellsDone:
        """Return the shells ready for their files (waiting for the other process).

        Their ``shells`` are None when there are none or they failed; the seconds are
        those of the shells computed beside the slabs and of the wait for them. The files'
        shells are cleaned and jittered (:func:`shellvox.offset.reference.for_file.shell_for_file`);
        with the "shells" rule :attr:`shells` stays as computed (the voxels' shells), and without
        shell meshes to write those are what is returned.
        """
        if self.meshes_voxels:
            return self._voxel_shells()
        if self._pending is None:
            if self.shells is None or not self.config.shell_meshes:
                return ShellsDone(self.shells, {})  # no files: the voxels' shells as computed
            return ShellsDone(
                [ready_for_file(s, self.config.shell_method).shell for s in self.shells], {}
            )
        tick = time.perf_counter()
        seconds = {}
        try:
            with self._bar(self._started):
                self.shells, seconds["shells"] = self._pending.result()
        except Exception as error:  # the voxels do not depend on the shell meshes
            warn(
                f"{self.mesh.source}: the shell meshes failed ({error}); the voxel stack "
                f"is complete without shells/; rerun with {opt('layer_rule', 'shells')} to see the "
                "error",
            )
        seconds["shells_wait"] = time.perf_counter() - tick
        self._pending = None
        return ShellsDone(self.shells, seconds)

    def _voxel_shells(self) -> ShellsDone:
        """Return the ``field`` shells of the layer field the slabs kept, simplified."""
        tick = time.perf_counter()
        mesh, depth = self.mesh, np.cumsum(self.thickness, axis=0)
        try:
            for marched in self._marched:  # a march's error is raised here
                marched.result()
            self._stop_marching()
            if self._mesher is not None:
                with self._bar(tick - self._march_s):
                    field = self._mesher.surfaces()
                    made = field_shells(
                        field,
                        mesh.vertices,
                        mesh.faces,
                        depth,
                        field_s=self._march_s + time.perf_counter() - tick,
                        source="voxels",
                    )
                self._mesher = None
            else:  # resumed slabs without nodes: the shells scan the field themselves
                made = method_shells(mesh.vertices, mesh.faces, self.thickness, method="field")
                made.record["field_source"] = "own scan (resumed slabs kept no nodes)"
            self.shells = [ready_for_file(shell, "field").shell for shell in made.shells]
            self.record = {**made.record, "layer_field_scans": 1 + self._nodes_missing}
        except Exception as error:  # the voxels do not depend on the shell meshes
            warn(
                f"{mesh.source}: the shell meshes failed ({error}); the voxel stack is "
                "complete without shells/; run `shellvox shells` on the model for its shells",
            )
            self.shells = None
        seconds = time.perf_counter() - tick
        return ShellsDone(self.shells, {"shells": self._march_s + seconds, "shells_wait": seconds})

    @contextlib.contextmanager
    def _bar(self, started: float) -> Iterator[None]:
        """Show the seconds spent on the shells since `started` against their estimate."""
        done = threading.Event()
        bar = progress_bar(
            self.progress,
            total=max(self.estimate_s, 1.0),
            desc="shell meshes",
            unit="s",
            bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.0f} of about {total:.0f} s",
        )

        def tick() -> None:
            while not done.wait(TICK_S):
                elapsed = time.perf_counter() - started
                if elapsed > 0.95 * bar.total:  # longer than estimated: the end moves on
                    bar.total = elapsed / 0.95
                bar.n = elapsed
                bar.refresh()

        ticker = threading.Thread(target=tick, name="shell-progress", daemon=True)
        ticker.start()
        try:
            yield
        finally:
            done.set()
            ticker.join()
            bar.n = bar.total
            bar.close()


def timed_shells(
    vertices: np.ndarray[Any, Any],
    faces: np.ndarray[Any, Any],
    thickness: np.ndarray[Any, Any],
    config: BuildConfig,
    for_files: bool = False,
) -> tuple[list[Shell], float]:
    """Return the offset shells of the model and the seconds they took (picklable).

    With `for_files`, the shells are those for the files
    (:func:`shellvox.offset.reference.for_file.shell_for_file`: cleaned and jittered).
    """
    tick = time.perf_counter()
    shells = method_shells(vertices, faces, thickness, method=config.shell_method).shells
    if for_files:
        shells = [ready_for_file(shell, config.shell_method).shell for shell in shells]
    return shells, time.perf_counter() - tick
