"""Per-voxel cost of materials_for_slab on a 64 x 512 x 512 slab (J750 profile).

Usage: .venv/bin/python benchmarks/bench_materials.py
       [--out benchmarks/results/bench_materials.json]

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
blue-noise tile) and compiling the kernels (numba, cached on disk afterwards).
A benchmark, not a test.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from shellvox.config import MaterialSettings
from shellvox.printer import build_material_plan, load_profile
from shellvox.voxel.colour import materials_for_slab

ROOT = Path(__file__).resolve().parents[1]
SHAPE = (64, 512, 512)


def slabs() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    z, y, x = np.ogrid[: SHAPE[0], : SHAPE[1], : SHAPE[2]]
    radius = np.hypot(y - 256.0, x - 256.0) + 0 * z
    hue = np.arctan2(y - 256.0, x - 256.0) + 0 * z
    smooth = np.empty((*SHAPE, 4), dtype=np.uint8)
    for channel, phase in enumerate((0.0, 2.1, 4.2)):
        smooth[..., channel] = (127.5 + 127.5 * np.cos(hue + phase + z / 40.0)).astype(np.uint8)
    smooth[..., 3] = 255
    shell = np.zeros(SHAPE, dtype=np.uint8)
    shell[radius < 250] = 3
    shell[(radius < 250) & (radius >= 226)] = 2
    shell[(radius < 250) & (radius >= 238)] = 1
    everywhere = np.ones(SHAPE, dtype=np.uint8)
    random = np.random.default_rng(0).integers(0, 256, size=(*SHAPE, 4), dtype=np.uint8)
    return {
        "shell": (shell, smooth),
        "all_colour_smooth": (everywhere, smooth),
        "all_colour_random": (everywhere, random),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    default = ROOT / "benchmarks" / "results" / "bench_materials.json"
    parser.add_argument("--out", type=Path, default=default)
    args = parser.parse_args()
    profile = load_profile("j750")
    results: dict[str, Any] = {"slab_shape_zyx": SHAPE, "n_voxels": int(np.prod(SHAPE))}
    results["load_average_1min_at_start"] = round(os.getloadavg()[0], 2)
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
    for name, (layers, rgba) in slabs().items():
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
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(results, indent=2) + "\n")


if __name__ == "__main__":
    main()
