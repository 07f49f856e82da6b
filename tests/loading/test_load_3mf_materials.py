"""3MF composite materials, multiproperties and Production-extension parts.

Every file is written here by hand from the specifications; what it declares is read
back with lib3mf (the 3MF Consortium's reader), and the expected colours are computed
from that with colour-science's sRGB transfer and the Materials extension's blend
equations (chapter 5), independently of the loader.
"""

from __future__ import annotations

import ctypes
import json
import zipfile

import colour
import numpy as np
import pytest
from builders import TET_FACES, TET_VERTICES, locate, marker_image, png_bytes

from shellvox.cli import main
from shellvox.errors import ShellvoxWarning
from shellvox.loading import load_model

lib3mf = pytest.importorskip("lib3mf")

CORE = "http://schemas.microsoft.com/3dmanufacturing/core/2015/02"
MATERIAL = "http://schemas.microsoft.com/3dmanufacturing/material/2015/02"
PRODUCTION = "http://schemas.microsoft.com/3dmanufacturing/production/2015/06"
MODEL_REL = "http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"
TEXTURE_REL = "http://schemas.microsoft.com/3dmanufacturing/2013/01/3dtexture"
CONTENT_TYPES = (
    '<?xml version="1.0" encoding="UTF-8"?><Types xmlns="http://schemas.openxmlformats.org/'
    'package/2006/content-types"><Default Extension="rels" ContentType="application/vnd.'
    'openxmlformats-package.relationships+xml"/><Default Extension="model" ContentType='
    '"application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/><Default Extension="png" '
    'ContentType="image/png"/></Types>'
)


def _rels(targets: list[tuple[str, str]]) -> str:
    body = "".join(
        f'<Relationship Target="{t}" Id="r{i}" Type="{kind}"/>'
        for i, (t, kind) in enumerate(targets)
    )
    return (
        '<?xml version="1.0" encoding="UTF-8"?><Relationships xmlns="http://schemas.'
        f'openxmlformats.org/package/2006/relationships">{body}</Relationships>'
    )


def _mesh(triangle_attributes: list[str]) -> str:
    vertices = "".join(f'<vertex x="{x}" y="{y}" z="{z}"/>' for x, y, z in TET_VERTICES)
    triangles = "".join(
        f'<triangle v1="{a}" v2="{b}" v3="{c}" {extra}/>'
        for (a, b, c), extra in zip(TET_FACES, triangle_attributes, strict=True)
    )
    return f"<mesh><vertices>{vertices}</vertices><triangles>{triangles}</triangles></mesh>"


def _model(resources: str, build: str = '<item objectid="1"/>') -> str:
    return (
        f'<?xml version="1.0" encoding="UTF-8"?><model unit="millimeter" xml:lang="en-US" '
        f'xmlns="{CORE}" xmlns:m="{MATERIAL}" xmlns:p="{PRODUCTION}">'
        f"<resources>{resources}</resources><build>{build}</build></model>"
    )


def _write(path, model: str, parts: dict[str, str] | None = None, texture=None) -> None:
    parts = parts or {}
    model_rels = [(f"/{name}", MODEL_REL) for name in parts]
    if texture is not None:
        model_rels.append(("/3D/Textures/tex.png", TEXTURE_REL))
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("[Content_Types].xml", CONTENT_TYPES)
        archive.writestr("_rels/.rels", _rels([("/3D/3dmodel.model", MODEL_REL)]))
        archive.writestr("3D/3dmodel.model", model)
        if model_rels:
            archive.writestr("3D/_rels/3dmodel.model.rels", _rels(model_rels))
        for name, text in parts.items():
            archive.writestr(name, text)
        if texture is not None:
            archive.writestr("3D/Textures/tex.png", png_bytes(texture))


def _lib3mf_model(path):
    model = lib3mf.get_wrapper().CreateModel()
    model.QueryReader("3mf").ReadFromFile(str(path))
    return model


def _multi(group, property_id: int, layers: int) -> list[int]:
    """``MultiPropertyGroup.GetMultiProperty`` (lib3mf 2.5's Python binding passes the
    needed-count argument by value, so the C function is called directly)."""
    buffer, needed = (ctypes.c_uint32 * layers)(), ctypes.c_uint64(0)
    group._wrapper.checkError(
        group,
        group._wrapper.lib.lib3mf_multipropertygroup_getmultiproperty(
            group._handle,
            ctypes.c_uint32(property_id),
            ctypes.c_uint64(layers),
            ctypes.byref(needed),
            buffer,
        ),
    )
    return list(buffer)


