"""Structural damage to 3MF model parts (XML) and VRML, and the per-format mutation lists.

See :mod:`fuzz_mutate` for the kinds of damage and the text, byte, JSON and companion
mutations; :func:`cases` draws a valid model and zero to four mutations of its format.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from xml.etree import ElementTree

from builders import CORE_NS, MATERIAL_NS
from fuzz_models import MODELS, PRODUCTION_NS, Model
from fuzz_mutate import (
    DEEP,
    EVIL_ATTRIBUTES,
    Bytes,
    Companion,
    Edit,
    Json,
    Text,
    pick,
    put,
    read,
)
from hypothesis import strategies as st

ElementTree.register_namespace("", CORE_NS)
ElementTree.register_namespace("m", MATERIAL_NS)
ElementTree.register_namespace("p", PRODUCTION_NS)
ATTRIBUTES = [
    "objectid", "pid", "pindex", "p1", "p2", "p3", "texid", "path", "pids", "pindices",
    "blendmethods", "transform", "v1", "v2", "v3", "x", "y", "z", "u", "v", "id", "color",
    "displaycolor", "unit", "type", f"{{{PRODUCTION_NS}}}path",
]  # fmt: skip


def _parts(model: Model) -> list[str]:
    return [f"entry:{n}" for n in sorted(model.entries or {}) if n.endswith(".model")]


@dataclass(frozen=True)
class Xml(Edit):
    """Set or delete an attribute of a 3MF element, or drop or repeat the element.

    ``what``: "set", "delete", "drop", "repeat"; ``file`` picks the model part.
    """

    attribute: int

    def apply(self, model: Model) -> Model:
        parts = _parts(model)
        if not parts:
            return model
        name = pick(parts, self.file)
        root = ElementTree.fromstring(read(model, name))
        pairs = [(parent, child) for parent in root.iter() for child in parent]
        if not pairs:  # earlier edits dropped every element
            return model
        parent, element = pick(pairs, self.at)
        key = pick(sorted(element.attrib) + ATTRIBUTES, self.attribute)
        if self.what == "set":
            element.set(key, pick(EVIL_ATTRIBUTES, self.value))
        elif self.what == "delete":
            element.attrib.pop(key, None)
        elif self.what == "drop":
            parent.remove(element)
        else:
            parent.insert(list(parent).index(element), element)
        return put(model, name, ElementTree.tostring(root, xml_declaration=True))


@dataclass(frozen=True)
class Deep:
    """Nest deep: 3MF components (a chain of objects) or unknown elements; VRML groups or
    brackets; written as text (ElementTree would recurse while writing them)."""

    what: str  # "components", "elements", "groups", "brackets"
    depth: int
    at: int

    def apply(self, model: Model) -> Model:
        depth = pick(DEEP, self.depth)
        if self.what == "components":  # a chain of objects: 10,000 is far past the limit of
            depth = min(depth, 10_000)  # 32 and keeps the part's XML under 2 MB
        if self.what in ("components", "elements"):
            name = pick(_parts(model), self.at) if _parts(model) else None
            if name is None:
                return model
            text = read(model, name).decode()
            if self.what == "elements":
                text = text.replace("<resources>", "<resources>" + "<x>" * depth + "</x>" * depth)
            else:
                chain = "".join(
                    f'<object id="{1000 + k}" type="model"><components><component objectid='
                    f'"{1000 + k - 1 if k else 1}"/></components></object>'
                    for k in range(depth)
                )
                text = text.replace("</resources>", chain + "</resources>")
                text = re.sub(r'<item objectid="\d+"', f'<item objectid="{999 + depth}"', text)
            return put(model, name, text.encode())
        data = model.files[model.name]
        head, _, body = data.partition(b"\n")
        if self.what == "groups":
            body = b"Group { children [ " * depth + body + b" ] }" * depth
        else:
            at = self.at % (len(body) + 1)
            body = body[:at] + b"[ " * depth + body[at:]
        return put(model, model.name, head + b"\n" + body)


_STAGE = {Json: 0, Xml: 0, Deep: 1, Text: 2, Companion: 3, Bytes: 4}
_INDEX = st.integers(0, 2**16)


def _ops(fmt: str) -> st.SearchStrategy[object]:
    text = ["number", "word", "drop line", "repeat line"]
    ops = [
        st.builds(Text, st.sampled_from(text), _INDEX, _INDEX, _INDEX),
        st.builds(
            Bytes, st.sampled_from(["truncate", "noise", "insert", "field"]), _INDEX, _INDEX, _INDEX
        ),
    ]
    if fmt in ("obj", "ply", "gltf", "3mf", "wrl"):
        ops.append(st.builds(Companion, st.sampled_from(["delete", "empty", "half"]), _INDEX))
    if fmt == "gltf":
        ops.append(st.builds(Json, st.sampled_from(["set", "delete", "nest"]), _INDEX, _INDEX))
    if fmt == "3mf":
        what = st.sampled_from(["set", "delete", "drop", "repeat"])
        ops.append(st.builds(Xml, what, _INDEX, _INDEX, _INDEX, _INDEX))
        ops.append(st.builds(Deep, st.sampled_from(["components", "elements"]), _INDEX, _INDEX))
    if fmt == "wrl":
        ops.append(st.builds(Deep, st.sampled_from(["groups", "brackets"]), _INDEX, _INDEX))
    return st.one_of(*ops)


@st.composite
def cases(draw: st.DrawFn, fmt: str) -> tuple[Model, tuple[object, ...]]:
    """A valid model of ``fmt`` and its mutations (none in about one case in eight)."""
    model = draw(MODELS[fmt])
    if draw(st.integers(0, 7)) == 0:
        return model, ()
    ops = draw(st.lists(_ops(fmt), min_size=1, max_size=4))
    return model, tuple(sorted(ops, key=lambda op: _STAGE[type(op)]))


def damaged(model: Model, ops: tuple[object, ...]) -> Model:
    """``model`` after every mutation of ``ops`` in order."""
    for op in ops:
        model = op.apply(model)  # type: ignore[attr-defined]
    return model
