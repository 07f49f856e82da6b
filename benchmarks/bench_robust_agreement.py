"""Field shells against the robust ones: volume and Hausdorff distance, spot at 100 mm.

Usage: .venv/bin/python benchmarks/bench_robust_agreement.py
       [--out benchmarks/results/bench_field_shells.json] [--key robust_agreement_spot94k]

``shellvox shells`` of spot with two Loop subdivisions (93,696 faces) at 100 mm, layers
0.5 + 1.0 mm, by the default method (``field``) and by ``--method robust`` (minutes), each a
child process; the files are read back with trimesh and compared per layer: volumes, and
distances (libigl's exact point-to-surface distance, :mod:`shellvox.voxel.geometry._nearest`) from
200,000 area-weighted samples and every vertex of each shell to the other, both ways
(p50, p99, max; the Hausdorff distance is the larger maximum). Merged into the results
JSON under ``--key``. A benchmark, not a test.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from shellvox.voxel.geometry._nearest import SurfaceIndex, distance_to_surface

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
from bench_field_shells import run_shells  # noqa: E402
from bench_offset import load_shared  # noqa: E402


def _distances(source: trimesh.Trimesh, target: trimesh.Trimesh) -> dict[str, float]:
    """Return p50, p99 and max of the distance from `source`'s points to `target` (mm)."""
    points = np.concatenate([source.sample(200_000, seed=0), source.vertices])
    index = SurfaceIndex.build(np.asarray(target.vertices), np.asarray(target.faces, np.int64))
    distance = distance_to_surface(index, np.asarray(points, dtype=np.float64))
    return {
        "p50": float(np.percentile(distance, 50)),
        "p99": float(np.percentile(distance, 99)),
        "max": float(distance.max()),
    }


def agreement(work: Path) -> dict[str, Any]:
    """Run both methods on spot at 100 mm and compare their shells layer by layer."""
    mesh = load_shared("spot/spot_triangulated.obj", 100.0, subdivisions=2)
    model = work / "spot94k.ply"
    mesh.export(model)
    seconds = {
        method: run_shells(model, work / method, ["--method", method])
        for method in ("field", "robust")
    }
    result: dict[str, Any] = {"command_s": seconds}
    for layer in (1, 2):
        field, robust = (
            trimesh.load(work / method / f"shell_{layer}.ply", process=False, force="mesh")
            for method in ("field", "robust")
        )
        there, back = _distances(field, robust), _distances(robust, field)
        result[f"shell_{layer}"] = {
            "faces": [len(field.faces), len(robust.faces)],
            "volume_mm3": [float(field.volume), float(robust.volume)],
            "volume_rel_diff": float(field.volume / robust.volume - 1.0),
            "field_to_robust_mm": there,
            "robust_to_field_mm": back,
            "hausdorff_mm": max(there["max"], back["max"]),
        }
    return result


def main() -> None:
    """Measure and merge the result into the JSON results."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--out", type=Path, default=ROOT / "benchmarks/results/bench_field_shells.json"
    )
    parser.add_argument("--key", default="robust_agreement_spot94k")
    args = parser.parse_args()
    results = json.loads(args.out.read_text()) if args.out.is_file() else {}
    with tempfile.TemporaryDirectory() as tmp:
        results[args.key] = agreement(Path(tmp))
    args.out.write_text(json.dumps(results, indent=1))
    print(json.dumps(results[args.key], indent=1))


if __name__ == "__main__":
    main()