def _linear(c) -> np.ndarray:
    """lib3mf sColor -> linear RGB + alpha (colour-science's sRGB decoding)."""
    rgb = colour.cctf_decoding(np.array([c.Red, c.Green, c.Blue]) / 255, function="sRGB")
    return np.append(rgb, c.Alpha / 255)


def _srgb(linear: np.ndarray) -> list[int]:
    rgb = np.rint(colour.cctf_encoding(np.clip(linear[:3], 0, 1), function="sRGB") * 255)
    return [*rgb.astype(int).tolist(), round(float(linear[3]) * 255)]


def _corner_colour(mesh, face: int, corner: int) -> list[int]:
    """The loaded mesh's colour at corner ``corner`` of tetrahedron face ``face``."""
    triangle = TET_VERTICES[TET_FACES[face]]
    inside = triangle.mean(0) * 0.999 + triangle[corner] * 0.001
    fid, _ = locate(mesh, inside)
    near = mesh.vertices[mesh.faces[fid[0]]]
    local = int(np.flatnonzero(np.isclose(near, triangle[corner]).all(1))[0])
    return mesh.colour_at(fid, np.eye(3)[local][None])[0].tolist()


def _mesh_object(model):
    objects = model.GetMeshObjects()
    assert objects.MoveNext()
    return objects.GetCurrentMeshObject()


def test_composite_materials_mix_display_colours_in_linear_light(tmp_path):
    corners = [(0, 0, 1), (1, 1, 1), (0, 2, 1), (2, 2, 0)]
    resources = (
        '<basematerials id="3"><base name="red" displaycolor="#FF0000"/>'
        '<base name="blue" displaycolor="#0000FF"/><base name="grey" displaycolor="#808080"/>'
        "</basematerials>"
        '<m:compositematerials id="5" matid="3" matindices="0 1 2">'
        '<m:composite values="0.2 0.6"/><m:composite values="0 0 0"/>'
        '<m:composite values="0.5 0 0.5"/></m:compositematerials>'
        '<object id="1" type="model">'
        + _mesh([f'pid="5" p1="{a}" p2="{b}" p3="{c}"' for a, b, c in corners])
        + "</object>"
    )
    path = tmp_path / "composite.3mf"
    _write(path, _model(resources))
    with pytest.warns(ShellvoxWarning, match="display colour"):
        mesh = load_model(path)
    assert mesh.colour_kind == "vertex"
    model = _lib3mf_model(path)
    groups = model.GetCompositeMaterials()
    assert groups.MoveNext()
    composites = groups.GetCurrentCompositeMaterials()
    bases = composites.GetBaseMaterialGroup()
    ids = list(composites.GetAllPropertyIDs())
    obj = _mesh_object(model)
    for face in range(4):
        properties = obj.GetTriangleProperties(face)
        for corner, property_id in enumerate(properties.PropertyIDs):
            parts = composites.GetComposite(property_id)
            ratios = np.array([p.MixingRatio for p in parts])
            ratios = ratios / ratios.sum() if ratios.sum() > 0 else np.full(len(ratios), 1 / 3)
            linear = sum(
                r * _linear(bases.GetDisplayColor(p.PropertyID))
                for r, p in zip(ratios, parts, strict=True)
            )
            assert _corner_colour(mesh, face, corner) == _srgb(linear), (face, corner)
    assert ids == [1, 2, 3]


def test_multiproperties_over_a_base_material_and_colour_group(tmp_path):
    # Base material first: the colour layer is laid over the display colour with its alpha.
    resources = (
        '<basematerials id="3"><base name="red" displaycolor="#FF0000"/></basematerials>'
        '<m:colorgroup id="2"><m:color color="#0000FF80"/><m:color color="#00FF00"/>'
        "</m:colorgroup>"
        '<m:multiproperties id="6" pids="3 2"><m:multi pindices="0 0"/>'
        '<m:multi pindices="0 1"/><m:multi pindices="0"/></m:multiproperties>'
        '<object id="1" type="model">'
        + _mesh(['pid="6" p1="0"', 'pid="6" p1="1"', 'pid="6" p1="2"', 'pid="6" p1="0"'])
        + "</object>"
    )
    path = tmp_path / "multi.3mf"
    _write(path, _model(resources))
    mesh = load_model(path)
    model = _lib3mf_model(path)
    groups = model.GetMultiPropertyGroups()
    assert groups.MoveNext()
    group = groups.GetCurrentMultiPropertyGroup()
    assert group.GetLayerCount() == 2
    colours = model.GetColorGroups()
    assert colours.MoveNext()
    colour_group = colours.GetCurrentColorGroup()
    bases = model.GetBaseMaterialGroups()
    assert bases.MoveNext()
    base = bases.GetCurrentBaseMaterialGroup()
    obj = _mesh_object(model)
    for face in range(4):
        property_id = obj.GetTriangleProperties(face).PropertyIDs[0]
        base_id, colour_id = _multi(group, property_id, 2)
        under, over = (
            _linear(base.GetDisplayColor(base_id)),
            _linear(colour_group.GetColor(colour_id)),
        )
        # Spec 5: skip the material, accumulate the rest, then printColor over the material.
        rgb = over[:3] * over[3] + under[:3] * (1 - over[3])
        expected = _srgb(np.append(rgb, under[3]))
        assert _corner_colour(mesh, face, 0) == expected, face
    assert mesh.colour_kind == "face"


