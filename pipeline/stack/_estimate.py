"""What a build will cost, known before anything is allocated: voxels, memory, disk, time.

The numbers come from the grid (exact), the slab size (exact up to the model's own
arrays) and, for the compressed file sizes and the time, from the model's surface area
with rates measured on this project's benchmarks (``benchmarks/results/bench_build.json``):
they are estimates, good to a factor of about two. :func:`check_resources` refuses a build
that cannot fit (memory, disk, index range) with the numbers and the options that change
them; ``--force`` skips the refusal, and ``--dry-run`` prints it
(:func:`resource_shortfall`) instead of stopping.
"""

from __future__ import annotations

import math
import os
import shutil
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from shellvox.errors import ResourceError, opt
from shellvox.offset import ShellCost
from shellvox.run import EXTRA_SLOTS
from shellvox.voxel.colour import PROOF_MAX_SAMPLES
from shellvox.voxel.io import SHARD_ROWS, encoded_by_slabs

#: Working bytes per voxel of a slab in its worker: the inside test and its crossings (3),
#: the scan's distance and face (12), layers, colour, signed distance, band and
#: materials (11), the copy into the shared slot (11), VDB and TIFF encoding temporaries.
BYTES_PER_VOXEL = 48

#: Bytes per voxel of a level-0 row the OME-Zarr writer holds in its shards' buffers:
#: RGBA and two label images (6), and the levels above (under half as much again).
STORE_BYTES_PER_VOXEL = 9

#: Shared bytes per voxel of a slab slot (:mod:`shellvox.run._slots`; there are
#: :data:`~shellvox.run._slots.EXTRA_SLOTS` beyond one per worker).
SLOT_BYTES_PER_VOXEL = 11

#: Largest grid side: OpenVDB and TIFF index voxels with signed 32-bit integers.
MAX_SIDE = 2**31 - 1

#: The fix for a grid past the index range.
GRID_RANGE_FIX = f"use a larger {opt('voxel_size')} or a smaller {opt('scale')}"

#: Model bytes per face held by every process (vertices, faces, AABB tree, colours).
BYTES_PER_FACE = 600
#: Bytes per surface sample of the colour report while the slabs stream: its voxel
#: counts (20 depth bins of 8 int32, one per material index, 640 B), its disc (160 B),
#: its point, normal and colours and their predictions (about 200 B).
REPORT_BYTES_PER_SAMPLE = 1_000
#: Material slabs the colour report gathers before it counts them (bytes, one per voxel).
REPORT_GATHER_BYTES = 128 << 20

#: Time per voxel of the grid (inside test, layer pass, encoders) and per voxel of the
#: surface band (nearest-face scan, colour), seconds on one core; fitted to the compiled
#: kernels' builds of spot at 100 mm (539 core-seconds) and 30 mm (bench_build.json).
SECONDS_PER_VOXEL = 6e-8
SECONDS_PER_BAND_VOXEL = 7e-7


#: Bytes on disk per voxel of the whole grid (compressed TIFF pages, VDB topology) and per
#: voxel of the surface band (colour, level-set values), measured on the demo and spot.
DISK_PER_VOXEL = 0.02
DISK_PER_BAND_VOXEL = 3.5


@dataclass(frozen=True)
class BuildEstimate:
    """The cost of a build.

    Attributes
    ----------
    shape_zyx : (3,) int
        Grid size ``(Z, Y, X)``.
    voxels : int
        ``Z * Y * X``.
    band_voxels : int
        Voxels within the deepest layer or the level-set band of the surface (estimated
        from the surface area).
    slab_rows : int
        Rows per slab.
    workers : int
        Slab processes.
    memory_bytes : int
        Peak memory of the run: every worker's slab, the slab being written, the model
        in every process and the shell meshes' (:attr:`shell_memory_bytes`).
    disk_bytes : int
        Size of the output files (estimated).
    seconds : float
        Wall time of the voxels (estimated).
    shell_seconds : float
        Time of the offset shells (estimated; 0 without them): before the voxels with
        the ``"shells"`` layer rule, beside them otherwise.
    shell_memory_bytes : int
        Their memory at its peak (estimated; 0 without them or not estimated for their
        method), counted on top of the voxels' since the two overlap.
    """

    shape_zyx: tuple[int, int, int]
    voxels: int
    band_voxels: int
    slab_rows: int
    workers: int
    memory_bytes: int
    disk_bytes: int
    seconds: float
    shell_seconds: float = 0.0
    shell_memory_bytes: int = 0

    def line(self) -> str:
        """One line for the user: grid, voxels, memory, disk and time."""
        z, y, x = self.shape_zyx
        return (
            f"grid {z:,} x {y:,} x {x:,} (z, y, x) = {self.voxels:.3g} voxels; about "
            f"{_size(self.memory_bytes)} of memory ({self.workers} workers, slabs of "
            f"{self.slab_rows} rows), {_size(self.disk_bytes)} on disk, "
            f"{_duration(self.seconds)}"
            + (
                f", and {_duration(self.shell_seconds)} for the shell meshes"
                if self.shell_seconds > 0
                else ""
            )
            + (
                f" ({_size(self.shell_memory_bytes)} of the memory)"
                if self.shell_memory_bytes > 0
                else ""
            )
        )


