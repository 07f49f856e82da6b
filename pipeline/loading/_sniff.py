"""What a model file actually holds, told from its first bytes, before its reader runs.

:func:`check_content` reads the first :data:`HEAD_BYTES` bytes of a file and refuses one
whose content is plainly not the format its suffix names, saying what it is instead: a
known signature (images, archives, documents, programs, other model formats), a binary
file where a text format is expected, or a text file where a binary one is. The fix names
the right suffix when the content is another model format that shellvox reads.

Files of the expected format pass. A PLY, STL, glTF/GLB, 3MF, VRML or OFF passes when
it starts as its reader requires (a binary PLY has an ASCII header; a binary STL is known
by its size, 84 + 50 bytes per triangle, whatever its 80-byte header says, "solid"
included; a glTF reader reads GLB and JSON alike; a 3MF is any zip archive). An OBJ has no
signature: it passes unless it starts like another kind of file or is binary (over 5 % of
its first bytes are control bytes). Text may carry a UTF-8 byte order mark and Latin-1 or
UTF-8 bytes. A file this module cannot place goes to the reader, whose messages name what
is wrong inside it.
"""

from __future__ import annotations

import re
import struct
import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path

from shellvox.errors import InputError

#: Bytes read from the start of a file to tell what it is.
HEAD_BYTES = 4096

#: What each format's reader expects, as said in a message ("is not <this>: ...").
EXPECTED = {
    "obj": "a text OBJ",
    "ply": "a PLY",
    "stl": "an STL",
    "off": "a text OFF",
    "wrl": "a VRML text file",
    "gltf": "a glTF (JSON) or GLB file",
    "glb": "a GLB or glTF (JSON) file",
    "3mf": "a 3MF package (a zip archive)",
}
#: Each format's name in a fix ("export the model again as ...").
NAMES = {
    "obj": "OBJ",
    "ply": "PLY",
    "stl": "STL",
    "off": "OFF",
    "wrl": "VRML 2.0",
    "gltf": "glTF",
    "glb": "GLB",
    "3mf": "3MF",
}
#: How the formats with a signature start, for a message.
SIGNATURES = {
    "ply": "the first line 'ply'",
    "gltf": "the GLB signature 'glTF' or JSON's '{'",
    "glb": "the GLB signature 'glTF' or JSON's '{'",
    "3mf": "the zip signature 'PK'",
}
#: The suffixes of the content each format's reader takes (a glTF reader takes both kinds).
READ_AS = {
    "obj": {".obj"},
    "ply": {".ply"},
    "stl": {".stl"},
    "off": {".off"},
    "wrl": {".wrl"},
    "gltf": {".gltf", ".glb"},
    "glb": {".gltf", ".glb"},
    "3mf": {".3mf"},
}

_IMAGE_FIX = "give the model file (an image is read only as a texture that a model names)"
_ARCHIVE_FIX = "unpack it and give the model file inside"
_OTHER_FIX = "give the model file itself (export or download it again)"
_EXPORT_FIX = "export the model as 3MF, glTF (.glb), OBJ, PLY or STL"

#: Byte signatures at the start of a file: (signature, what it is, fix).
MAGIC: tuple[tuple[bytes, str, str], ...] = (
    (b"\x89PNG\r\n\x1a\n", "a PNG image", _IMAGE_FIX),
    (b"\xff\xd8\xff", "a JPEG image", _IMAGE_FIX),
    (b"GIF87a", "a GIF image", _IMAGE_FIX),
    (b"GIF89a", "a GIF image", _IMAGE_FIX),
    (b"II*\x00", "a TIFF image", _IMAGE_FIX),
    (b"MM\x00*", "a TIFF image", _IMAGE_FIX),
    (b"\xabKTX 20\xbb\r\n\x1a\n", "a KTX2 texture", _IMAGE_FIX),
    (b"DDS |", "a DDS texture", _IMAGE_FIX),
    (b"%PDF-", "a PDF document", _OTHER_FIX),
    (b"\x7fELF", "a program (ELF executable)", _OTHER_FIX),
    (b"7z\xbc\xaf\x27\x1c", "a 7z archive", _ARCHIVE_FIX),
    (b"Rar!\x1a\x07", "a RAR archive", _ARCHIVE_FIX),
    (b"\xfd7zXZ\x00", "an xz-compressed file", _ARCHIVE_FIX),
    (b"\x28\xb5\x2f\xfd", "a zstd-compressed file", _ARCHIVE_FIX),
    (b"Kaydara FBX Binary", "an FBX file", _EXPORT_FIX),
    (b"; FBX ", "an ASCII FBX file", _EXPORT_FIX),
    (b"xof 03", "a DirectX .x file", _EXPORT_FIX),
    (b"BLENDER", "a Blender file", "export it from Blender as glTF (.glb), OBJ or PLY"),
    (b"ISO-10303-21;", "a STEP CAD file", "export a mesh from the CAD program (3MF or STL)"),
    (b"SQLite format 3\x00", "an SQLite database", _OTHER_FIX),
    (b"\xff\xfe", "UTF-16 text", "save it as UTF-8 text"),
    (b"\xfe\xff", "UTF-16 text", "save it as UTF-8 text"),
)

