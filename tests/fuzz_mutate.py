"""Hypothesis strategies of structural damage to a :class:`fuzz_models.Model`.

A mutation is a small frozen object drawn by Hypothesis that edits a model's files when
applied; the places it hits (which file, which number, which JSON node or XML element)
are drawn as plain integers and taken modulo what the file has, so that the strategies
need not know the files and shrink well. Kinds of damage:

- text: a number (a count, an index, a coordinate) replaced by a huge, negative, zero,
  NaN, infinite or malformed one; a word replaced (broken references); a line dropped or
  duplicated (missing or repeated headers);
- bytes: truncation anywhere, random bytes, inserted tokens, a 4-byte field of a binary
  file overwritten (counts, lengths, floats);
- JSON (glTF, GLB): a value replaced by one of the wrong type or a broken reference, a
  key deleted, a value nested thousands deep;
- XML (3MF): an attribute set to a bad value or deleted, an element dropped or repeated,
  components 1000 deep, unknown elements nested deep, a package entry dropped;
- VRML: brackets and groups nested deep;
- companions: a texture, MTL or buffer deleted, emptied or replaced by garbage.

Structured edits apply before byte-level ones (a byte edit packs a 3MF's entries).
"""

from __future__ import annotations

import json
import re
import struct
from dataclasses import dataclass, replace
from typing import Any

from builders import glb_chunks
from fuzz_models import MODEL_ENTRY, Model