def estimate_build(
    shape_zyx: tuple[int, int, int],
    voxel_mm: tuple[float, float, float],
    *,
    bands: Sequence[tuple[float, float]],
    n_faces: int,
    slab_rows: int,
    workers: int,
    shells: ShellCost | None = None,
    store_rows: int = 0,
    report_samples: int = 0,
) -> BuildEstimate:
    """Estimate a build's cost from its grid and its models' surfaces.

    Parameters
    ----------
    shape_zyx : (3,) int
        Grid size ``(Z, Y, X)``.
    voxel_mm : (3,) float, mm
        Voxel size ``(x, y, z)``.
    bands : sequence of (area_mm2, reach_mm)
        Surface area (mm^2) and depth of the deepest layer, or the level-set half width if
        larger (mm), of each model in the grid (a tray's copies each counted): the band
        voxels are the sum of their products.
    n_faces : int
        Faces held by every process (each distinct model once).
    slab_rows : int
        Rows per slab.
    workers : int
        Slab processes.
    shells : ShellCost, optional
        The offset shells' cost (:attr:`shellvox.offset.Method.cost`; None: no shells).
    store_rows : int
        Rows of level 0 the OME-Zarr writer fills its shards with (0: none, or the slabs
        hold whole shards; :func:`store_buffer_rows`).
    report_samples : int
        Surface samples of the colour report and the soft proof (0: no report): their
        voxel counts, and the material slabs gathered for them.
    """
    z, y, x = (int(n) for n in shape_zyx)
    voxels = z * y * x
    volume = voxel_mm[0] * voxel_mm[1] * voxel_mm[2]
    band = min(voxels, int(sum(area * reach for area, reach in bands) / volume))
    slab_voxels = min(slab_rows, z) * y * x
    slots = workers + EXTRA_SLOTS if workers > 1 else 0
    memory = slab_voxels * (
        BYTES_PER_VOXEL * (workers + 1) + SLOT_BYTES_PER_VOXEL * slots
    ) + n_faces * BYTES_PER_FACE * (workers + 2)
    memory += min(store_rows, z) * y * x * STORE_BYTES_PER_VOXEL
    if report_samples > 0:
        memory += report_samples * REPORT_BYTES_PER_SAMPLE + REPORT_GATHER_BYTES
    disk = int(voxels * DISK_PER_VOXEL + band * DISK_PER_BAND_VOXEL)
    seconds = (voxels * SECONDS_PER_VOXEL + band * SECONDS_PER_BAND_VOXEL) / max(1, workers)
    shells = shells or ShellCost(0.0, 0)
    memory += shells.memory_bytes
    return BuildEstimate(
        (z, y, x),
        voxels,
        band,
        slab_rows,
        workers,
        memory,
        disk,
        seconds,
        shells.seconds,
        shells.memory_bytes,
    )


def store_buffer_rows(formats: Sequence[str], slab_rows: int) -> int:
    """Return the level-0 rows the OME-Zarr writer buffers (0 without it, or whole shards).

    >>> store_buffer_rows(("tiff", "zarr"), 8), store_buffer_rows(("zarr",), 128)
    (64, 0)
    """
    if "zarr" not in formats or encoded_by_slabs(slab_rows):
        return 0
    return SHARD_ROWS