#: The suffixes of model files looked for inside a zip archive.
_MODEL_SUFFIXES = (".obj", ".ply", ".stl", ".off", ".wrl", ".glb", ".gltf", ".3mf")
_ZIP_MAGIC = (b"PK\x03\x04", b"PK\x05\x06")
_GZIP_MAGIC = b"\x1f\x8b"
_BOM = b"\xef\xbb\xbf"
#: Bytes that do not occur in text (ASCII controls but tab, newline, VT, FF, CR).
_CONTROL = bytes([*range(0, 9), *range(14, 32), 127])
_GLTF_KEYS = (b'"asset"', b'"accessors"', b'"bufferViews"')
_OFF_HEADER = re.compile(rb"(?:ST)?C?N?4?n?OFF(?:\s|$)")
_OBJ_VERTEX = re.compile(rb"^[ \t]*v[ \t]+[-+.\d][^\n]*[ \t][-+.\d][^\n]*[ \t][-+.\d]", re.M)
_OBJ_FACE = re.compile(rb"^[ \t]*f[ \t]+\d", re.M)


@dataclass(frozen=True)
class Content:
    """What a file holds, as told from its first bytes.

    Parameters
    ----------
    what : str
        A phrase, e.g. "a PNG image".
    evidence : str
        How it shows, completing "it ...", e.g. "starts like a PNG image".
    suffix : str or None
        The suffix of the model format it is, when shellvox reads that format.
    fix : str
        What the user can do, when it is not a model format shellvox reads.
    """

    what: str
    evidence: str
    suffix: str | None = None
    fix: str = _OTHER_FIX


def check_content(path: Path, format_name: str) -> None:
    """Refuse `path` if its content is plainly not `format_name`; say what it is.

    Parameters
    ----------
    path : Path
        An existing, non-empty file.
    format_name : str
        The format its suffix names (``"obj"``, ``"ply"``, ... as registered); others pass.

    Raises
    ------
    InputError
        The file is another known kind of file, binary where text is expected (OBJ, OFF,
        VRML), text where binary is (3MF, or an STL that is not ASCII STL), or a PLY
        without its ``ply`` first line.
    """
    if format_name not in EXPECTED:
        return
    size = path.stat().st_size
    with path.open("rb") as handle:
        head = handle.read(HEAD_BYTES)
    if _is_expected(path, format_name, head, size):
        return
    found = identify(path, head, size)
    if found is not None and found.suffix in READ_AS[format_name]:
        return
    found = found or _unknown(format_name, head)
    if found is None:
        return
    fix = f"rename it {found.suffix}" if found.suffix else found.fix
    raise InputError(path, f"is not {EXPECTED[format_name]}: it {found.evidence}", fix)


def identify(path: Path, head: bytes, size: int) -> Content | None:
    """Say what a file is from its first bytes and size, or None if no signature fits.

    Parameters
    ----------
    path : Path
        The file (a zip archive's entries are listed from it).
    head : bytes
        Its first bytes (:data:`HEAD_BYTES` or all of a smaller file).
    size : int
        Its size in bytes.

    Returns
    -------
    Content or None
    """
    stl = _binary_stl(head, size)
    if stl is not None:
        return stl
    if _text_start(head).split(b"\n", 1)[0].strip().lower() == b"ply":  # binary PLY too
        return Content("a PLY", "starts like a PLY ('ply')", ".ply")
    if head.startswith(b"glTF"):
        return Content("a GLB", "starts like a GLB (binary glTF)", ".glb")
    if head.startswith(_ZIP_MAGIC):
        return _zip(path)
    if head.startswith(_GZIP_MAGIC):
        return _gzip(head)
    for magic, what, fix in MAGIC:
        if head.startswith(magic):
            return Content(what, f"starts like {what}", None, fix)
    if head.startswith(b"BZh") and head[4:10] == b"1AY&SY":
        return Content("a bzip2-compressed file", "starts like a bzip2 file", None, _ARCHIVE_FIX)
    if head.startswith(b"RIFF") and head[8:12] == b"WEBP":
        return Content("a WebP image", "starts like a WebP image", None, _IMAGE_FIX)
    if head.startswith(b"BM") and len(head) >= 6 and struct.unpack_from("<I", head, 2)[0] == size:
        return Content("a BMP image", "starts like a BMP image", None, _IMAGE_FIX)
    if head.startswith(b"MM") and len(head) >= 6 and struct.unpack_from("<I", head, 2)[0] == size:
        return Content("a 3DS file", "starts like a 3DS file", None, _EXPORT_FIX)
    if head.startswith(b"FORM") and head[8:11] == b"LWO":
        return Content("a LightWave object", "starts like a LightWave object", None, _EXPORT_FIX)
    if head.startswith(b"MZ") and _is_windows_program(head):
        return Content("a Windows program", "starts like a Windows program (.exe)")
    if _is_utf16(head):
        return Content("UTF-16 text", "is UTF-16 text", None, "save it as UTF-8 text")
    return None if is_binary(head) else _text_kind(head)


