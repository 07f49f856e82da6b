"""Slabs on a Dask LocalCluster give the same files as one process (issue 14)."""

from __future__ import annotations

import json
import os
import signal
from pathlib import Path

import psutil
import pytest
from build_compare import differences, manifest_core, output_digests
from fault_harness import wait_for
from tray_models import tray_models

from shellvox.cli import main
from shellvox.testing import Command

MODEL = Path(__file__).resolve().parents[2] / "data" / "colour_target" / "colour_target.obj"
OPTIONS = ["--voxel-size", "0.2,0.2,0.15", "--thickness", "0.5,0.5", "--no-shell-meshes",
           "--slab-mb", "1", "--no-progress"]  # fmt: skip

#: The inputs of each case: one model, and a tray of three (texture, vertex, face colour).
INPUTS = [
    pytest.param(lambda folder: [MODEL], id="one-model"),
    pytest.param(tray_models, id="three-model-tray"),
]


@pytest.mark.slow
@pytest.mark.parametrize("inputs", INPUTS)
def test_local_cluster_of_two_gives_the_single_process_build(tmp_path, inputs):
    single, cluster = tmp_path / "single", tmp_path / "cluster"
    files = [str(path) for path in inputs(tmp_path)]
    assert main(["build", *files, "-o", str(single), *OPTIONS, "--workers", "1"]) == 0
    argv = ["build", *files, "-o", str(cluster), *OPTIONS, "--workers", "2", "--scheduler", "local"]
    assert main(argv) == 0
    single_digests = output_digests(single)
    assert {"layers.tif", "colour.tif", "materials.tif", "volume.vdb"} <= set(single_digests)
    assert output_digests(cluster) == single_digests
    assert differences(manifest_core(cluster), manifest_core(single)) == []
    run = json.loads((cluster / "manifest.json").read_text())["run"]
    assert run["scheduler"] == "local" and run["slabs"] >= 4  # several slabs
    assert not (cluster / ".shellvox-run").exists()  # checkpoints go when the build commits


@pytest.mark.slow
def test_a_dask_worker_killed_mid_build_is_replaced_and_the_files_are_the_same(tmp_path):
    """A worker process SIGKILLed (the OOM killer, a lost node): its nanny starts another,
    Dask runs the lost slab again, and the build writes the files of one process."""
    single, cluster = tmp_path / "single", tmp_path / "cluster"
    many = [*OPTIONS, "--voxel-size", "0.1,0.1,0.08", "--slab-mb", "2", "--checkpoint"]
    assert main(["build", str(MODEL), "-o", str(single), *many, "--workers", "1"]) == 0
    argv = ["build", str(MODEL), "-o", str(cluster), *many, "--workers", "2"]
    command = Command([*argv, "--scheduler", "local"], tmp_path / "run")
    chunks = cluster / ".shellvox-run"
    wait_for(lambda: any(chunks.glob("slab_*.npz")), what="a slab from the cluster")
    workers = [p for p in psutil.Process(command.pid).children(recursive=True) if _dask_worker(p)]
    assert len(workers) == 2, [p.cmdline() for p in workers]
    assert not (cluster / "manifest.json").exists()  # killed mid-build
    os.kill(workers[0].pid, signal.SIGKILL)
    result = command.finish(timeout=300)
    assert result.status == 0, result.stderr
    assert output_digests(cluster) == output_digests(single)
    assert differences(manifest_core(cluster), manifest_core(single)) == []


def _dask_worker(process: psutil.Process) -> bool:
    """A LocalCluster's worker process (spawned by its nanny), not a helper."""
    try:
        line = " ".join(process.cmdline())
    except psutil.Error:
        return False
    return "multiprocessing.spawn" in line or "spawn_main" in line


def test_an_unreachable_scheduler_is_one_line_and_status_2(tmp_path, monkeypatch, capsys):
    import shellvox.run._cluster as slab_dask

    monkeypatch.setattr(slab_dask, "CONNECT_S", 2.0)
    argv = ["build", str(MODEL), "-o", str(tmp_path / "out"), *OPTIONS,
            "--scheduler", "tcp://127.0.0.1:9"]  # fmt: skip
    assert main(argv) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines[-1].startswith("shellvox: error: --scheduler: cannot use the Dask scheduler")
    assert not any(p.is_file() for p in (tmp_path / "out").rglob("*"))


