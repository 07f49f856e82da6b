"""An output folder holds one build or none (issue 9, 3 and 7): rebuilds and concurrent runs."""

from __future__ import annotations

import hashlib
import json
import os
import signal

import pytest
from fault_harness import assert_failed, assert_succeeded, build_argv, run, wait_for

from shellvox.testing import Command, verified_files


@pytest.mark.parametrize(
    "shells",
    [pytest.param(False, id="no-shells"), pytest.param(True, id="shells", marks=pytest.mark.slow)],
)
def test_rebuild_with_other_options_replaces_the_old_build(tmp_path, shells):
    out = tmp_path / "out"
    # Old: three layers, VDB (and the shell meshes: ~20 s); then inspect adds previews.
    extra = ["--shell-meshes"] if shells else []
    old = run(build_argv(out, "--thickness", "0.5,0.5,0.5", *extra), tmp_path / "a")
    assert_succeeded(old, out)
    assert_succeeded(run(["inspect", str(out)], tmp_path / "inspect"), out)
    old_files = {p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()}
    assert {"volume.vdb", "materials.tif", "preview/section_xy.png"} <= old_files
    assert "stack.ome.zarr/labels/materials/zarr.json" in old_files
    assert ("shells/shell_3.ply" in old_files) == shells
    (out / "notes.txt").write_text("mine")  # not shellvox's: stays
    # New: two layers, no VDB, no materials, no shell meshes.
    new = run(
        build_argv(out, "--thickness", "0.4,0.4", "--no-vdb", "--no-materials"), tmp_path / "b"
    )
    assert_succeeded(new, out)
    manifest = verified_files(out, extra=("notes.txt",))  # every file listed, checksums
    store = {name for name in manifest["files"] if name.startswith("stack.ome.zarr/")}
    assert set(manifest["files"]) - store == {"layers.tif", "colour.tif"}
    # the store of the new build: no materials image left of the old one's
    assert "stack.ome.zarr/labels/layers/zarr.json" in store
    assert not any(name.startswith("stack.ome.zarr/labels/materials") for name in store)
    assert manifest["config"]["thickness_mm"] == [0.4, 0.4]
    # No folder of the old build is left either (shells/, preview/).
    assert sorted(p.name for p in out.iterdir()) == [
        "colour.tif",
        "layers.tif",
        "manifest.json",
        "notes.txt",
        "stack.ome.zarr",
    ]
    # The new manifest describes the new files, byte for byte (not stale records).
    for name in ("layers.tif", "colour.tif"):
        digest = hashlib.sha256((out / name).read_bytes()).hexdigest()
        assert json.loads((out / "manifest.json").read_text())["files"][name]["sha256"] == digest
    assert_succeeded(run(["inspect", str(out), "--no-preview"], tmp_path / "check"), out)


def test_concurrent_builds_into_one_folder(tmp_path):
    # The first build holds the folder; it is stopped (SIGSTOP) while it does, so the
    # second build and inspect surely meet it. Both are refused at once; the first, let
    # go on, completes intact.
    out = tmp_path / "out"
    first = Command(build_argv(out, "--thickness", "0.5,0.5"), tmp_path / "first")
    wait_for(lambda: len(first.workers()) == 2, what="the first build's slab workers")
    os.killpg(first.pid, signal.SIGSTOP)
    try:
        assert (out / ".shellvox.lock").is_file()
        second = run(build_argv(out, "--thickness", "0.3,0.3"), tmp_path / "second")
        line = assert_failed(second, 2, "another shellvox run", f"pid {first.pid}")
        assert str(out) in line
        busy = run(["inspect", str(out)], tmp_path / "inspect")
        assert_failed(busy, 2, "another shellvox run")
    finally:
        os.killpg(first.pid, signal.SIGCONT)
    result = first.finish(timeout=120)
    assert_succeeded(result, out)
    manifest = verified_files(out)
    assert manifest["config"]["thickness_mm"] == [0.5, 0.5]  # the first build's, not mixed


def test_a_signal_while_the_folder_is_locked_leaves_no_lock(tmp_path, monkeypatch):
    # SIGINT sent while the lock is taken (held back there) raises as that block closes:
    # the folder is then left without the lock file, and a next run is not refused.
    from shellvox.faults import Interrupted, signals_raise
    from shellvox.output import _outdir

    acquire = _outdir._acquire

    def acquire_then_signal(path):
        fd = acquire(path)
        os.kill(os.getpid(), signal.SIGINT)  # blocked here: delivered as the block closes
        assert (path.parent / _outdir.LOCK_NAME).is_file()
        return fd

    monkeypatch.setattr(_outdir, "_acquire", acquire_then_signal)
    with signals_raise(), pytest.raises(Interrupted), _outdir.OutputFolder(tmp_path / "out"):
        pytest.fail("the block ran although the signal came before it")
    assert list((tmp_path / "out").iterdir()) == []
    monkeypatch.setattr(_outdir, "_acquire", acquire)
    with _outdir.OutputFolder(tmp_path / "out") as folder:
        assert (folder.path / _outdir.LOCK_NAME).is_file()
