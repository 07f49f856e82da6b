"""The 3MF projects read back with a zip reader and an XML parser, and the refusals.

The structure checked is what the slicers' readers take (PrusaSlicer
``src/libslic3r/Format/3mf.cpp``; Bambu Studio / OrcaSlicer ``bbs_3mf.cpp`` and
``ModelVolume::type_from_string``): volumes / parts in order with their types and extruders,
filament colours in the project config, every triangle index inside its volume.
"""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest
import trimesh
from fdm_slicer import BOX_FILAMENTS, coloured_box

from shellvox.cli import main
from shellvox.errors import FdmError
from shellvox.fdm import FdmSettings, make_project, parse_filaments, write_projects

CORE = "{http://schemas.microsoft.com/3dmanufacturing/core/2015/02}"
PRODUCTION = "{http://schemas.microsoft.com/3dmanufacturing/production/2015/06}"


@pytest.fixture(scope="module")
def box_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("files")
    mesh = coloured_box()
    project = make_project(mesh, np.full(mesh.n_faces, 1.2), parse_filaments(BOX_FILAMENTS))
    return project, write_projects(folder, "box", project, ["prusa", "bambu"])


def _mesh(element):
    vertices = np.array(
        [[float(v.get(k)) for k in "xyz"] for v in element.iter(f"{CORE}vertex")], np.float64
    )
    triangles = np.array(
        [[int(t.get(k)) for k in ("v1", "v2", "v3")] for t in element.iter(f"{CORE}triangle")],
        np.int64,
    )
    return vertices, triangles


def test_names_are_stem_and_slicer(box_files):
    _, paths = box_files
    assert [p.name for p in paths] == ["box_prusa.3mf", "box_bambu.3mf"]


def test_bambu_parts_extruders_and_colours(box_files):
    project, (_, bambu) = box_files
    with zipfile.ZipFile(bambu) as archive:
        names = set(archive.namelist())
        model = ET.fromstring(archive.read("3D/3dmodel.model"))
        objects = ET.fromstring(archive.read("3D/Objects/object_1.model"))
        settings = ET.fromstring(archive.read("Metadata/model_settings.config"))
        config = json.loads(archive.read("Metadata/project_settings.config"))
        rels = archive.read("3D/_rels/3dmodel.model.rels").decode()
    assert {"[Content_Types].xml", "_rels/.rels"} <= names
    assert "/3D/Objects/object_1.model" in rels
    (parent,) = model.iter(f"{CORE}object")
    components = list(parent.iter(f"{CORE}component"))
    assert {c.get(f"{PRODUCTION}path") for c in components} == {"/3D/Objects/object_1.model"}
    meshes = {o.get("id"): o for o in objects.iter(f"{CORE}object")}
    assert [c.get("objectid") for c in components] == list(meshes)
    (item,) = model.iter(f"{CORE}item")
    assert item.get("objectid") == parent.get("id")
    (config_object,) = settings.iter("object")
    assert config_object.get("id") == parent.get("id")
    parts = list(config_object.iter("part"))
    assert [p.get("id") for p in parts] == list(meshes)
    subtypes = [p.get("subtype") for p in parts]
    assert subtypes == ["normal_part"] + ["modifier_part"] * 4 + ["normal_part"]
    extruders = [
        int(next(m.get("value") for m in p.iter("metadata") if m.get("key") == "extruder"))
        for p in parts
    ]
    assert extruders == [1, 2, 3, 4, 5, 1]  # body, the four sides, the core last
    assert config["filament_colour"] == ["#FFFFFF", "#FF0000", "#00FF00", "#0000FF", "#FFFF00"]
    for part, mesh in zip(project.parts, meshes.values(), strict=True):
        vertices, triangles = _mesh(mesh)
        assert np.array_equal(triangles, part.faces)
        assert np.allclose(vertices, part.vertices)


def test_prusa_volumes_cover_the_mesh_in_order(box_files):
    project, (prusa, _) = box_files
    _check_prusa(project, prusa)


