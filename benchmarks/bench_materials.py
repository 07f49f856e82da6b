"""Per-voxel cost of materials_for_slab on a 64 x 512 x 512 slab (J750 profile).

    python benchmarks/bench_materials.py

Three slabs of 64 x 512 x 512 voxels (16.8 M):

- ``shell``: a cylinder of radius 250 voxels with a 12-voxel colour layer (layer 1), a
  12-voxel backing band and a core, colours varying smoothly around it (a hue wheel,
  alpha 255), as a build's slab looks;
- ``all_colour_smooth``: every voxel in the colour layer, smooth colours;
- ``all_colour_random``: every voxel in the colour layer, independent random colours
  (the table lookups miss the cache: the worst case).

For each: the blue-noise halftone (default) and error diffusion, best of 3 (error
diffusion once), as wall and process CPU time (the machine may be shared: the load
average is recorded). Also the one-off costs: building the plan (separation table and
blue-noise tile) and compiling the kernels (numba, cached on disk afterwards). The peer
is error diffusion, the classic halftone, on the same slabs.
"""

from __future__ import annotations

import json
import os
import time
from typing import Any

import numpy as np
from _common import load_average, parser, write_result

from shellvox.config import MaterialSettings
from shellvox.printer import build_material_plan, load_profile
from shellvox.voxel.colour import materials_for_slab

NAME = "bench_materials"
WHAT = (
    "Time per voxel of the halftone into the J750's materials (materials_for_slab, "
    "blue noise, the default) on 64 x 512 x 512 slabs, against error diffusion on the "
    "same slabs."
)
SHAPE = (64, 512, 512)


def slabs(shape: tuple[int, int, int]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The three slabs of `shape` (a cylinder of radius 250 voxels on a 512 x 512 slab)."""
    z, y, x = np.ogrid[: shape[0], : shape[1], : shape[2]]
    radius = np.hypot(y - 256.0, x - 256.0) + 0 * z
    hue = np.arctan2(y - 256.0, x - 256.0) + 0 * z
    smooth = np.empty((*shape, 4), dtype=np.uint8)
    for channel, phase in enumerate((0.0, 2.1, 4.2)):
        smooth[..., channel] = (127.5 + 127.5 * np.cos(hue + phase + z / 40.0)).astype(np.uint8)
    smooth[..., 3] = 255
    shell = np.zeros(shape, dtype=np.uint8)
    shell[radius < 250] = 3
    shell[(radius < 250) & (radius >= 226)] = 2
    shell[(radius < 250) & (radius >= 238)] = 1
    everywhere = np.ones(shape, dtype=np.uint8)
    random = np.random.default_rng(0).integers(0, 256, size=(*shape, 4), dtype=np.uint8)
    return {
        "shell": (shell, smooth),
        "all_colour_smooth": (everywhere, smooth),
        "all_colour_random": (everywhere, random),
    }


def summary(details: dict[str, Any]) -> list[dict[str, Any]]:
    return [
        {
            "slab": name,
            "halftone": kind,
            "seconds": details[name][kind]["seconds"],
            "cpu_seconds": details[name][kind]["cpu_seconds"],
            "voxels_per_s": details[name][kind]["voxels_per_s"],
            "colour_voxels_per_s": details[name][kind]["colour_voxels_per_s"],
        }
        for name in ("shell", "all_colour_smooth", "all_colour_random")
        if name in details
        for kind in ("blue-noise", "error-diffusion")
    ]


def main() -> None:
    args = parser(__doc__).parse_args()
    shape = (4, 512, 512) if args.quick else SHAPE
    profile = load_profile("j750")
    results: dict[str, Any] = {"slab_shape_zyx": shape, "n_voxels": int(np.prod(shape))}
    results["load_average_1min_at_start"] = load_average()[0]
    results["cpus"] = os.cpu_count()
    start = time.perf_counter()
    plans = {
        kind: build_material_plan(
            profile, MaterialSettings(halftone=kind), colour_layers=(1,), n_bands=2
        )
        for kind in ("blue-noise", "error-diffusion")
    }
    results["plan_build_s"] = round(time.perf_counter() - start, 3)
    tiny = np.ones((2, 4, 4), np.uint8), np.zeros((2, 4, 4, 4), np.uint8)
    start = time.perf_counter()
    for plan in plans.values():
        materials_for_slab(*tiny, 0, plan)
    results["first_call_compile_s"] = round(time.perf_counter() - start, 3)
    for name, (layers, rgba) in slabs(shape).items():
        entry: dict[str, Any] = {"colour_voxels": int(np.count_nonzero(layers == 1))}
        for kind, plan in plans.items():
            times, cpu_times = [], []
            for _ in range(3 if kind == "blue-noise" else 1):
                start, cpu_start = time.perf_counter(), time.process_time()
                materials_for_slab(layers, rgba, 0, plan)
                times.append(time.perf_counter() - start)
                cpu_times.append(time.process_time() - cpu_start)
            best = min(times)
            entry[kind] = {
                "seconds": round(best, 3),
                "cpu_seconds": round(min(cpu_times), 3),
                "voxels_per_s": round(layers.size / best),
                "colour_voxels_per_s": round(entry["colour_voxels"] / best),
            }
        results[name] = entry
        print(name, json.dumps(entry))
    print(f"plan build {results['plan_build_s']} s, compile {results['first_call_compile_s']} s")
    path = write_result(
        NAME, {"what": WHAT, "summary": summary(results), "details": results}, quick=args.quick
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