@pytest.mark.parametrize("method", ["multiply", "mix"])
def test_multiproperties_colour_under_a_texture_is_baked(tmp_path, method):
    width, height, row, col = 32, 16, 5, 7
    image = marker_image(width, height, row, col)
    image[..., 3] = 255
    image[row, col, 3] = 128  # a half-transparent marker (mix blends it)
    corner_uv = np.array([[0.05, 0.05], [0.95, 0.05], [0.05, 0.95]])
    coords = "".join(f'<m:tex2coord u="{u}" v="{v}"/>' for u, v in corner_uv)
    resources = (
        '<m:texture2d id="7" path="/3D/Textures/tex.png" contenttype="image/png" '
        'filter="linear"/>'
        f'<m:texture2dgroup id="4" texid="7">{coords}</m:texture2dgroup>'
        '<m:colorgroup id="2"><m:color color="#808080"/></m:colorgroup>'
        f'<m:multiproperties id="6" pids="2 4" blendmethods="{method}">'
        '<m:multi pindices="0 0"/><m:multi pindices="0 1"/><m:multi pindices="0 2"/>'
        "</m:multiproperties>"
        '<object id="1" type="model">' + _mesh(['pid="6" p1="0" p2="1" p3="2"'] * 4) + "</object>"
    )
    path = tmp_path / "textured.3mf"
    _write(path, _model(resources), texture=image)
    mesh = load_model(path)
    assert mesh.colour_kind == "texture"
    groups = _lib3mf_model(path).GetTexture2DGroups()
    assert groups.MoveNext()
    group = groups.GetCurrentTexture2DGroup()
    assert [group.GetTex2Coord(i).U for i in group.GetAllPropertyIDs()] == pytest.approx(
        corner_uv[:, 0]
    )
    grey = colour.cctf_decoding(128 / 255, function="sRGB")
    for r, c in [(row, col), (row + 3, col + 9)]:
        u, v = (c + 0.5) / width, 1 - (r + 0.5) / height  # texel centre, v up
        b1, b2 = (np.array([u, v]) - corner_uv[0]) / 0.9
        point = np.array([1 - b1 - b2, b1, b2]) @ TET_VERTICES[TET_FACES[0]]
        fid, bary = locate(mesh, point)
        texel = colour.cctf_decoding(image[r, c, :3] / 255, function="sRGB")
        alpha = image[r, c, 3] / 255
        if method == "multiply":
            linear = np.append(texel * grey, alpha)
        else:
            linear = np.append(texel * alpha + grey * (1 - alpha), alpha + 1 * (1 - alpha))
        assert mesh.colour_at(fid, bary)[0].tolist() == _srgb(linear), (r, c)