def _is_expected(path: Path, format_name: str, head: bytes, size: int) -> bool:
    """Whether the file may be `format_name` (at least what its reader accepts)."""
    text = _text_start(head)
    if format_name == "ply":  # trimesh's test: "ply" somewhere in the first line
        return b"ply" in head.split(b"\n", 1)[0].lower()
    if format_name == "stl":
        return _binary_stl(head, size) is not None or text.lower().startswith(b"solid")
    if format_name in ("gltf", "glb"):
        return head.startswith(b"glTF") or text.startswith((b"{", b"["))
    if format_name == "3mf":
        return head.startswith(_ZIP_MAGIC) or zipfile.is_zipfile(path)
    if format_name == "wrl":
        return text.startswith(b"#VRML")
    if format_name == "off":
        return _OFF_HEADER.match(_first_data_line(text)) is not None
    return False  # OBJ: no signature of its own; it is text that is nothing else


def _unknown(format_name: str, head: bytes) -> Content | None:
    """Say what a file no signature fits is, or None to leave it to the reader."""
    fix = f"export the model again as {NAMES[format_name]}"
    if is_binary(head):
        if format_name == "stl":  # a broken binary STL: the reader names its size
            return None
        if format_name in SIGNATURES:
            evidence = f"is binary data without {SIGNATURES[format_name]} (it starts {_hex(head)})"
            return Content("binary data", evidence, None, fix)
        at = next(at for at, byte in enumerate(head) if byte in _CONTROL)
        if at >= 16:  # text, then binary bytes: damaged, or text and data mixed
            evidence = f"is text with binary bytes in it (the first at byte {at:,})"
            return Content("text with binary bytes", evidence, None, fix)
        return Content("binary data", f"is binary data (it starts {_hex(head)})", None, fix)
    if format_name not in ("ply", "stl", "3mf"):  # text: the reader names what is wrong
        return None
    line = next((line.strip() for line in head.splitlines() if line.strip()), b"")
    if not line:
        return Content("white space", "holds only white space", None, fix)
    shown = line[:40].decode("latin-1")
    return Content("text", f"is text whose first line is {shown!r}", None, fix)


def is_binary(head: bytes) -> bool:
    """Whether bytes are binary data, not text: over 5 % are control bytes.

    Text in any 8-bit encoding (UTF-8, Latin-1) passes, and so does text with a few
    stray control bytes; random bytes are 11 % control bytes, binary meshes and
    images more (runs of zero bytes).
    """
    if not head:
        return False
    controls = len(head) - len(head.translate(None, _CONTROL))
    return controls * 20 > len(head)


def _binary_stl(head: bytes, size: int) -> Content | None:
    if size < 84 + 50 or len(head) < 84:
        return None
    count = int.from_bytes(head[80:84], "little")
    if size != 84 + 50 * count:
        return None
    return Content(
        "a binary STL",
        f"has the size of a binary STL of {count:,} triangles ({size:,} = 84 + 50 x {count:,} "
        "bytes)",
        ".stl",
    )


def _zip(path: Path) -> Content:
    try:
        with zipfile.ZipFile(path) as archive:
            names = archive.namelist()
    except (zipfile.BadZipFile, OSError, EOFError, ValueError, NotImplementedError):
        return Content("a zip archive", "starts like a zip archive", None, _ARCHIVE_FIX)
    lower = [name.lower() for name in names]
    if any(name.startswith("3d/") and name.endswith(".model") for name in lower):
        return Content("a 3MF package", "is a 3MF package (a zip archive with a 3D model)", ".3mf")
    models = [n for n, low in zip(names, lower, strict=True) if low.endswith(_MODEL_SUFFIXES)]
    if models:
        return Content(
            "a zip archive",
            f"is a zip archive holding {models[0]!r}",
            None,
            f"unpack it and give {models[0]!r}",
        )
    return Content("a zip archive", "is a zip archive", None, _ARCHIVE_FIX)