@pytest.mark.slow
def test_default_model_volumes_are_closed(tmp_path):
    # rounded edges (patches shallower than the reach) and colour patches that meet at a
    # vertex only (bow ties, split so every volume stays 2-manifold)
    out = tmp_path / "out"
    model = "data/colour_target/colour_target.obj"
    filaments = "#FFFFFF,#000000,#FF0000,#0000FF,#FFD000,#00A000"
    argv = ["fdm", model, "-o", str(out), "--thickness", "1.2", "--filaments", filaments]
    assert main(argv) == 0
    with zipfile.ZipFile(out / "colour_target_prusa.3mf") as archive:
        config = ET.fromstring(archive.read("Metadata/Slic3r_PE_model.config"))
        model_xml = ET.fromstring(archive.read("3D/3dmodel.model"))
    vertices, triangles = _mesh(model_xml)
    for volume in config.iter("volume"):
        # topology by index, as the slicers read it (process=True would merge the split
        # bow-tie vertices back by position)
        own = triangles[int(volume.get("firstid")) : int(volume.get("lastid")) + 1]
        mesh = trimesh.Trimesh(vertices[own.min() : own.max() + 1], own - own.min(), process=False)
        assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0


def _check_prusa(project, prusa):
    with zipfile.ZipFile(prusa) as archive:
        model = ET.fromstring(archive.read("3D/3dmodel.model"))
        config = ET.fromstring(archive.read("Metadata/Slic3r_PE_model.config"))
        text = archive.read("Metadata/Slic3r_PE.config").decode()
    vertices, triangles = _mesh(model)
    volumes = list(config.iter("volume"))
    first = [int(v.get("firstid")) for v in volumes]
    last = [int(v.get("lastid")) for v in volumes]
    assert first[0] == 0 and last[-1] == len(triangles) - 1
    assert all(b == a + 1 for a, b in zip(last[:-1], first[1:], strict=True))
    meta = [{m.get("key"): m.get("value") for m in v.iter("metadata")} for v in volumes]
    assert [m["volume_type"] for m in meta] == (
        ["ModelPart"] + ["ParameterModifier"] * 4 + ["ModelPart"]
    )
    assert [m["extruder"] for m in meta] == ["1", "2", "3", "4", "5", "1"]
    for part, lo, hi in zip(project.parts, first, last, strict=True):
        own = triangles[lo : hi + 1]
        mesh = trimesh.Trimesh(vertices[own.min() : own.max() + 1], own - own.min(), process=False)
        assert mesh.is_watertight and mesh.volume > 0, part.name
    assert "; extruder_colour = #FFFFFF;#FF0000;#00FF00;#0000FF;#FFFF00\n" in text
    assert text.splitlines()[0].startswith("; generated by shellvox")


def test_the_core_is_the_shell_at_the_skin_depth(box_files):
    project, _ = box_files
    core = project.parts[-1]
    assert np.allclose(core.vertices.max(axis=0), [10 - 1.2, 10 - 1.2, 5 - 1.2])


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--filaments", "#FFFFFF"], "at least two filaments"),
        (["--filaments", "#FFFFFF,red"], "not a colour #RRGGBB"),
        (["--filaments", "#FFFFFF,#FF0000", "--thickness", "0.3"], "below the nozzle width"),
        (["--filaments", ",".join(["#FFFFFF"] * 16), "--slicer", "prusa"], "at most 15"),
        (["--filaments", ",".join(["#FFFFFF"] * 17), "--slicer", "bambu"], "at most 16"),
        (["--filaments", "#FFFFFF,#FF0000", "--slicer", "cura"], "expected some of prusa"),
    ],
)
def test_refusals_are_one_line(tmp_path, capsys, argv, message):
    model = "data/colour_target/colour_target.obj"
    status = main(["fdm", model, "-o", str(tmp_path / "out"), "--thickness", "1.2", *argv])
    err = capsys.readouterr().err
    assert status == 2
    assert message in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "out").exists()


def test_api_refusals_are_value_errors():
    mesh = coloured_box()
    with pytest.raises(ValueError, match="below the nozzle width"):
        make_project(mesh, np.full(mesh.n_faces, 0.3), parse_filaments(BOX_FILAMENTS))
    with pytest.raises(FdmError, match="at least two"):
        parse_filaments("#FFFFFF")
    lifted = make_project(
        mesh,
        np.full(mesh.n_faces, 0.3),
        parse_filaments(BOX_FILAMENTS),
        lift=True,
        settings=FdmSettings(layer_height_mm=0.2),
    )
    # raised to one extrusion width (0.45 mm); up and down faces to whole layers (0.6 mm)
    assert sorted(set(np.round(lifted.depth_mm, 6).tolist())) == [0.45, 0.6]
