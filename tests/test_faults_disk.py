"""Out of disk space and read-only output folders (issue 9, 1 and 7): exit 3, one line.

Both need a file system of their own: a 2 MB tmpfs fills up for real (ENOSPC), and a
read-only mount refuses writes even to root (``chmod 0555`` does not stop root). Mounting
needs root; the tests skip, saying why, where it is not permitted.
"""

from __future__ import annotations

import shutil
import subprocess

import pytest
from fault_harness import assert_failed, assert_succeeded, build_argv, run

from shellvox.testing import holds_nothing, verified_files


@pytest.fixture
def tmpfs(tmp_path):
    """Return a function mounting a tmpfs of a given size at a new folder (unmounted after)."""
    mounted = []

    def mount(name: str, size: str = "2m") -> object:
        point = tmp_path / name
        point.mkdir()
        if shutil.which("mount") is None:
            pytest.skip("no mount command: ENOSPC and read-only folders need a tmpfs")
        done = subprocess.run(
            ["mount", "-t", "tmpfs", "-o", f"size={size},mode=0755", "tmpfs", str(point)],
            capture_output=True,
            text=True,
        )
        if done.returncode != 0:
            pytest.skip(f"cannot mount a tmpfs here (needs root): {done.stderr.strip()}")
        mounted.append(point)
        return point

    yield mount
    for point in reversed(mounted):
        subprocess.run(["umount", "-l", str(point)], check=False)


def _read_only(point) -> None:
    subprocess.run(["mount", "-o", "remount,ro", str(point)], check=True)


def test_out_of_space_mid_build(tmp_path, tmpfs):
    # The outputs (~5.5 MB, the VDB spool and file most of it) do not fit in 2 MB;
    # --force skips the up-front disk estimate, so the build meets ENOSPC for real.
    disk = tmpfs("disk", "2m")
    (disk / "keep.bin").write_bytes(b"\1" * 100_000)  # the user's: must stay
    out = disk / "out"
    result = run(build_argv(out, "--force"), tmp_path / "run")
    assert_failed(result, 3, "No space left", "free some space", folder=out)
    assert holds_nothing(out)
    assert (disk / "keep.bin").read_bytes() == b"\1" * 100_000


def test_out_of_space_refused_up_front(tmp_path, tmpfs):
    disk = tmpfs("disk", "2m")
    out = disk / "out"
    result = run(build_argv(out), tmp_path / "run")
    assert_failed(result, 2, "disk has", "--force")
    assert not out.exists()


def test_dry_run_on_a_full_disk_says_the_build_would_stop(tmp_path, tmpfs):
    # The estimate is the dry run's answer, so the shortfall is printed, not raised.
    disk = tmpfs("disk", "2m")
    out = disk / "out"
    result = run(build_argv(out, "--dry-run"), tmp_path / "run")
    assert result.status == 0, result.stderr
    (line,) = [ln for ln in result.stdout.splitlines() if ln.startswith("a build would stop")]
    assert "disk has" in line and str(out) in line and "--force" in line
    assert not out.exists()


def test_out_of_space_while_replacing_an_old_build(tmp_path, tmpfs):
    # A rebuild that cannot fit fails cleanly: the folder then holds no build (the old
    # one went when the new one started), never a mix.
    disk = tmpfs("disk", "16m")  # the first build (~7.5 MB) and its VDB spool must fit
    out = disk / "out"
    assert_succeeded(run(build_argv(out), tmp_path / "first"), out)
    verified_files(out)
    (disk / "filler.bin").write_bytes(b"\0" * (shutil.disk_usage(disk).free - 1_000_000))
    result = run(build_argv(out, "--force", "--voxel-size", "0.08"), tmp_path / "second")
    assert_failed(result, 3, "No space left", folder=out)
    assert holds_nothing(out)


def test_read_only_folder_with_an_old_build(tmp_path, tmpfs):
    disk = tmpfs("disk", "24m")
    out = disk / "out"
    assert_succeeded(run(build_argv(out), tmp_path / "first"), out)
    before = verified_files(out)
    _read_only(disk)
    result = run(build_argv(out, "--thickness", "0.4,0.4"), tmp_path / "second")
    assert_failed(result, 3, "Read-only file system", "-o DIR")
    assert verified_files(out) == before  # untouched


def test_read_only_parent_folder(tmp_path, tmpfs):
    disk = tmpfs("disk", "16m")
    _read_only(disk)
    out = disk / "new" / "out"
    result = run(build_argv(out), tmp_path / "run")
    assert_failed(result, 3, "Read-only file system")
    assert not (disk / "new").exists()


def test_inspect_without_previews_reads_a_read_only_folder(tmp_path, tmpfs):
    # Verifying a build kept on a read-only medium needs no write.
    disk = tmpfs("disk", "16m")
    out = disk / "out"
    assert_succeeded(run(build_argv(out), tmp_path / "first"), out)
    _read_only(disk)
    result = run(["inspect", str(out), "--no-preview"], tmp_path / "inspect")
    assert_succeeded(result, out)
    assert "layers.tif" in result.stdout and "verified" in result.stdout
    with_previews = run(["inspect", str(out)], tmp_path / "previews")
    assert_failed(with_previews, 3, "Read-only file system")


def test_a_disk_error_without_its_text_is_named_by_its_number():
    # A writer may raise an OSError that carries an errno but no strerror (a library
    # building its own, or a thread's error re-raised): the line names the errno's text.
    import errno
    import os

    from shellvox.faults import EXIT_DISK, describe

    error = OSError(errno.ENOSPC, "No space left on device", "out/layers.tif")
    error.strerror = None
    wrapped = RuntimeError("writer thread failed")
    wrapped.__cause__ = error
    status, line = describe(wrapped)
    assert status == EXIT_DISK
    assert line.startswith(f"out/layers.tif: cannot write ({os.strerror(errno.ENOSPC)})")
    assert "<function" not in line
    assert len(line.splitlines()) == 1