def _gzip(head: bytes) -> Content:
    """Say that a file is gzip-compressed, and what it holds if its first bytes tell."""
    try:
        inner = zlib.decompressobj(16 + zlib.MAX_WBITS).decompress(head, HEAD_BYTES)
    except zlib.error:
        inner = b""
    found = None if is_binary(inner) else _text_kind(inner)
    if found is None:
        return Content("a gzip file", "is gzip-compressed", None, "decompress it (gunzip)")
    suffix = f" and give the {found.suffix} file it holds" if found.suffix else ""
    return Content(
        f"gzip-compressed {found.what}",
        f"is {found.what}, gzip-compressed",
        None,
        f"decompress it (gunzip){suffix}",
    )


def _text_kind(head: bytes) -> Content | None:
    """Say what a text file is, from its first line or its first statements."""
    text = _text_start(head)
    lower = text[:512].lower()
    if lower.startswith(b"solid") and b"facet" in lower:
        return Content("an ASCII STL", "starts like an ASCII STL ('solid ... facet')", ".stl")
    if text.startswith(b"#VRML V2.0"):
        return Content("a VRML 2.0 file", "starts like a VRML 2.0 file ('#VRML V2.0')", ".wrl")
    if text.startswith(b"#VRML"):
        return Content(
            "a VRML 1.0 file", "starts like a VRML 1.0 file", None, "export it as VRML 2.0 (.wrl)"
        )
    if _OFF_HEADER.match(_first_data_line(text)):
        return Content("an OFF", "starts like an OFF ('OFF')", ".off")
    if text.startswith(b"{") and any(key in head for key in _GLTF_KEYS):
        return Content("a glTF (JSON) file", "is a glTF (JSON) document", ".gltf")
    if lower.startswith(b"<"):
        return _markup(lower)
    vertices = len(_OBJ_VERTEX.findall(text))
    if vertices >= 3 or (vertices and _OBJ_FACE.search(text)):
        return Content("an OBJ", "is an OBJ ('v x y z' lines)", ".obj")
    if re.search(rb"^[ \t]*newmtl[ \t]", text, re.M):
        return Content(
            "an MTL material library",
            "is an MTL material library ('newmtl')",
            None,
            "give the .obj file whose 'mtllib' line names it",
        )
    return None


def _markup(lower: bytes) -> Content:
    if b"<!doctype html" in lower or b"<html" in lower:
        return Content("an HTML page", "is an HTML page", None, "download the model file itself")
    if b"<x3d" in lower:
        return Content("an X3D file", "is an X3D file", None, "export it as VRML 2.0 (.wrl)")
    if b"<collada" in lower:
        return Content("a COLLADA file", "is a COLLADA (.dae) file", None, _EXPORT_FIX)
    if b"<amf" in lower:
        return Content("an AMF file", "is an AMF file", None, "export it as 3MF")
    if b"<model" in lower and b"3dmanufacturing" in lower:
        return Content(
            "the model part of a 3MF",
            "is the XML model part of a 3MF package, without the package",
            None,
            "give the .3mf file it came from",
        )
    return Content("an XML document", "is an XML document", None, _OTHER_FIX)


def _text_start(head: bytes) -> bytes:
    """Return the bytes without a UTF-8 byte order mark and leading white space."""
    return head.removeprefix(_BOM).lstrip()


def _first_data_line(text: bytes) -> bytes:
    """Return the first line that is not a '#' comment or blank (of the first 64)."""
    for line in text.split(b"\n", 64)[:64]:
        stripped = line.strip()
        if stripped and not stripped.startswith(b"#"):
            return stripped
    return b""


def _is_utf16(head: bytes) -> bool:
    """Whether bytes are UTF-16 text without a byte order mark (every other byte zero)."""
    sample = head[:256]
    if len(sample) < 8:
        return False
    for zeros, chars in ((sample[1::2], sample[0::2]), (sample[0::2], sample[1::2])):
        if not zeros.strip(b"\x00") and not is_binary(chars) and b"\x00" not in chars:
            return True
    return False


def _is_windows_program(head: bytes) -> bool:
    if len(head) < 64:
        return False
    at = struct.unpack_from("<I", head, 60)[0]
    return head[at : at + 4] == b"PE\x00\x00"


def _hex(head: bytes) -> str:
    return " ".join(f"{byte:02x}" for byte in head[:8])