def _slab_job():
    """A small one-model slab job and rows of it that cut the colour layer."""
    import numpy as np

    from shellvox.config import LoadOptions
    from shellvox.loading import load_model
    from shellvox.run import SlabJob
    from shellvox.voxel.geometry import SurfaceIndex
    from shellvox.voxel.grid import GridSpec
    from shellvox.voxel.io.vdb import VdbEncoder
    from shellvox.voxel.slab import StackModel

    mesh = load_model(MODEL, LoadOptions())
    depth = np.cumsum(np.full((2, mesh.n_faces), 0.5), axis=0)
    model = StackModel(
        surfaces=((mesh.vertices, mesh.faces),),
        surface=SurfaceIndex.build(mesh.vertices, mesh.faces),
        colour_at=mesh.colour_at,
        surface_colour=mesh.surface_colour(),
        colour_layers=(1,),
        sdf_half_width_mm=0.3,
        depth_mm=depth,
        layer_rule="distance",
    )
    grid = GridSpec.from_bounds(
        mesh.vertices.min(axis=0), mesh.vertices.max(axis=0), (0.2, 0.2, 0.15), margin_mm=0.3
    )
    vdb = VdbEncoder.for_grid(grid, sdf_half_width_mm=0.3, material_grid=False)
    middle = grid.shape_zyx[0] // 2
    return SlabJob(model, grid, None, vdb), (middle - middle % 8, middle - middle % 8 + 8)


def test_a_pickled_model_gives_bit_identical_slabs():
    """What a Dask worker receives (the model pickled and unpickled, its AABB tree and
    Voronoi regions rebuilt there) computes the same slab as the original."""
    import pickle

    import numpy as np

    job, rows = _slab_job()
    copy = pickle.loads(pickle.dumps(job))
    assert copy.model.surface.tree is not job.model.surface.tree  # rebuilt, not shared
    here, there = job.run(rows), copy.run(rows)
    assert int(here.slab.layer_counts[1]) > 0  # the rows cut the colour layer
    for name in ("layers", "rgba", "sdf", "sdf_band", "layer_counts"):
        np.testing.assert_array_equal(getattr(there.slab, name), getattr(here.slab, name))
    assert [s.stream.getvalue() for s in there.vdb] == [s.stream.getvalue() for s in here.vdb]


@pytest.mark.slow
def test_slabs_of_one_row_in_forked_workers_give_the_single_process_build(tmp_path):
    """Slabs thinner than a VDB leaf row (8 rows), as a full tray's are, in two forked
    workers: the VDB writer must not hold the workers' shared slots while it waits for
    a whole leaf row (it did, and the build hung)."""
    files = [str(path) for path in tray_models(tmp_path)]
    single, forked = tmp_path / "single", tmp_path / "forked"
    assert main(["build", *files, "-o", str(single), *OPTIONS, "--workers", "1"]) == 0
    assert main(["build", *files, "-o", str(forked), *OPTIONS, "--workers", "2"]) == 0
    manifest = json.loads((forked / "manifest.json").read_text())
    assert manifest["slab_rows"] < 8 and manifest["run"]["slabs"] > 8
    assert output_digests(forked) == output_digests(single)
    assert manifest_core(forked) == manifest_core(single)


@pytest.mark.slow
def test_job_slices_encoded_in_workers_give_the_single_process_job(tmp_path):
    """On the printer's grid the build writes job.gcvf: its slices, encoded in forked
    workers (with the TIFF pages; a Dask worker runs the same task, and chunks carry the
    pages, see test_tiff_pages), equal the writer's own."""
    box = tray_models(tmp_path)[2]
    options = ["--thickness", "0.3,0.3", "--scale", "0.5", "--slab-mb", "1", "--no-progress",
               "--no-checkpoint"]  # fmt: skip
    builds = {}
    for name, extra in (
        ("single", ["--workers", "1"]),
        ("forked", ["--workers", "2"]),
    ):
        builds[name] = tmp_path / name
        assert main(["build", str(box), "-o", str(builds[name]), *options, *extra]) == 0
    digests = {name: output_digests(folder) for name, folder in builds.items()}
    assert "job.gcvf" in digests["single"]
    assert digests["forked"] == digests["single"]
    manifest = json.loads((builds["forked"] / "manifest.json").read_text())
    assert manifest["run"]["slabs"] >= 4
