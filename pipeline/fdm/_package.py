"""The zip container both slicers' 3MF projects share (3MF core spec: OPC parts).

Only serialisation: the geometry comes in as arrays, ready (:mod:`shellvox.fdm._parts`).
"""

from __future__ import annotations

import zipfile
from collections.abc import Mapping
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
from numpy.typing import NDArray

from shellvox.atomic import atomic_path

CORE_NS = "http://schemas.microsoft.com/3dmanufacturing/core/2015/02"

CONTENT_TYPES = """<?xml version="1.0" encoding="UTF-8"?>
<Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types">
 <Default Extension="rels" ContentType="application/vnd.openxmlformats-package.relationships+xml"/>
 <Default Extension="model" ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/>
 <Default Extension="config" ContentType="text/xml"/>
 <Default Extension="png" ContentType="image/png"/>
</Types>
"""

RELS = """<?xml version="1.0" encoding="UTF-8"?>
<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">
 <Relationship Target="/3D/3dmodel.model" Id="rel-1" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/>
</Relationships>
"""


def mesh_xml(
    vertices: NDArray[np.float64], faces: NDArray[np.int64], *, indent: str = "    "
) -> str:
    """Return ``<mesh>`` with ``<vertices>`` and ``<triangles>`` (3MF core), as text."""
    rows = [f"{indent}<mesh>\n{indent} <vertices>\n"]
    rows.extend(
        f'{indent}  <vertex x="{x:.9g}" y="{y:.9g}" z="{z:.9g}"/>\n'
        for x, y, z in vertices.tolist()
    )
    rows.append(f"{indent} </vertices>\n{indent} <triangles>\n")
    rows.extend(f'{indent}  <triangle v1="{a}" v2="{b}" v3="{c}"/>\n' for a, b, c in faces.tolist())
    rows.append(f"{indent} </triangles>\n{indent}</mesh>\n")
    return "".join(rows)


def transform_attr(translation_mm: NDArray[np.float64]) -> str:
    """Return a 3MF ``transform`` (3 x 4, column-major rows of a pure translation)."""
    x, y, z = (float(t) for t in translation_mm)
    return f"1 0 0 0 1 0 0 0 1 {x:.9g} {y:.9g} {z:.9g}"


def attr(value: object) -> str:
    """Return ``value`` as a quoted, escaped XML attribute value."""
    return quoteattr(str(value))


def write_package(target: str | Path, entries: Mapping[str, str]) -> Path:
    """Write the zip (deflated) with ``[Content_Types].xml``, ``_rels/.rels`` and `entries`.

    The file appears atomically (:func:`shellvox.atomic.atomic_path`).
    """
    target = Path(target)
    with (
        atomic_path(target) as temporary,
        zipfile.ZipFile(temporary, "w", zipfile.ZIP_DEFLATED) as archive,
    ):
        archive.writestr("[Content_Types].xml", CONTENT_TYPES)
        archive.writestr("_rels/.rels", RELS)
        for name, text in entries.items():
            archive.writestr(name, text)
    return target
