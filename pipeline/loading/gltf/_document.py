"""A glTF 2.0 or GLB document, checked before trimesh or the colour reader sees it.

The buffers are checked against the bytes that really exist (a GLB that declares a
1e12-byte buffer is refused), buffer views and accessors against their buffers, and a
buffer-less accessor may not hold more than ``3 * max_faces`` items; external URIs follow
the path policy of :mod:`shellvox.loading._references` (inside the model's folder unless
``--force``; ``data:`` URIs are fine; remote URIs are refused). See
:mod:`shellvox.loading.gltf._reader`.
"""

from __future__ import annotations

import base64
import binascii
import json
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from urllib.parse import unquote

from shellvox.config import LoadOptions
from shellvox.errors import InputError, opt
from shellvox.loading._references import check_inside, is_file

COMPONENT_BYTES = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
TYPE_COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
FIX = "the file is truncated or corrupt; export it again"


@dataclass(frozen=True)
class GltfDocument:
    """A parsed glTF or GLB file."""

    path: Path
    json: dict[str, Any]
    glb: bool
    data: bytes  # the whole file
    json_chunk: tuple[int, int]  # GLB: start and end of the JSON chunk (header included)
    binary: bytes | None  # GLB: the BIN chunk


def read_document(path: Path) -> GltfDocument:
    """Parse a ``.gltf`` (JSON) or ``.glb`` (binary container) file; refuse a malformed one."""
    data = path.read_bytes()
    if data[:4] != b"glTF":
        try:
            document = json.loads(data)
        except (ValueError, UnicodeDecodeError) as error:
            raise InputError(path, f"is neither GLB nor glTF JSON ({error})", FIX) from None
        return _checked(GltfDocument(path, document, False, data, (0, 0), None))
    try:
        _, version, length = struct.unpack_from("<4sII", data, 0)
        json_length, json_type = struct.unpack_from("<I4s", data, 12)
    except struct.error:
        raise InputError(path, "has a truncated GLB header", FIX) from None
    if length > len(data) or json_type != b"JSON" or 20 + json_length > len(data):
        raise InputError(
            path,
            f"is a truncated or malformed GLB (it declares {length:,} bytes, holds {len(data):,})",
            FIX,
        )
    end = 20 + json_length
    binary = None
    if end + 8 <= len(data):
        bin_length, bin_type = struct.unpack_from("<I4s", data, end)
        if bin_type == b"BIN\0":
            if end + 8 + bin_length > len(data):
                raise InputError(
                    path,
                    f"its BIN chunk declares {bin_length:,} bytes but the file ends "
                    f"{len(data) - end - 8:,} bytes after its start",
                    FIX,
                )
            binary = data[end + 8 : end + 8 + bin_length]
    try:
        document = json.loads(data[20:end])
    except (ValueError, UnicodeDecodeError) as error:
        raise InputError(path, f"has a malformed JSON chunk ({error})", FIX) from None
    if version != 2:
        raise InputError(path, f"is GLB version {version}", "export it as glTF 2.0")
    return _checked(GltfDocument(path, document, True, data, (12, end), binary))


def _checked(document: GltfDocument) -> GltfDocument:
    if not isinstance(document.json, dict):
        raise InputError(document.path, "its JSON is not a glTF document", FIX)
    version = str(document.json.get("asset", {}).get("version", "2.0"))
    if not version.startswith("2"):
        raise InputError(document.path, f"is glTF version {version}", "export it as glTF 2.0")
    return document


