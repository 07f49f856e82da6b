"""A killed build resumed with --resume gives the files of an uninterrupted build (issue 14).

Independent truth: an uninterrupted build's files, read back (SHA-256 of every file; see
build_compare)."""

from __future__ import annotations

import json
import os
import signal
from pathlib import Path

import numpy as np
import pytest
from build_compare import differences, manifest_core, output_digests
from fault_harness import MODEL, wait_for

from shellvox.cli import main
from shellvox.faults import Interrupted, describe
from shellvox.run import (
    RUN_FOLDER,
    RunFolder,
    RunSettings,
    _checkpoints,
    checkpoints,
    decode_chunk,
    encode_chunk,
)
from shellvox.testing import Command, temporary_files, verified_files

SMALL = ["--voxel-size", "0.2,0.2,0.15", "--thickness", "0.5,0.5", "--no-shell-meshes",
         "--slab-mb", "8", "--no-progress", "--checkpoint"]  # fmt: skip
#: A build of a few seconds in many slabs of one process, so a kill lands mid-way.
KILLABLE = ["--voxel-size", "0.1,0.1,0.08", "--thickness", "0.5,0.5", "--no-shell-meshes",
            "--slab-mb", "4", "--workers", "1", "--no-progress", "--checkpoint"]  # fmt: skip


def _build(out: Path, *options: str) -> int:
    return main(["build", str(MODEL), "-o", str(out), *options])


def _chunks(out: Path) -> list[Path]:
    return sorted((out / RUN_FOLDER).glob("slab_*.npz"))


@pytest.mark.slow
@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT], ids=["TERM", "INT"])
def test_a_stopped_build_keeps_its_chunks_and_resumes(tmp_path, capsys, signum):
    """A batch system's SIGTERM at its time limit, or Ctrl-C: the finished slabs stay, the
    message says how to continue, and --resume gives the uninterrupted build's files."""
    reference, out = tmp_path / "reference", tmp_path / "out"
    assert _build(reference, *KILLABLE) == 0
    command = Command(["build", str(MODEL), "-o", str(out), *KILLABLE], tmp_path / "run")
    wait_for(lambda: len(_chunks(out)) >= 1, what="a finished slab's chunk")
    os.killpg(command.pid, signum)
    result = command.finish(timeout=60, grace=1.0)
    assert result.status == 128 + signum, result.stderr
    last = result.stderr.strip().splitlines()[-1]
    assert "finished slab(s) are kept" in last and "--resume" in last, last
    assert not (out / "manifest.json").exists()
    assert _chunks(out)
    assert _build(out, *KILLABLE, "--resume") == 0
    assert output_digests(out) == output_digests(reference)
    assert not (out / RUN_FOLDER).exists()


@pytest.mark.slow
def test_sigkilled_build_resumes_to_the_uninterrupted_files(tmp_path, capsys):
    reference, out = tmp_path / "reference", tmp_path / "out"
    assert _build(reference, *KILLABLE) == 0
    command = Command(["build", str(MODEL), "-o", str(out), *KILLABLE], tmp_path / "run")
    wait_for(lambda: len(_chunks(out)) >= 1, what="a finished slab's chunk")
    os.killpg(command.pid, signal.SIGKILL)
    result = command.finish(timeout=60, grace=1.0)
    assert result.status == -signal.SIGKILL, "the build finished before the kill"
    assert not (out / "manifest.json").exists()
    kept = _chunks(out)
    assert kept

    # Other options: refused, naming what changed; the chunks stay.
    capsys.readouterr()
    assert _build(out, *KILLABLE, "--seed", "1", "--resume") == 2
    error = capsys.readouterr().err
    assert "the build options" in error and "differ" in error
    assert _chunks(out) == kept

    assert _build(out, *KILLABLE, "--resume") == 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["run"]["resumed_slabs"] >= len(kept)  # (more may have landed meanwhile)
    assert manifest["run"]["resumed_slabs"] < manifest["run"]["slabs"]
    assert output_digests(out) == output_digests(reference)
    assert differences(manifest_core(out), manifest_core(reference)) == []
    assert temporary_files(out) == [] or all(
        p.name == ".shellvox.lock" for p in temporary_files(out)
    )
    assert not (out / RUN_FOLDER).exists()

    # Resuming a finished build: one clear line, and the build is left as it is.
    capsys.readouterr()
    assert _build(out, *KILLABLE, "--resume") == 2
    assert "holds a finished build" in capsys.readouterr().err
    verified_files(out)


