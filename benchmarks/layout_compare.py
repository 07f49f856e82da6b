"""Compare two output trees of benchmarks/layout_identity.sh file by file.

Every file must be byte-identical, except manifest.json, compared as JSON without its
measured ``seconds`` (the wall times of the stages). The VDB's UUID is a hash of its
content (voxel/io/vdb/), so volume.vdb is compared byte for byte too.

    .venv/bin/python benchmarks/layout_compare.py BEFORE AFTER

Exit status 0 when every file is the same, 1 otherwise.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

TIMINGS = ("seconds",)  # top-level manifest keys that are measured wall times


def manifest(path: Path) -> object:
    data = json.loads(path.read_text())
    for key in TIMINGS:
        data.pop(key, None)
    return data


def main(before: Path, after: Path) -> int:
    names = sorted(
        {p.relative_to(before) for p in before.rglob("*") if p.is_file()}
        | {p.relative_to(after) for p in after.rglob("*") if p.is_file()}
    )
    bad = 0
    for name in names:
        a, b = before / name, after / name
        if not a.exists() or not b.exists():
            print(f"MISSING {name}: before {a.exists()}, after {b.exists()}")
            bad += 1
        elif name.name == "manifest.json":
            same = manifest(a) == manifest(b)
            print(f"{'same' if same else 'DIFFERENT'} {name} (JSON without {TIMINGS})")
            bad += not same
        else:
            same = a.read_bytes() == b.read_bytes()
            print(f"{'same' if same else 'DIFFERENT'} {name} ({a.stat().st_size} bytes)")
            bad += not same
    print(f"{len(names)} files, {bad} different")
    return 1 if bad else 0


if __name__ == "__main__":
    if sys.argv[1:2] in (["-h"], ["--help"]):
        print(__doc__)
        raise SystemExit(0)
    if len(sys.argv) != 3:
        raise SystemExit("usage: python benchmarks/layout_compare.py BEFORE AFTER")
    sys.exit(main(Path(sys.argv[1]), Path(sys.argv[2])))