def test_production_components_and_items_in_other_model_parts(tmp_path):
    # As Bambu Studio writes them: the root holds components whose p:path names the
    # part that holds the mesh; a second build item names another part directly.
    sub = _model(
        '<m:colorgroup id="2"><m:color color="#FF8000"/><m:color color="#2040C0"/></m:colorgroup>'
        '<object id="1" type="model">'
        + _mesh([f'pid="2" p1="{i % 2}"' for i in range(4)])
        + "</object>",
        build="",
    )
    root = _model(
        '<object id="9" type="model"><components>'
        '<component p:path="/3D/Objects/object_1.model" objectid="1" '
        'transform="1 0 0 0 1 0 0 0 1 5 0 0"/></components></object>',
        build='<item objectid="9" transform="1 0 0 0 1 0 0 0 1 0 0 2"/>'
        '<item objectid="1" p:path="/3D/Objects/object_1.model" '
        'transform="1 0 0 0 1 0 0 0 1 40 0 0"/>',
    )
    path = tmp_path / "production.3mf"
    _write(path, root, {"3D/Objects/object_1.model": sub})
    mesh = load_model(path)
    # Two copies: translated by the component and its item (5, 0, 2), and by (40, 0, 0).
    for offset in ([5.0, 0.0, 2.0], [40.0, 0.0, 0.0]):
        for vertex in TET_VERTICES + offset:
            assert np.isclose(mesh.vertices, vertex).all(1).any(), vertex
    model = _lib3mf_model(path)
    obj = _mesh_object(model)
    groups = model.GetColorGroups()
    assert groups.MoveNext()
    table = groups.GetCurrentColorGroup()
    for face in range(4):
        expected = table.GetColor(obj.GetTriangleProperties(face).PropertyIDs[0])
        want = [expected.Red, expected.Green, expected.Blue, expected.Alpha]
        for offset in ([5.0, 0.0, 2.0], [40.0, 0.0, 0.0]):
            centre = TET_VERTICES[TET_FACES[face]].mean(0) + offset
            fid, bary = locate(mesh, centre)
            assert mesh.colour_at(fid, bary)[0].tolist() == want


