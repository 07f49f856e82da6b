"""Randomly damaged files (fixed seeds) load, or end in an InputError: never another error.

Byte-level damage (flipped, deleted and inserted bytes, absurd numbers) of a valid file
of every format with colour, and value-level damage of a glTF document's JSON tree.
"""

from __future__ import annotations

import random
import warnings

import numpy as np
import pytest
from builders import CORNER_UV, glb_bytes, gltf_parts, write_3mf
from corpus_files import IMAGE, TEX, obj_text, ply_text, write_gltf

from shellvox.errors import InputError
from shellvox.loading import load_model

INSERTS = [b"1e300", b"-", b"nan", b"999999999", b'"', b"{", b"[", b"../", b"\t", b" ", b"0"]
VALUES = ["x", -1, 0, 7, 10**12, 2.5, None, [], {}, [1, 2], {"index": 0}, True, "../x.png"]


def _glb_document():
    document, binary = gltf_parts(image={}, factor=[0.5, 0.5, 0.5, 1])
    document["bufferViews"].append({"buffer": 0, "byteOffset": len(binary), "byteLength": len(TEX)})
    binary += TEX + b"\0" * (-len(TEX) % 4)
    document["buffers"][0]["byteLength"] = len(binary)
    document["images"] = [{"bufferView": 3, "mimeType": "image/png"}]
    document["samplers"] = [{"wrapS": 33071}]
    document["textures"][0]["sampler"] = 0
    return document, binary


def _write(kind, folder):
    """A valid coloured model; returns (model, file to damage)."""
    if kind == "glb":
        (folder / "m.glb").write_bytes(glb_bytes(*_glb_document()))
        return folder / "m.glb", folder / "m.glb"
    if kind == "gltf":
        model = write_gltf(folder, *gltf_parts(image={"uri": "tex.png"}))
        (folder / "tex.png").write_bytes(TEX)
        return model, model
    if kind in ("obj", "mtl"):
        (folder / "m.obj").write_text(obj_text())
        (folder / "model.mtl").write_text("newmtl painted\nKd 1 0 0\nd 0.5\nmap_Kd tex.png\n")
        (folder / "tex.png").write_bytes(TEX)
        return folder / "m.obj", folder / ("m.obj" if kind == "obj" else "model.mtl")
    if kind == "ply":
        (folder / "m.ply").write_text(ply_text(texture_file="tex.png"))
        (folder / "tex.png").write_bytes(TEX)
        return folder / "m.ply", folder / "m.ply"
    write_3mf(folder / "m.3mf", texture=IMAGE, corner_uv=CORNER_UV)
    return folder / "m.3mf", folder / "m.3mf"


def _damage(data: bytes, rng: random.Random) -> bytes:
    out = bytearray(data)
    for _ in range(rng.choice([1, 2, 5, 20])):
        at = rng.randrange(max(len(out), 1))
        kind = rng.random()
        if kind < 0.5 and at < len(out):
            out[at] = rng.randrange(256)
        elif kind < 0.7:
            del out[at : at + rng.randrange(1, 50)]
        else:
            out[at:at] = rng.choice(INSERTS)
    return bytes(out)


def _loads_or_refuses(model):
    message = ""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # ShellvoxWarnings are fine here
        try:
            load_model(model)
        except InputError as error:  # any other exception fails the test
            message = str(error)
    assert "\n" not in message


@pytest.mark.parametrize("kind", ["obj", "mtl", "ply", "glb", "gltf", "3mf"])
def test_damaged_bytes(tmp_path, kind):
    rng = random.Random(kind)
    for trial in range(25):
        folder = tmp_path / str(trial)
        folder.mkdir()
        model, target = _write(kind, folder)
        target.write_bytes(_damage(target.read_bytes(), rng))
        _loads_or_refuses(model)


def _nodes(node, prefix=()):
    if prefix:
        yield prefix
    if isinstance(node, dict):
        for key, child in node.items():
            yield from _nodes(child, (*prefix, key))
    elif isinstance(node, list):
        for key, child in enumerate(node):
            yield from _nodes(child, (*prefix, key))


def test_damaged_gltf_documents(tmp_path):
    rng = np.random.default_rng(5)
    for trial in range(60):
        document, binary = _glb_document()
        for _ in range(int(rng.integers(1, 4))):
            paths = list(_nodes(document))
            path = paths[int(rng.integers(len(paths)))]
            parent = document
            for key in path[:-1]:
                parent = parent[key]
            parent[path[-1]] = VALUES[int(rng.integers(len(VALUES)))]
        model = tmp_path / f"{trial}.glb"
        model.write_bytes(glb_bytes(document, binary))
        _loads_or_refuses(model)
