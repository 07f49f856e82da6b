"""glTF ``KHR_texture_transform`` and ``TEXCOORD_n`` (n > 0) against hand-computed UVs.

The GLB files are written by the corpus builders (bytes by hand from the glTF spec);
the expected texture coordinates are worked out by hand from the KHR_texture_transform
specification (``uv' = T R S uv`` in glTF's top-left texture space) and converted to
shellvox's bottom-left convention (``v -> 1 - v``).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from builders import (
    TET_FACES,
    TET_VERTICES,
    embed_image,
    glb_bytes,
    gltf_parts,
    locate,
    marker_image,
    png_bytes,
)

from shellvox.cli import main
from shellvox.loading import load_model

IMAGE = marker_image(16, 8, 2, 3)


def _glb(path, *, tex_coord=0, extensions=None, second=None) -> None:
    """The corpus tetrahedron with a texture; ``second`` (12, 2) uint16 is TEXCOORD_1."""
    document, binary = gltf_parts(image={}, tex_coord=tex_coord, texture_extensions=extensions)
    document, binary = embed_image(png_bytes(IMAGE))(document, binary)
    if second is not None:
        blob = np.asarray(second, "<u2").tobytes()
        document["bufferViews"].append(
            {"buffer": 0, "byteOffset": len(binary), "byteLength": len(blob)}
        )
        binary += blob + b"\0" * (-len(blob) % 4)
        document["buffers"][0]["byteLength"] = len(binary)
        document["accessors"].append(
            {
                "bufferView": len(document["bufferViews"]) - 1,
                "componentType": 5123,
                "normalized": True,
                "count": 12,
                "type": "VEC2",
            }
        )
        primitive = document["meshes"][0]["primitives"][0]
        primitive["attributes"]["TEXCOORD_1"] = len(document["accessors"]) - 1
    path.write_bytes(glb_bytes(document, binary))


def _corner_uv(mesh) -> np.ndarray:
    """UVs ``(4, 3, 2)`` at the corners of each tetrahedron face, in TET_FACES order."""
    out = np.zeros((4, 3, 2))
    for f, face in enumerate(TET_FACES):
        centre = TET_VERTICES[face].mean(0)
        for c, vertex in enumerate(TET_VERTICES[face]):
            fid, _ = locate(mesh, vertex * 0.999 + centre * 0.001)
            # the file holds metres as float32: the corner in mm within 1e-4 mm
            near = np.isclose(mesh.vertices[mesh.faces[fid[0]]], vertex, atol=1e-4).all(1)
            local = np.flatnonzero(near)[0]
            out[f, c] = mesh.corner_uv[fid[0], local]
    return out


def test_texture_transform_offset_rotation_scale(tmp_path):
    transform = {"offset": [0.1, 0.2], "rotation": math.pi / 2, "scale": [2.0, 0.5]}
    _glb(tmp_path / "m.glb", extensions={"KHR_texture_transform": transform})
    mesh = load_model(tmp_path / "m.glb")
    assert mesh.colour_kind == "texture"
    # Corners in glTF space (u, 1 - v) of the corpus UVs: (.05, .95) (.95, .95) (.05, .05).
    # rotation pi/2: R = [[0, 1], [-1, 0]]; scale (2, .5); so uv' = (.5 v + .1, -2 u + .2):
    # (.575, .1) (.575, -1.7) (.125, .1); in shellvox's convention v -> 1 - v:
    expected = np.array([[0.575, 0.9], [0.575, 2.7], [0.125, 0.9]])
    np.testing.assert_allclose(_corner_uv(mesh), np.tile(expected, (4, 1, 1)), atol=1e-6)


@pytest.mark.parametrize("where", ["textureInfo", "extension"])
def test_second_texture_coordinate_set(tmp_path, where):
    # TEXCOORD_1: each face's corners get texels (row, col) = (1, 2), (6, 2), (1, 13) of a
    # 16 x 8 image, as normalised unsigned shorts (glTF space, v down).
    texels = np.array([[2.5 / 16, 1.5 / 8], [2.5 / 16, 6.5 / 8], [13.5 / 16, 1.5 / 8]])
    stored = np.rint(np.tile(texels, (4, 1)) * 65535).astype(np.uint16)
    if where == "textureInfo":
        _glb(tmp_path / "m.glb", tex_coord=1, second=stored)
    else:  # KHR_texture_transform's texCoord overrides the textureInfo's (0)
        _glb(
            tmp_path / "m.glb", extensions={"KHR_texture_transform": {"texCoord": 1}}, second=stored
        )
    mesh = load_model(tmp_path / "m.glb")
    expected = stored.reshape(4, 3, 2) / 65535.0
    expected[..., 1] = 1.0 - expected[..., 1]
    np.testing.assert_allclose(_corner_uv(mesh), expected, atol=1e-12)
    # the marker texel (row 2, col 3) lies between the corners: sample it by hand
    u, v_down = 3.5 / 16, 2.5 / 8
    b = np.linalg.solve(
        np.array([[*texels[:, 0]], [*texels[:, 1]], [1, 1, 1]]), np.array([u, v_down, 1.0])
    )
    point = b @ TET_VERTICES[TET_FACES[0]]
    fid, bary = locate(mesh, point)
    assert mesh.colour_at(fid, bary)[0].tolist() == [255, 0, 0, 255]


def test_info_reports_texture(tmp_path, capsys):
    _glb(tmp_path / "m.glb", extensions={"KHR_texture_transform": {"scale": [2, 2]}})
    assert main(["info", "--json", str(tmp_path / "m.glb")]) == 0
    assert json.loads(capsys.readouterr().out)["colour"] == "texture"