@pytest.mark.parametrize(
    ("pids", "expected"), [('pid="5" p1="0"', "face"), ('pid="6" p1="0" p2="1" p3="2"', "texture")]
)
def test_info_reports_the_colour_kind(tmp_path, capsys, pids, expected):
    coords = "".join(f'<m:tex2coord u="{u}" v="0.5"/>' for u in (0.1, 0.5, 0.9))
    resources = (
        '<basematerials id="3"><base name="a" displaycolor="#FF0000"/>'
        '<base name="b" displaycolor="#FFFFFF"/></basematerials>'
        '<m:compositematerials id="5" matid="3" matindices="0 1">'
        '<m:composite values="0.5 0.5"/></m:compositematerials>'
        '<m:texture2d id="7" path="/3D/Textures/tex.png" contenttype="image/png"/>'
        f'<m:texture2dgroup id="4" texid="7">{coords}</m:texture2dgroup>'
        '<m:multiproperties id="6" pids="3 4" blendmethods="multiply">'
        '<m:multi pindices="0 0"/><m:multi pindices="0 1"/><m:multi pindices="0 2"/>'
        "</m:multiproperties>"
        '<object id="1" type="model">' + _mesh([pids] * 4) + "</object>"
    )
    path = tmp_path / "m.3mf"
    _write(path, _model(resources), texture=marker_image(8, 8, 1, 1))
    assert main(["info", "--json", str(path)]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["colour"] == expected
    assert "compositematerials" in captured.err


def test_multiproperties_over_two_texture_groups_and_object_level_properties(tmp_path):
    # A colour group layered over two texture groups (mix: the opaque texture shows),
    # triangles on the multiproperties, on the colour group with only p1, and on the
    # object's pid/pindex (a pid without p1 takes the object's, as lib3mf reads it); the
    # build item names the mesh object, another object only wraps it in <components>.
    rng = np.random.default_rng(7)
    image = rng.integers(0, 256, (8, 8, 4), dtype=np.uint8)
    image[..., 3] = 255
    uv = [(0.1, 0.1), (0.9, 0.1), (0.1, 0.9), (0.9, 0.9)]
    coords = "".join(f'<m:tex2coord u="{u}" v="{v}"/>' for u, v in uv)
    resources = (
        '<m:colorgroup id="1"><m:color color="#80C0FF"/></m:colorgroup>'
        '<m:texture2d id="2" path="/3D/Textures/tex.png" contenttype="image/png" '
        'filter="nearest"/>'
        f'<m:texture2dgroup id="4" texid="2">{coords}</m:texture2dgroup>'
        f'<m:texture2dgroup id="5" texid="2">{coords}</m:texture2dgroup>'
        '<m:multiproperties id="6" pids="1 4 5">'
        + "".join(f'<m:multi pindices="0 {i} {i}"/>' for i in range(4))
        + '</m:multiproperties><object id="3" type="model" pid="6" pindex="3">'
        + _mesh(
            ['pid="6" p1="0" p2="1" p3="2"', 'pid="1" p1="0"', 'pid="6" p1="1" p2="3"', 'pid="1"']
        )
        + '</object><object id="7" type="model"><components><component objectid="3"/>'
        "</components></object>"
    )
    path = tmp_path / "layers.3mf"
    _write(path, _model(resources, '<item objectid="3"/>'), texture=image)
    with pytest.warns(ShellvoxWarning, match="layer 2 textures"):
        mesh = load_model(path)
    model = _lib3mf_model(path)
    colours = model.GetColorGroups()
    assert colours.MoveNext()
    colour_group = colours.GetCurrentColorGroup()
    groups = model.GetMultiPropertyGroups()
    assert groups.MoveNext()
    multi = groups.GetCurrentMultiPropertyGroup()
    textures = model.GetTexture2DGroups()
    assert textures.MoveNext()
    texture_group = textures.GetCurrentTexture2DGroup()
    obj = _mesh_object(model)
    kinds = []
    for face in range(4):
        properties = obj.GetTriangleProperties(face)
        for corner, property_id in enumerate(properties.PropertyIDs):
            if properties.ResourceID == colour_group.GetResourceID():
                c = colour_group.GetColor(property_id)
                expected = [c.Red, c.Green, c.Blue, c.Alpha]
                kinds.append("colour")
            else:
                assert properties.ResourceID == multi.GetResourceID()
                coord = texture_group.GetTex2Coord(_multi(multi, property_id, 3)[1])
                row, col = int((1 - coord.V) * 8), int(coord.U * 8)  # nearest texel, v up
                expected = image[row, col].tolist()
                kinds.append("texture")
            assert _corner_colour(mesh, face, corner) == expected, (face, corner)
    assert kinds.count("colour") == 3  # face 1 only: face 3's pid without p1 is the object's


def _unprefixed_multi_model(entries: str) -> str:
    """The 3MF Consortium's multiprop samples: ``<m:multiproperties>`` whose entries are
    written ``<multi>`` without the prefix (so in the core namespace), a colour group
    under an opaque texture group with explicit coordinates."""
    uv = [(0.1, 0.1), (0.9, 0.1), (0.1, 0.9), (0.9, 0.9)]
    coords = "".join(f'<m:tex2coord u="{u}" v="{v}"/>' for u, v in uv)
    return _model(
        '<m:colorgroup id="1"><m:color color="#0090FF"/></m:colorgroup>'
        '<m:texture2d id="2" path="/3D/Textures/tex.png" contenttype="image/png" '
        'filter="nearest"/>'
        f'<m:texture2dgroup id="4" texid="2">{coords}</m:texture2dgroup>'
        f'<m:multiproperties id="6" pids="1 4">{entries}</m:multiproperties>'
        '<object id="3" type="model">'
        + _mesh(['pid="6" p1="0" p2="1" p3="2"', 'pid="6" p1="3" p2="2" p3="1"'] * 2)
        + "</object>",
        '<item objectid="3"/>',
    )


def test_multi_entries_in_the_core_namespace_are_read_with_a_warning(tmp_path):
    rng = np.random.default_rng(3)
    image = rng.integers(0, 256, (8, 8, 4), dtype=np.uint8)
    image[..., 3] = 255  # opaque: the texture layer hides the colour under it
    entries = "".join(f'<multi pindices="0 {i}"/>' for i in range(4))
    path = tmp_path / "multiprop-opaque.3mf"
    _write(path, _unprefixed_multi_model(entries), texture=image)
    with pytest.warns(ShellvoxWarning, match=r"multiproperties '6'.*<multi> in the core namespace"):
        mesh = load_model(path)
    assert mesh.colour_kind == "texture"
    # The truth: each corner names a texture coordinate explicitly (entry i -> uv[i]);
    # the corner's colour is the texel there (nearest filter, v up).
    uv = np.array([(0.1, 0.1), (0.9, 0.1), (0.1, 0.9), (0.9, 0.9)])
    corners = [(0, 1, 2), (3, 2, 1)] * 2
    for face in range(4):
        for corner, entry in enumerate(corners[face]):
            u, v = uv[entry]
            expected = image[int((1 - v) * 8), int(u * 8)].tolist()
            assert _corner_colour(mesh, face, corner) == expected, (face, corner)
    # lib3mf, the consortium's reader, sees the same entries as no entries at all.
    groups = _lib3mf_model(path).GetMultiPropertyGroups()
    assert groups.MoveNext()
    assert groups.GetCurrentMultiPropertyGroup().GetCount() == 0


def test_a_multiproperties_group_without_entries_is_refused_naming_it(tmp_path, capsys):
    path = tmp_path / "empty.3mf"
    _write(path, _unprefixed_multi_model(""), texture=marker_image(8, 8, 1, 1))
    assert main(["info", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert "multiproperties '6' have no <multi> entries" in err[0]
    assert str(path) in err[0]