EVIL_NUMBERS = [
    b"99999999999999999999", b"-99999999999999999999", b"-1", b"0", b"-0", b"1", b"3",
    b"2147483648", b"4294967296", b"9223372036854775808", b"18446744073709551616",
    b"1e308", b"-1e308", b"1e309", b"nan", b"NaN", b"inf", b"-inf", b"1e-320", b"0x10",
    b"1.5", b"", b"3e", b"1" * 400, b"x",
]  # fmt: skip
EVIL_WORDS = [b"", b"gone.png", b"../x.png", b"/etc/hostname", b"gone", b"\xff\xfe", b"a" * 5000]
TOKENS = [b"1e300", b"-", b"nan", b"999999999", b'"', b"{", b"}", b"[", b"]", b"<", b"/>", b"\0"]
FIELDS = [0xFFFFFFFF, 0x7FFFFFFF, 0x80000000, 0, 1, 0x7FC00000, 0x7F800000, 0x7F7FFFFF]
EVIL_VALUES: list[Any] = [
    "x", -1, 0, 1, 99, 10**20, -(10**20), 2.5, float("nan"), float("inf"), 1e308, None, True,
    [], {}, [1, 2], {"index": 0}, "../x.png", "gone.bin", [float("nan")] * 16,
]  # fmt: skip
EVIL_ATTRIBUTES = [
    "", "x", "-1", "0", "99", "99999999999999999999", "nan", "inf", "1e308", "#GG0000", "#FF",
    "1 0 0 0 1 0 0 0 1 nan 0 0", "0 0 0 0 0 0 0 0 0 0 0 0", "/3D/gone.model", "2 2 2 2",
    "mix mix screen",
]  # fmt: skip
NUMBER = re.compile(rb"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
WORD = re.compile(rb"[A-Za-z_][\w./]*")
DEEP = [10, 100, 1000, 100_000]


def pick(items: list[Any], at: int) -> Any:
    return items[at % len(items)]


def _target(model: Model, at: int) -> str:
    """A file (or a 3MF's package entry, ``entry:NAME``) to damage."""
    names = sorted(model.files) + [f"entry:{n}" for n in sorted(model.entries or {})]
    return str(pick(names, at))


def read(model: Model, name: str) -> bytes:
    if name.startswith("entry:"):
        assert model.entries is not None
        return model.entries[name[6:]]
    return model.files[name]


def put(model: Model, name: str, data: bytes | None) -> Model:
    """``model`` with file (or entry) ``name`` replaced by ``data``, or deleted if None."""
    if name.startswith("entry:"):
        entries = dict(model.entries or {})
        entries.pop(name[6:]) if data is None else entries.__setitem__(name[6:], data)
        return replace(model, entries=entries)
    files = dict(model.files)
    files.pop(name) if data is None else files.__setitem__(name, data)
    return replace(model, files=files)


@dataclass(frozen=True)
class Edit:
    """A mutation: ``what`` it does, in which ``file``, ``at`` which place, with which ``value``
    (the integers are taken modulo what there is)."""

    what: str
    file: int
    at: int
    value: int


class Text(Edit):
    """Replace the ``at``-th number or word of a file, or drop or repeat its ``at``-th line.

    ``what``: "number", "word", "drop line", "repeat line".
    """

    def apply(self, model: Model) -> Model:
        name = _target(model, self.file)
        data = read(model, name)
        if self.what in ("number", "word"):
            matches = list((NUMBER if self.what == "number" else WORD).finditer(data))
            if not matches:
                return model
            hit = pick(matches, self.at)
            new = pick(EVIL_NUMBERS if self.what == "number" else EVIL_WORDS, self.value)
            return put(model, name, data[: hit.start()] + new + data[hit.end() :])
        lines = data.split(b"\n")
        at = self.at % len(lines)
        lines[at : at + 1] = [] if self.what == "drop line" else [lines[at]] * (2 + self.value % 3)
        return put(model, name, b"\n".join(lines))


class Bytes(Edit):
    """Truncate a file, flip bytes, insert a token, or overwrite a 4-byte binary field.

    ``what``: "truncate", "noise", "insert", "field".
    """

    def apply(self, model: Model) -> Model:
        model = model.packed()
        name = _target(model, self.file)
        data = bytearray(read(model, name))
        at = self.at % (len(data) + 1)
        if self.what == "truncate":
            del data[at:]
        elif self.what == "noise":
            data[at : at + 1] = bytes([self.value % 256])
        elif self.what == "insert":
            data[at:at] = pick(TOKENS, self.value) * (1 + self.value % 7)
        else:
            at -= at % 4
            data[at : at + 4] = struct.pack("<I", pick(FIELDS, self.value))
        return put(model, name, bytes(data))


@dataclass(frozen=True)
class Companion:
    """Delete a texture, MTL, buffer or package entry, empty it, or cut it in half."""

    what: str  # "delete", "empty", "half"
    file: int

    def apply(self, model: Model) -> Model:
        names = [n for n in _names(model) if n not in (model.name, f"entry:{MODEL_ENTRY}")]
        if not names:
            return model
        name = pick(names, self.file)
        data = read(model, name)
        return put(
            model, name, {"delete": None, "empty": b"", "half": data[: len(data) // 2]}[self.what]
        )


def _names(model: Model) -> list[str]:
    return sorted(model.files) + [f"entry:{n}" for n in sorted(model.entries or {})]


def _nodes(node: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Paths to every value in a JSON tree."""
    paths = [prefix] if prefix else []
    children = (
        node.items()
        if isinstance(node, dict)
        else enumerate(node)
        if isinstance(node, list)
        else ()
    )
    for key, child in children:
        paths += _nodes(child, (*prefix, key))
    return paths


def _json_parts(model: Model) -> tuple[Any, bytes] | None:
    """The document and binary chunk; None after an earlier edit nested it too deep to read."""
    data = model.files[model.name]
    try:
        if model.name.endswith(".glb"):
            (length,) = struct.unpack_from("<I", data, 12)
            return json.loads(data[20 : 20 + length]), data[28 + length :]
        return json.loads(data), b""
    except RecursionError:
        return None


@dataclass(frozen=True)
class Json:
    """Set a glTF value to a wrong type or broken reference, delete it, or nest it deep."""

    what: str  # "set", "delete", "nest"
    at: int
    value: int

    def apply(self, model: Model) -> Model:
        parts = _json_parts(model)
        if parts is None:
            return model
        document, binary = parts
        paths = _nodes(document)
        if not paths:  # earlier edits left an empty document
            return model
        path = pick(paths, self.at)
        parent = document
        for key in path[:-1]:
            parent = parent[key]
        if self.what == "delete":
            del parent[path[-1]]
            text = json.dumps(document)
        elif self.what == "set":
            parent[path[-1]] = pick(EVIL_VALUES, self.value)
            text = json.dumps(document)
        else:  # nested in text: json.dumps itself would recurse too deep
            parent[path[-1]] = "@DEEP@"
            depth = pick(DEEP, self.value)
            opener, closer = ("[", "]") if self.value % 2 else ('{"a":', "}")
            text = json.dumps(document).replace('"@DEEP@"', opener * depth + "0" + closer * depth)
        if model.name.endswith(".glb"):
            return put(model, model.name, glb_chunks(text.encode(), binary))
        return put(model, model.name, text.encode())
