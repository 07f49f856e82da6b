"""Which part of a build a py-spy sample belongs to (``bench_materials_build.py profile``)."""

from __future__ import annotations

import collections
import re
from pathlib import Path
from typing import Any

#: Parts of a build recognised in a py-spy sample, by a substring of a frame; the
#: innermost frame that matches one decides (so "numba" inside the halftone is numba).
CATEGORIES = (
    ("numba compile / cache load", ("(numba/", "numba/core", "numba/")),
    ("halftone kernel (materials_for_slab)", ("materials_for_slab (",)),
    ("gcvf: PNG encode (keys + zlib)", ("GcvfWriter._encode (",)),
    ("gcvf: zip write", ("GcvfWriter._add (",)),
    ("gcvf: key counts (write_slab)", ("GcvfWriter.write_slab (",)),
    ("gcvf: other", ("gcvf_writer.py", "gcvf_job.py")),
    ("png slices: colour_slices", ("StackOutputs.colour_slices (",)),
    ("png slices: writer", ("png_slices.py", "slab_thread.py")),
    ("colour report: add_slab", ("ModelReport.add_slab (",)),
    ("colour report: result + thickness_effect", ("ColourCheck.result (",)),
    ("colour report: sample_surface + init", ("ColourCheck.__init__ (",)),
    ("material tally (Tally.add)", ("Tally.add (",)),
    ("material plan build", ("build_material_plan (",)),
    ("tiff writers (layers/colour/materials.tif)", ("tiff_writer.py", "tifffile")),
    # voxel/io/vdb/ since the layout of issue 23; the old names for the saved profiles
    ("vdb writer", ("io/vdb/", "vdb_writer.py", "vdb_encode.py", "vdb_leaves.py", "vdb_format.py")),
    ("compute_slab (voxels)", ("compute_slab (",)),
    ("outputs.finish other", ("StackOutputs.finish (",)),
    ("thickness rule", ("choose_thickness (",)),
    ("load / scale model", ("scaled_model (", "load_model (")),
    ("imports", ("_find_and_load (",)),
)


def categorise(frames: list[str]) -> str:
    for frame in reversed(frames):  # leaf first
        for name, patterns in CATEGORIES:
            if any(p in frame for p in patterns):
                return name
    return "other: " + (frames[-1].split(" (")[0] if frames else "?")


def parse_raw(path: Path, rate: int) -> dict[str, Any]:
    """Samples per category and per thread role from a py-spy raw file, as seconds.

    A sample counts a thread that was running or runnable: on a machine shared with
    other jobs that is more than its CPU time (the totals say how much more).
    """
    text = path.read_text()
    per_category: collections.Counter[str] = collections.Counter()
    roles: dict[str, collections.Counter[str]] = collections.defaultdict(collections.Counter)
    pids: set[str] = set()
    # 'process PID:"cmd";[process CHILD:"cmd";]thread (TID): NAME;frame;frame;... COUNT'
    pattern = re.compile(r'^((?:process \d+:"[^"]*";)+)thread \((\d+)\)([^;]*);(.*) (\d+)$')
    for line in text.splitlines():
        match = pattern.match(line)
        if match is None:
            continue
        chain, tid, name, stack, count = match.groups()
        chain_pids = re.findall(r"process (\d+):", chain)
        pids.update(chain_pids)
        category = categorise(stack.split(";"))
        per_category[category] += int(count)
        if len(chain_pids) > 1:
            role = "slab workers"
        elif "MainThread" in name or tid == chain_pids[0]:
            role = "main thread"
        else:
            role = "main process, other threads"
        roles[role][category] += int(count)
    return {
        "sampled_s_by_part": {k: round(v / rate, 1) for k, v in per_category.most_common()},
        "sampled_s_total": round(sum(per_category.values()) / rate, 1),
        "sampled_s_by_role": {
            role: {k: round(v / rate, 1) for k, v in counter.most_common()}
            for role, counter in roles.items()
        },
        "processes_sampled": len(pids),
    }