def check_buffers(document: GltfDocument, options: LoadOptions) -> list[Path | bytes | None]:
    """Check buffers, views and accessors; return where each buffer's bytes are."""
    path, tree = document.path, document.json
    sources: list[Path | bytes | None] = []
    lengths: list[int] = []
    for index, buffer in enumerate(tree.get("buffers", [])):
        declared = count_of(path, f"buffer {index}", buffer.get("byteLength"))
        uri = buffer.get("uri")
        if uri is None:
            if not document.glb or index != 0:
                raise InputError(path, f"buffer {index} has no uri", FIX)
            source: Path | bytes | None = document.binary
            held, where = len(document.binary or b""), "the GLB's BIN chunk"
        elif str(uri).startswith("data:"):
            source = data_uri(path, f"buffer {index}", str(uri))
            held, where = len(source), "its data: URI"
        else:
            file = external_file(document, str(uri), f"buffer {index} ({uri!r})", options)
            if not is_file(file):
                raise InputError(
                    path,
                    f"buffer file {uri!r} is missing",
                    "put it beside the .gltf file, or export the model as one .glb",
                )
            source, held, where = file, file.stat().st_size, f"{uri!r}"
        if declared > held:
            raise InputError(
                path,
                f"buffer {index} declares {declared:,} bytes but {where} holds only {held:,}",
                FIX,
            )
        sources.append(source)
        lengths.append(declared)
    views = tree.get("bufferViews", [])
    for index, view in enumerate(views):
        buffer = view.get("buffer")
        offset = count_of(path, f"bufferView {index} byteOffset", view.get("byteOffset", 0))
        length = count_of(path, f"bufferView {index} byteLength", view.get("byteLength"))
        if not isinstance(buffer, int) or not 0 <= buffer < len(lengths):
            raise InputError(path, f"bufferView {index} refers to a missing buffer", FIX)
        if offset + length > lengths[buffer]:
            raise InputError(
                path,
                f"bufferView {index} ends at byte {offset + length:,}, past the end of "
                f"buffer {buffer} ({lengths[buffer]:,} bytes)",
                FIX,
            )
    for index, accessor in enumerate(tree.get("accessors", [])):
        _check_accessor(path, index, accessor, views, options)
    return sources


def _check_accessor(
    path: Path, index: int, accessor: dict[str, Any], views: list[Any], options: LoadOptions
) -> None:
    count = count_of(path, f"accessor {index} count", accessor.get("count"))
    size = COMPONENT_BYTES.get(accessor.get("componentType", 0))
    components = TYPE_COMPONENTS.get(accessor.get("type", ""))
    if size is None or components is None:
        raise InputError(path, f"accessor {index} has an unknown componentType or type", FIX)
    view_index = accessor.get("bufferView")
    if view_index is None:  # zeros (or sparse): nothing bounds it but the face limit
        if count > 3 * options.max_faces and not options.force:
            raise InputError(
                path,
                f"accessor {index} declares {count:,} items without data, more than "
                f"3 x {opt('max_faces')} ({3 * options.max_faces:,})",
                f"export it again, or pass {opt('force')}",
            )
        return
    if not isinstance(view_index, int) or not 0 <= view_index < len(views):
        raise InputError(path, f"accessor {index} refers to a missing bufferView", FIX)
    view = views[view_index]
    offset = count_of(path, f"accessor {index} byteOffset", accessor.get("byteOffset", 0))
    element = size * components
    stride = count_of(path, f"bufferView {view_index} byteStride", view.get("byteStride", element))
    needed = offset + (max(count, 1) - 1) * max(stride, element) + element if count else 0
    if needed > view["byteLength"]:
        raise InputError(
            path,
            f"accessor {index} needs {needed:,} bytes but bufferView {view_index} holds "
            f"{view['byteLength']:,}",
            FIX,
        )


def count_of(path: Path, what: str, value: Any) -> int:
    """Return `value` as a count (a non-negative int) or refuse the file."""
    if not isinstance(value, int) or isinstance(value, bool) or value < 0:
        raise InputError(path, f"{what} is {value!r}, not a count of bytes or items", FIX)
    return value


def data_uri(path: Path, what: str, uri: str) -> bytes:
    """Return the bytes of a base64 ``data:`` URI or refuse the file."""
    head, _, payload = uri.partition(",")
    try:
        if head.endswith(";base64"):
            return base64.b64decode(payload, validate=True)
        return unquote(payload).encode("latin-1")
    except (binascii.Error, ValueError, UnicodeEncodeError):
        raise InputError(path, f"{what} has a malformed data: URI", FIX) from None


def external_file(document: GltfDocument, uri: str, what: str, options: LoadOptions) -> Path:
    """Return the file an external URI names, under the path policy (remote URIs refused)."""
    if "://" in uri:
        raise InputError(
            document.path,
            f"{what} is a remote URI, which shellvox does not fetch",
            "download it into the model's folder and refer to it by a relative name",
        )
    candidate = document.path.parent / unquote(uri)
    return check_inside(document.path, candidate, what, force=options.force)