@pytest.mark.parametrize("halftone", ["blue-noise", "error-diffusion"])
def test_resumed_slabs_stream_as_computed_ones(tmp_path, monkeypatch, halftone):
    """Half the slabs read back from their chunks, half computed: the same files (error
    diffusion, which runs in z order in the parent, included)."""
    reference, out = tmp_path / "reference", tmp_path / "out"
    options = [*SMALL, "--halftone", halftone, "--workers", "2"]
    assert _build(reference, *options) == 0
    with monkeypatch.context() as patch:  # as if killed once the manifest was written
        patch.setattr(RunFolder, "remove", lambda self: None)
        assert _build(out, *options) == 0
    chunks = _chunks(out)
    assert len(chunks) >= 4
    for chunk in chunks[1::2]:
        chunk.unlink()
    assert _build(out, *options, "--resume") == 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["run"]["resumed_slabs"] == len(chunks) - len(chunks[1::2])
    assert output_digests(out) == output_digests(reference)
    assert differences(manifest_core(out), manifest_core(reference)) == []


@pytest.mark.slow
def test_resume_of_a_killed_build_without_checkpoints_builds_from_the_start(tmp_path, capsys):
    """A short build (no checkpoints) SIGKILLed, then rerun with --resume: one line says
    there is nothing to resume, the build runs from the start and gives the files of an
    uninterrupted build."""
    reference, out = tmp_path / "reference", tmp_path / "out"
    options = [o for o in KILLABLE if o != "--checkpoint"]
    assert _build(reference, *options) == 0
    command = Command(["build", str(MODEL), "-o", str(out), *options], tmp_path / "run")
    wait_for(lambda: any(".partial" in p.name for p in temporary_files(out)), what="a file")
    os.killpg(command.pid, signal.SIGKILL)
    result = command.finish(timeout=60, grace=1.0)
    assert result.status == -signal.SIGKILL, "the build finished before the kill"
    assert not (out / RUN_FOLDER).exists()
    capsys.readouterr()
    assert _build(out, *options, "--resume") == 0
    warning = [line for line in capsys.readouterr().err.splitlines() if "resume" in line]
    assert len(warning) == 1 and "building from the start" in warning[0], warning
    assert output_digests(out) == output_digests(reference)
    assert differences(manifest_core(out), manifest_core(reference)) == []
    assert not (out / RUN_FOLDER).exists()


def test_resume_in_an_empty_folder_builds_from_the_start(tmp_path, capsys):
    out = tmp_path / "empty"
    assert _build(out, *SMALL, "--resume") == 0
    err = capsys.readouterr().err
    assert "no checkpoints to resume" in err and "building from the start" in err
    assert (out / "manifest.json").is_file()
    assert json.loads((out / "manifest.json").read_text())["run"]["resumed_slabs"] == 0


