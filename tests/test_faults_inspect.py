"""``inspect`` on corrupted output folders (issue 9, 3 and 7): one line, exit 2, no hang.

One real build is made once; each case copies it, breaks one thing, and runs
``shellvox inspect`` as a process with a timeout (a FIFO in place of a file must not
block it).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil

import pytest
from fault_harness import assert_failed, assert_succeeded, build_argv, run


@pytest.fixture(scope="module")
def build(tmp_path_factory):
    root = tmp_path_factory.mktemp("inspect")
    out = root / "build"
    assert_succeeded(run(build_argv(out), root / "run"), out)
    return out


@pytest.fixture
def folder(build, tmp_path):
    copy = tmp_path / "build"
    shutil.copytree(build, copy)
    return copy


def _manifest(folder):
    return json.loads((folder / "manifest.json").read_text())


def _rewrite(folder, change):
    manifest = _manifest(folder)
    change(manifest)
    (folder / "manifest.json").write_text(json.dumps(manifest))


def _truncate(path, fraction=0.5):
    data = path.read_bytes()
    path.write_bytes(data[: int(len(data) * fraction)])


def _flip_byte(path):
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0xFF
    path.write_bytes(bytes(data))


def _fifo(path):
    path.unlink()
    os.mkfifo(path)


def _outside(folder):
    (folder.parent / "x").write_text("outside")
    _rewrite(folder, lambda m: m["files"].update({"../x": {"bytes": 7, "sha256": "0" * 64}}))


def _symlink_out(folder):
    (folder / "layers.tif").unlink()
    (folder / "layers.tif").symlink_to("/etc/hostname")


def _garbage_listed(folder):
    # Not a TIFF, but listed with its true size and checksum: verification passes, reading fails.
    data = b"II*\0" + bytes(range(256)) * 40
    (folder / "colour.tif").write_bytes(data)
    record = {"bytes": len(data), "sha256": hashlib.sha256(data).hexdigest()}
    _rewrite(folder, lambda m: m["files"].update({"colour.tif": record}))


def _del(key):
    return lambda m: m.pop(key)


CASES = {
    "empty manifest": (lambda f: (f / "manifest.json").write_bytes(b""), "not valid JSON"),
    "malformed JSON": (lambda f: (f / "manifest.json").write_text('{"grid": '), "not valid JSON"),
    "manifest not UTF-8": (lambda f: (f / "manifest.json").write_bytes(b"\xff\xfe{"), "JSON"),
    "manifest a list": (lambda f: (f / "manifest.json").write_text("[]"), "not a shellvox"),
    "manifest without files": (lambda f: _rewrite(f, _del("files")), "not a shellvox"),
    "manifest listing no files": (
        lambda f: _rewrite(f, lambda m: m.update(files={})),
        "layers.tif",
    ),
    "manifest a FIFO": (lambda f: _fifo(f / "manifest.json"), "manifest.json"),
    "missing manifest": (lambda f: (f / "manifest.json").unlink(), "no manifest.json"),
    "missing TIFF": (lambda f: (f / "layers.tif").unlink(), "layers.tif: is missing"),
    "truncated TIFF": (lambda f: _truncate(f / "colour.tif"), "colour.tif: has"),
    "changed TIFF": (lambda f: _flip_byte(f / "layers.tif"), "SHA-256"),
    "truncated VDB": (lambda f: _truncate(f / "volume.vdb", 0.9), "volume.vdb: has"),
    "TIFF a FIFO": (lambda f: _fifo(f / "layers.tif"), "not a regular file"),
    "TIFF a folder": (
        lambda f: ((f / "layers.tif").unlink(), (f / "layers.tif").mkdir()),
        "not a regular file",
    ),
    "TIFF a link out of the folder": (_symlink_out, "outside the folder"),
    "listing ../x": (_outside, "outside the folder"),
    "listing an absolute path": (
        lambda f: _rewrite(f, lambda m: m["files"].update({"/etc/hostname": {"bytes": 1}})),
        "outside the folder",
    ),
    "record not a dict": (
        lambda f: _rewrite(f, lambda m: m["files"].update({"layers.tif": 5})),
        "layers.tif",
    ),
    "TIFF garbage, listed": (_garbage_listed, "cannot be read"),
    "grid edited": (
        lambda f: _rewrite(f, lambda m: m["grid"].update(shape_zyx=[10**9, 10**9, 10**9])),
        "cannot be read",
    ),
    "grid not numbers": (
        lambda f: _rewrite(f, lambda m: m["grid"].update(shape_zyx="big")),
        "manifest.json",
    ),
}


@pytest.mark.parametrize("case", list(CASES))
def test_corrupted_folder(folder, tmp_path, case):
    corrupt, needle = CASES[case]
    corrupt(folder)
    # within 2 GB of address space: a refusal must not allocate the grid it refuses
    result = run(["inspect", str(folder)], tmp_path / "run", timeout=60, rlimit_as=2 << 30)
    assert_failed(result, 2, needle, "rebuild", folder=folder)


def test_intact_folder_verifies(folder, tmp_path):
    result = run(["inspect", str(folder)], tmp_path / "run", timeout=60)
    assert_succeeded(result, folder)
    files = _manifest(folder)["files"]
    outside = [name for name in files if not name.startswith("stack.ome.zarr/")]
    # one row a file, the store's files summed up in one row
    assert result.stdout.count("verified") == len(outside) + (len(outside) < len(files))
