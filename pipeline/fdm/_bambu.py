"""Bambu Studio's (and OrcaSlicer's) 3MF project (read by ``bbs_3mf.cpp``).

- ``3D/3dmodel.model``: the parent ``<object>`` (id ``P + 1`` for ``P`` parts) with one
  ``<component p:path="/3D/Objects/object_1.model" objectid="k">`` per part, and the
  build item placing it on the bed; ``BambuStudio:3mfVersion`` = 1.
- ``3D/Objects/object_1.model``: one ``<object id="k">`` with a ``<mesh>`` per part
  (``k = 1..P``, in slicing order); ``3D/_rels/3dmodel.model.rels`` points at it.
- ``Metadata/model_settings.config``: ``<object id="P + 1">`` with ``name`` and
  ``extruder`` (the core's), one ``<part id="k" subtype=...>`` per part
  (``normal_part`` / ``modifier_part``, ``ModelVolume::type_from_string``) with its
  ``name``, ``matrix`` and ``extruder`` (1-based); one ``<plate>`` holding the instance.
- ``Metadata/project_settings.config``: JSON; ``filament_colour`` one ``#RRGGBB`` per
  filament, ``nozzle_diameter``, ``layer_height``, ``initial_layer_print_height``.

Only serialisation: the parts and settings come ready (:mod:`shellvox.fdm._project`).
"""

from __future__ import annotations

import json
from pathlib import Path

from shellvox import __version__
from shellvox.fdm._package import CORE_NS, attr, mesh_xml, transform_attr, write_package
from shellvox.fdm._project import FdmProject

PRODUCTION_NS = "http://schemas.microsoft.com/3dmanufacturing/production/2015/06"
BAMBU_NS = "http://schemas.bambulab.com/package/2021"
SUBTYPES = {"part": "normal_part", "modifier": "modifier_part"}
OBJECTS_FILE = "3D/Objects/object_1.model"
IDENTITY = "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1"

_HEADER = (
    '<?xml version="1.0" encoding="UTF-8"?>\n'
    f'<model unit="millimeter" xml:lang="en-US" xmlns="{CORE_NS}" '
    f'xmlns:BambuStudio="{BAMBU_NS}" xmlns:p="{PRODUCTION_NS}" requiredextensions="p">\n'
    ' <metadata name="BambuStudio:3mfVersion">1</metadata>\n'
    f' <metadata name="Application">shellvox {__version__}</metadata>\n'
)


def write_bambu_3mf(target: str | Path, project: FdmProject) -> Path:
    """Write `project` as a Bambu Studio / OrcaSlicer 3MF project to `target` (atomically)."""
    return write_package(
        target,
        {
            "3D/3dmodel.model": _model(project),
            "3D/_rels/3dmodel.model.rels": _model_rels(),
            OBJECTS_FILE: _objects(project),
            "Metadata/model_settings.config": _model_settings(project),
            "Metadata/project_settings.config": _project_settings(project),
        },
    )


def _parent_id(project: FdmProject) -> int:
    return len(project.parts) + 1


def _model(project: FdmProject) -> str:
    parent = _parent_id(project)
    components = "".join(
        f'    <component p:path="/{OBJECTS_FILE}" objectid="{k}" '
        'transform="1 0 0 0 1 0 0 0 1 0 0 0"/>\n'
        for k in range(1, parent)
    )
    return (
        _HEADER + " <resources>\n"
        f'  <object id="{parent}" name={attr(project.name)} type="model">\n'
        f"   <components>\n{components}   </components>\n  </object>\n </resources>\n"
        f' <build>\n  <item objectid="{parent}" '
        f'transform="{transform_attr(project.placement_mm)}" printable="1"/>\n </build>\n'
        "</model>\n"
    )


def _model_rels() -> str:
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        '<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">\n'
        f' <Relationship Target="/{OBJECTS_FILE}" Id="rel-1" '
        'Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/>\n'
        "</Relationships>\n"
    )


def _objects(project: FdmProject) -> str:
    objects = "".join(
        f'  <object id="{k}" name={attr(part.name)} type="model">\n'
        + mesh_xml(part.vertices, part.faces, indent="   ")
        + "  </object>\n"
        for k, part in enumerate(project.parts, start=1)
    )
    return _HEADER + f" <resources>\n{objects} </resources>\n <build/>\n</model>\n"


def _model_settings(project: FdmProject) -> str:
    parent = _parent_id(project)
    rows = [
        '<?xml version="1.0" encoding="UTF-8"?>\n<config>\n',
        f'  <object id="{parent}">\n',
        f'    <metadata key="name" value={attr(project.name)}/>\n',
        '    <metadata key="extruder" value="1"/>\n',
    ]
    for k, part in enumerate(project.parts, start=1):
        rows.append(f'    <part id="{k}" subtype="{SUBTYPES[part.kind]}">\n')
        for key, value in (
            ("name", part.name),
            ("matrix", IDENTITY),
            ("extruder", part.filament + 1),
        ):
            rows.append(f'      <metadata key="{key}" value={attr(value)}/>\n')
        rows.append(f'      <mesh_stat face_count="{len(part.faces)}" edges_fixed="0"/>\n')
        rows.append("    </part>\n")
    rows += [
        "  </object>\n  <plate>\n",
        '    <metadata key="plater_id" value="1"/>\n',
        "    <model_instance>\n",
        f'      <metadata key="object_id" value="{parent}"/>\n',
        '      <metadata key="instance_id" value="0"/>\n',
        "    </model_instance>\n  </plate>\n</config>\n",
    ]
    return "".join(rows)


def _project_settings(project: FdmProject) -> str:
    s = project.settings
    settings = {
        "name": "project_settings",
        "from": "project",
        "version": "1.0.0.0",
        "filament_colour": list(project.filaments.hex),
        "nozzle_diameter": [f"{s.nozzle_mm:g}"],  # per nozzle (one), not per filament
        "layer_height": f"{s.layer_height_mm:g}",
        "initial_layer_print_height": f"{s.layer_height_mm:g}",
        "enable_prime_tower": "1",
    }
    return json.dumps(settings, indent=4) + "\n"
