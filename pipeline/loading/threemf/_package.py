"""The 3MF package: a checked zip archive, its model parts and their XML.

The archive is checked before anything is extracted: no entry may escape it, and entries
may not expand beyond sane sizes (zip-bomb guard). Any broken entry (CRC, deflate data,
encryption, malformed XML) is an :class:`~shellvox.errors.InputError`.
"""

from __future__ import annotations

import zipfile
import zlib
from pathlib import Path, PurePosixPath
from xml.etree import ElementTree

from shellvox.errors import InputError

MODEL_REL = "http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"
MAX_ENTRY_BYTES = 4 * 1024**3
MAX_TOTAL_BYTES = 8 * 1024**3
MAX_RATIO = 200.0


def check_archive(path: Path, archive: zipfile.ZipFile) -> None:
    """Refuse entries that escape the archive or expand beyond sane sizes."""
    total = 0
    for info in archive.infolist():
        name = PurePosixPath(info.filename.replace("\\", "/"))
        if name.is_absolute() or ".." in name.parts or ":" in info.filename:
            raise InputError(
                path,
                f"zip entry {info.filename!r} escapes the archive",
                "refusing to read it; re-export the 3MF from a trusted tool",
            )
        total += info.file_size
        ratio = info.file_size / max(info.compress_size, 1)
        if (
            info.file_size > MAX_ENTRY_BYTES
            or total > MAX_TOTAL_BYTES
            or (ratio > MAX_RATIO and info.file_size > 64 * 1024**2)
        ):
            raise InputError(
                path,
                f"zip entry {info.filename!r} expands to {info.file_size} "
                f"bytes (ratio {ratio:.0f}:1), a likely zip bomb",
                "refusing to read it; re-export the 3MF",
            )


def root_model_part(path: Path, archive: zipfile.ZipFile) -> str:
    """Return the entry name of the root model part (from ``_rels/.rels``)."""
    names = set(archive.namelist())
    if "_rels/.rels" in names:
        try:
            rels = ElementTree.fromstring(read_entry(path, archive, "_rels/.rels"))
        except (ElementTree.ParseError, LookupError) as error:  # Lookup: an unknown encoding
            raise InputError(
                path, f"its _rels/.rels is malformed XML ({error})", "re-export it as 3MF"
            ) from None
        for rel in rels:
            if rel.get("Type") == MODEL_REL and rel.get("Target"):
                target = str(rel.get("Target")).lstrip("/")
                if target in names:
                    return target
    for name in names:
        if name.lower().endswith(".model"):
            return name
    raise InputError(path, "has no 3D model part", "re-export it as 3MF")


def read_entry(path: Path, archive: zipfile.ZipFile, name: str) -> bytes:
    """Return an entry's bytes; a corrupt or oversized entry is an InputError."""
    try:
        with archive.open(name) as handle:
            data = handle.read(MAX_ENTRY_BYTES + 1)
    except (zipfile.BadZipFile, zlib.error, EOFError, OSError) as error:
        # A bad CRC-32, corrupt deflate data or a truncated archive.
        raise InputError(
            path, f"zip entry {name!r} is corrupt ({error})", "re-export or re-download it"
        ) from None
    except (NotImplementedError, RuntimeError) as error:  # unknown compression, encrypted
        raise InputError(
            path, f"zip entry {name!r} cannot be read ({error})", "re-export it as 3MF"
        ) from None
    if len(data) > MAX_ENTRY_BYTES:
        raise InputError(path, f"zip entry {name!r} is larger than declared", "refusing it")
    return data


def parse_xml(path: Path, archive: zipfile.ZipFile, name: str) -> ElementTree.Element:
    """Parse an entry as XML; malformed XML is an InputError."""
    try:
        return ElementTree.fromstring(read_entry(path, archive, name))
    except (ElementTree.ParseError, LookupError) as error:  # Lookup: an unknown encoding
        raise InputError(path, f"model XML is malformed ({error})", "re-export it") from None
