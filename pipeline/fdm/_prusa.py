"""PrusaSlicer's 3MF project (read by ``_3MF_Importer`` in ``src/libslic3r/Format/3mf.cpp``).

- ``3D/3dmodel.model``: one ``<object>`` whose single ``<mesh>`` holds every volume's
  triangles, one after the other, each volume's vertices a contiguous range (the importer
  takes the vertices between a volume's smallest and largest index); the build item's
  ``transform`` places it on the bed; ``slic3rpe:Version3mf`` = 1 (without it the importer
  bakes the transform into the mesh, as for a foreign 3MF).
- ``Metadata/Slic3r_PE_model.config``: one ``<volume firstid lastid>`` per volume with
  ``name``, ``volume_type`` (``ModelPart`` / ``ParameterModifier``), ``matrix`` (identity)
  and ``extruder`` (1-based), which the importer sets on the volume's config.
- ``Metadata/Slic3r_PE.config``: ``; key = value`` lines read bottom up until the first line
  that is not one (``load_from_gcode_string_legacy``): the header line goes first, and every
  line is at least 10 characters.

Only serialisation: the parts and settings come ready (:mod:`shellvox.fdm._project`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from shellvox import __version__
from shellvox.fdm._package import CORE_NS, attr, mesh_xml, transform_attr, write_package
from shellvox.fdm._project import FdmProject

SLIC3RPE_NS = "http://schemas.slic3r.org/3mf/2017/06"
VOLUME_TYPES = {"part": "ModelPart", "modifier": "ParameterModifier"}
IDENTITY = "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1"


def write_prusa_3mf(target: str | Path, project: FdmProject) -> Path:
    """Write `project` as a PrusaSlicer 3MF project to `target` (atomically)."""
    return write_package(
        target,
        {
            "3D/3dmodel.model": _model(project),
            "Metadata/Slic3r_PE_model.config": _model_config(project),
            "Metadata/Slic3r_PE.config": _print_config(project),
        },
    )


def _model(project: FdmProject) -> str:
    offsets = np.cumsum([0] + [len(p.vertices) for p in project.parts])
    vertices = np.concatenate([p.vertices for p in project.parts])
    faces = np.concatenate([p.faces + offsets[i] for i, p in enumerate(project.parts)])
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<model unit="millimeter" xml:lang="en-US" xmlns="{CORE_NS}" '
        f'xmlns:slic3rpe="{SLIC3RPE_NS}">\n'
        ' <metadata name="slic3rpe:Version3mf">1</metadata>\n'
        f' <metadata name="Application">shellvox {__version__}</metadata>\n'
        " <resources>\n"
        f'  <object id="1" name={attr(project.name)} type="model">\n'
        + mesh_xml(vertices, faces, indent="   ")
        + "  </object>\n </resources>\n <build>\n"
        f'  <item objectid="1" transform="{transform_attr(project.placement_mm)}" '
        'printable="1"/>\n </build>\n</model>\n'
    )


def _model_config(project: FdmProject) -> str:
    rows = [
        '<?xml version="1.0" encoding="UTF-8"?>\n<config>\n',
        f' <object id="1" instances_count="1">\n'
        f'  <metadata type="object" key="name" value={attr(project.name)}/>\n',
    ]
    first = 0
    for part in project.parts:
        last = first + len(part.faces) - 1
        rows.append(f'  <volume firstid="{first}" lastid="{last}">\n')
        for key, value in (
            ("name", part.name),
            ("volume_type", VOLUME_TYPES[part.kind]),
            ("matrix", IDENTITY),
            ("extruder", part.filament + 1),
        ):
            rows.append(f'   <metadata type="volume" key="{key}" value={attr(value)}/>\n')
        rows.append("  </volume>\n")
        first = last + 1
    rows.append(" </object>\n</config>\n")
    return "".join(rows)


#: PrusaSlicer 2.5's defaults of the options it keeps one value of per filament, and per
#: extruder (as its G-code footer prints them). A project config must give each of them one
#: value per filament: PrusaSlicer pads them only for configs that carry a full filament
#: preset, and otherwise its wipe tower reads past the end of the shorter lists (G-code
#: moves to X = -9e5 mm or beyond, or std::bad_alloc, at random from run to run).
PER_FILAMENT = {
    "filament_diameter": "1.75",
    "filament_soluble": "0",
    "filament_max_volumetric_speed": "0",
    "extrusion_multiplier": "1",
    "filament_density": "0",
    "filament_cost": "0",
    "filament_spool_weight": "0",
    "filament_loading_speed": "28",
    "filament_loading_speed_start": "3",
    "filament_load_time": "0",
    "filament_unloading_speed": "90",
    "filament_unloading_speed_start": "100",
    "filament_unload_time": "0",
    "filament_toolchange_delay": "0",
    "filament_cooling_moves": "4",
    "filament_cooling_initial_speed": "2.2",
    "filament_cooling_final_speed": "3.4",
    "filament_minimal_purge_on_wipe_tower": "15",
    "temperature": "200",
    "first_layer_temperature": "200",
    "bed_temperature": "0",
    "first_layer_bed_temperature": "0",
    "fan_always_on": "0",
    "cooling": "1",
    "min_fan_speed": "35",
    "max_fan_speed": "100",
    "bridge_fan_speed": "100",
    "disable_fan_first_layers": "3",
    "full_fan_speed_layer": "0",
    "fan_below_layer_time": "60",
    "slowdown_below_layer_time": "5",
    "min_print_speed": "10",
    "retract_length": "2",
    "retract_lift": "0",
    "retract_lift_above": "0",
    "retract_lift_below": "0",
    "retract_speed": "40",
    "deretract_speed": "0",
    "retract_restart_extra": "0",
    "retract_before_travel": "2",
    "retract_layer_change": "0",
    "wipe": "0",
    "retract_before_wipe": "0%",
    "retract_length_toolchange": "10",
    "retract_restart_extra_toolchange": "0",
    "extruder_offset": "0x0",
    "max_layer_height": "0",
    "min_layer_height": "0.07",
}
#: The same for the options whose values are strings (a list separated by ``;``).
PER_FILAMENT_STRINGS = {
    "filament_type": "PLA",
    "filament_ramming_parameters": (
        '"120 100 6.6 6.8 7.2 7.6 7.9 8.2 8.7 9.4 9.9 10.0| 0.05 6.6 0.45 6.8 0.95 7.8 '
        '1.45 8.3 1.95 9.7 2.45 10 2.95 7.6 3.45 7.6 3.95 7.6 4.45 7.6 4.95 7.6"'
    ),
    "filament_notes": '""',
    "filament_settings_id": '""',
    "start_filament_gcode": '"; Filament gcode\\n"',
    "end_filament_gcode": '"; Filament-specific end gcode \\n;END gcode for filament\\n"',
}


def _print_config(project: FdmProject) -> str:
    s = project.settings
    n = len(project.filaments)
    colours = ";".join(project.filaments.hex)

    def each(value: object) -> str:
        return ",".join([str(value)] * n)

    settings = {
        "bed_shape": "0x0,{0}x0,{0}x{1},0x{1}".format(*s.bed_mm),
        "nozzle_diameter": each(s.nozzle_mm),
        "extruder_colour": colours,
        "filament_colour": colours,
        "layer_height": s.layer_height_mm,
        "first_layer_height": s.layer_height_mm,
        "clip_multipart_objects": 1,
        "single_extruder_multi_material": 1,
        "wipe_tower": 1,
        "wipe_tower_x": s.wipe_tower_mm[0],
        "wipe_tower_y": s.wipe_tower_mm[1],
        "mmu_segmented_region_max_width": 0,
        # one purge volume per pair of filaments: the defaults hold 5 x 5, and more
        # filaments than that run PrusaSlicer 2.5 out of memory (std::bad_alloc)
        "wiping_volumes_matrix": ",".join(
            "0" if i == j else "140" for i in range(n) for j in range(n)
        ),
        "wiping_volumes_extruders": each("70,70"),
        "gcode_flavor": "marlin2",
        "use_relative_e_distances": 1,
        "layer_gcode": "G92 E0",
    }
    settings.update({key: each(value) for key, value in PER_FILAMENT.items()})
    settings.update({key: ";".join([value] * n) for key, value in PER_FILAMENT_STRINGS.items()})
    lines = [f"; generated by shellvox {__version__} (a PrusaSlicer project config)"]
    lines += [f"; {key} = {value}" for key, value in settings.items()]
    return "\n".join(lines) + "\n"