def test_resumed_slabs_give_the_shell_meshes_of_one_run(tmp_path, monkeypatch):
    """The field shells are meshed from the layer field the slabs keep, which their chunks
    carry: a resumed build's shells are the uninterrupted build's, byte for byte; chunks
    without it (a build that kept none) leave the shells to a scan of their own."""
    options = [*SMALL, "--shell-meshes", "--workers", "2"]
    options.remove("--no-shell-meshes")
    reference, out = tmp_path / "reference", tmp_path / "out"
    assert _build(reference, *options) == 0
    with monkeypatch.context() as patch:  # as if killed once the manifest was written
        patch.setattr(RunFolder, "remove", lambda self: None)
        assert _build(out, *options) == 0
    chunks = _chunks(out)
    assert len(chunks) >= 4
    for chunk in chunks[1::2]:
        chunk.unlink()
    assert _build(out, *options, "--resume") == 0
    assert output_digests(out) == output_digests(reference)
    assert any(name.startswith("shells/") for name in output_digests(out))
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["shell_meshes"]["layer_field_scans"] == 1

    with monkeypatch.context() as patch:
        patch.setattr(RunFolder, "remove", lambda self: None)
        assert _build(out, *options) == 0
    first = _chunks(out)[0]
    done = decode_chunk(first.read_bytes())
    assert done.slab.nodes is not None
    first.write_bytes(encode_chunk(done._replace(slab=done.slab._replace(nodes=None))))
    assert _build(out, *options, "--resume") == 0
    record = json.loads((out / "manifest.json").read_text())["shell_meshes"]
    assert record["layer_field_scans"] == 2 and "resumed" in record["field_source"]
    digests, expected = output_digests(out), output_digests(reference)
    assert {n: d for n, d in digests.items() if not n.startswith("shells/")} == {
        n: d for n, d in expected.items() if not n.startswith("shells/")
    }


def test_a_chunk_decodes_to_the_slab_it_encodes(tmp_path):
    out = tmp_path / "out"
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(RunFolder, "remove", lambda self: None)
        assert _build(out, *SMALL, "--workers", "1") == 0
    for chunk in _chunks(out)[:3]:
        data = chunk.read_bytes()
        done = decode_chunk(data)
        assert encode_chunk(done) == data  # a fixed point: every field came back
        layers = done.slab.layers
        assert layers.shape[0] == done.slab.z_stop - done.slab.z_start
        counts = np.bincount(layers.ravel(), minlength=len(done.slab.layer_counts))
        np.testing.assert_array_equal(counts, done.slab.layer_counts)
    with pytest.raises(ValueError, match="not a slab chunk"):
        decode_chunk(data[: len(data) // 2])


def _chunk_file(run_folder: Path) -> None:
    (run_folder / "slab_0_4.npz").write_bytes(b"a finished slab")


def test_a_signal_while_the_run_folder_is_made_leaves_no_folder(tmp_path, monkeypatch):
    """The signal lands while the journal is written (before any slab): nothing is left."""

    def interrupted(path, text):
        path.write_text(text[:5])  # half a journal
        raise Interrupted(signal.SIGINT)

    monkeypatch.setattr(_checkpoints, "write_text_atomic", interrupted)
    with (
        pytest.raises(Interrupted),
        checkpoints(tmp_path, {"k": "1"}, RunSettings(checkpoint=True)),
    ):
        pytest.fail("the block ran without a journal")
    assert not (tmp_path / RUN_FOLDER).exists()


def _failed_run(tmp_path: Path, body) -> BaseException:
    """Run `body(run)` inside a checkpointing run folder; return what the block raised."""
    try:
        with checkpoints(tmp_path, {"k": "1"}, RunSettings(checkpoint=True)) as run:
            _chunk_file(run.path)
            body(run)
    except BaseException as error:
        return error
    raise AssertionError("the block did not fail")


def _cleanup_fails_under_a_signal(run: RunFolder) -> None:
    try:
        raise Interrupted(signal.SIGINT)
    finally:
        raise ValueError("Can't close the ZIP file while there is an open writing handle")


def _bug(run: RunFolder) -> None:
    raise ValueError("a bug: rerunning fails the same way")


def test_a_cleanup_that_fails_under_a_signal_keeps_the_chunks(tmp_path):
    """A library's cleanup raising while the signal unwinds (zipfile refusing to close an
    archive whose member the signal left open) is still a stop worth resuming."""
    status, line = describe(_failed_run(tmp_path, _cleanup_fails_under_a_signal))
    assert status == 130, line
    assert "1 finished slab(s) are kept" in line and "--resume" in line, line
    assert len(_chunks(tmp_path)) == 1


def test_a_bug_removes_the_chunks(tmp_path):
    status, line = describe(_failed_run(tmp_path, _bug))
    assert status == 1 and "finished slab" not in line, line
    assert not (tmp_path / RUN_FOLDER).exists()