def check_resources(estimate: BuildEstimate, out_dir: Path, *, force: bool) -> None:
    """Refuse a build that cannot fit this machine (unless `force`).

    Raises
    ------
    ResourceError
        The grid exceeds the index range, or the memory or the disk needed exceeds what
        is available; the message gives the numbers and the options that change them.
    """
    z, y, x = estimate.shape_zyx
    if max(z, y, x) > MAX_SIDE:
        # Not even --force: the files cannot index such a grid.
        raise ResourceError(
            opt("voxel_size"),
            f"the grid would be {z:,} x {y:,} x {x:,} voxels, past the 2^31 voxels per side "
            "that TIFF and OpenVDB can index",
            GRID_RANGE_FIX,
        )
    if force:
        return
    shortfall = resource_shortfall(estimate, out_dir)
    if shortfall is not None:
        raise shortfall


def resource_shortfall(estimate: BuildEstimate, out_dir: Path) -> ResourceError | None:
    """Return why the memory or the disk of this machine would not hold the build, or None.

    The memory needed is compared with ``MemAvailable`` now, the disk needed with the free
    space of `out_dir`'s file system (its nearest existing parent).
    """
    _, y, x = estimate.shape_zyx
    available = available_memory_bytes()
    if available is not None and estimate.memory_bytes > available:
        rows = estimate.slab_rows
        shells = (
            f", the shell meshes {_size(estimate.shell_memory_bytes)}"
            if estimate.shell_memory_bytes > 0
            else ""
        )
        needs = (
            f"the build needs about {_size(estimate.memory_bytes)} of memory "
            f"({estimate.workers} workers, slabs of {rows} row{'s' if rows != 1 else ''} of "
            f"{y:,} x {x:,} voxels{shells}) but {_size(available)} is available"
        )
        if estimate.shell_memory_bytes > available // 2:
            return ResourceError(
                opt("shell_meshes"),
                needs,
                f"leave out {opt('shell_meshes')} or use a smaller {opt('scale')} "
                f"({opt('force_run')} to try anyway)",
            )
        if rows == 1:  # no --slab-mb makes a slab thinner than one row: the grid is too fine
            return ResourceError(
                opt("voxel_size"),
                needs,
                f"use a larger {opt('voxel_size')} (or a smaller {opt('scale')}); "
                f"{opt('force_run')} to try anyway",
            )
        return ResourceError(
            opt("slab_mb"),
            needs,
            f"use a smaller {opt('slab_mb')}, fewer {opt('workers')} or a larger "
            f"{opt('voxel_size')} ({opt('force_run')} to try anyway)",
        )
    free = shutil.disk_usage(_existing(out_dir)).free
    if estimate.disk_bytes > free:
        return ResourceError(
            out_dir,
            f"the outputs need about {_size(estimate.disk_bytes)} but the disk has "
            f"{_size(free)} free",
            f"free some space, choose another {opt('out')}, use a larger {opt('voxel_size')} "
            f"or {opt('no_vdb')} ({opt('force_run')} to try anyway)",
        )
    return None


def available_memory_bytes() -> int | None:
    """Return the memory available to new allocations (Linux ``MemAvailable``), or None."""
    try:
        with open("/proc/meminfo", encoding="ascii") as stream:
            for line in stream:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError):
        return None


def _existing(path: Path) -> Path:
    path = Path(path).absolute()
    while not path.exists() and path != path.parent:
        path = path.parent
    return path


def _size(n_bytes: float) -> str:
    for unit in ("B", "kB", "MB", "GB", "TB", "PB", "EB"):
        if abs(n_bytes) < 1000 or unit == "EB":
            return f"{n_bytes:.3g} {unit}"
        n_bytes /= 1000
    return f"{n_bytes:.3g} EB"  # pragma: no cover


def _duration(seconds: float) -> str:
    if not math.isfinite(seconds) or seconds > 3600 * 24 * 365:
        return "more than a year"
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


def report_sample_count(area_mm2: float, report_samples: int, proof_density: float) -> int:
    """Return the surface samples of the colour report and the soft proof.

    The larger of `report_samples` and `proof_density` (per mm^2) times the surface's
    `area_mm2`, at most :data:`~shellvox.voxel.colour.PROOF_MAX_SAMPLES`; 0 when
    `report_samples` is 0 (no report).

    Examples
    --------
    >>> report_sample_count(1000.0, 20_000, 12.0), report_sample_count(1e6, 20_000, 12.0)
    (20000, 250000)
    """
    if report_samples <= 0:
        return 0
    return max(report_samples, min(math.ceil(proof_density * area_mm2), PROOF_MAX_SAMPLES))
