"""A small VRML 2.0 (VRML97, ISO/IEC 14772-1) parser: text to a tree of nodes.

No schema is needed for the subset shellvox reads: a field's value is a node (``Type {
... }``, ``DEF name Type { ... }``, ``USE name``, ``NULL``), a list in brackets, or a run
of scalars (numbers, strings, ``TRUE``/``FALSE``). Lists of numbers, the bulk of a file,
are parsed by numpy in one go. ``PROTO``/``EXTERNPROTO`` declarations and ``ROUTE``
statements are skipped (their names are reported so that the reader can warn), ``#``
comments and commas are whitespace. A malformed file is an
:class:`~shellvox.errors.InputError` naming the line.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Union

import numpy as np
from numpy.typing import NDArray

from shellvox.errors import InputError

FIX = "export it again as VRML 2.0"
_SPACE = re.compile(r"(?:[\s,]+|#[^\n\r]*)*")
_WORD = re.compile(r"[^\x00-\x20\"'#,.\[\]\\{}0-9+\-][^\x00-\x20\"'#,.\[\]\\{}]*")
_NUMBER = re.compile(r"[+\-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+\-]?\d+)?|0[xX][0-9a-fA-F]+")
_STRING = re.compile(r'"((?:[^"\\]|\\.)*)"', re.S)
# Numbers, separators and comments, possessive: linear, and it stops at the first other
# character instead of scanning on to the list's end (nested lists would be quadratic).
_NUMERIC_LIST = re.compile(r"(?:[\s,0-9eE+\-.]++|#[^\n\r]*+)*+")

Value = Union["Node", None, str, bool, float, NDArray[np.float64], list["Value"]]


@dataclass(eq=False)
class Node:
    """One VRML node: its type name and fields (values as parsed)."""

    type: str
    fields: dict[str, Value] = field(default_factory=dict)


@dataclass
class Scene:
    """A parsed file: top-level nodes and the names of what was skipped."""

    nodes: list[Node]
    skipped: set[str]


def parse_vrml(path: Path, text: str) -> Scene:
    r"""Parse VRML 2.0 text.

    Parameters
    ----------
    path : Path
        The file, for messages.
    text : str
        Its content, starting with the ``#VRML V2.0`` header.

    Returns
    -------
    Scene

    Examples
    --------
    >>> scene = parse_vrml(Path("m.wrl"), "#VRML V2.0 utf8\nTransform { scale 2 2 2 }")
    >>> scene.nodes[0].fields["scale"].tolist()
    [2.0, 2.0, 2.0]
    """
    if not text.startswith("#VRML V2.0"):
        first = text.splitlines()[0][:40] if text else ""
        raise InputError(
            path, f"is not VRML 2.0 (its first line is {first!r})", "export it as VRML 2.0 (VRML97)"
        )
    parser = _Parser(path, text)
    nodes = []
    while True:
        parser.space()
        if parser.at >= len(text):
            break
        value = parser.statement()
        if isinstance(value, Node):
            nodes.append(value)
    return Scene(nodes, parser.skipped)


class _Parser:
    def __init__(self, path: Path, text: str) -> None:
        self.path, self.text, self.at = path, text, text.index("\n") + 1 if "\n" in text else 0
        self.names: dict[str, Node] = {}
        self.skipped: set[str] = set()

    def fail(self, problem: str) -> InputError:
        line = self.text.count("\n", 0, self.at) + 1
        return InputError(self.path, f"line {line}: {problem}", FIX)

    def space(self) -> None:
        match = _SPACE.match(self.text, self.at)
        self.at = match.end() if match else self.at

    def peek(self, pattern: re.Pattern[str]) -> re.Match[str] | None:
        self.space()
        return pattern.match(self.text, self.at)

    def word(self) -> str:
        match = self.peek(_WORD)
        if match is None:
            found = repr(self.text[self.at : self.at + 20]) if self.at < len(self.text) else ""
            raise self.fail(f"expected a name, found {found or 'the end of the file'}")
        self.at = match.end()
        return match.group()

    def expect(self, char: str) -> None:
        self.space()
        if not self.text.startswith(char, self.at):
            found = self.text[self.at : self.at + 20] or "the end of the file"
            raise self.fail(f"expected {char!r}, found {found!r}")
        self.at += 1

    def statement(self) -> Value:
        """Parse a top-level statement: a node, or a PROTO/EXTERNPROTO/ROUTE to skip."""
        match = self.peek(_WORD)
        if match and match.group() in ("PROTO", "EXTERNPROTO"):
            self.at = match.end()
            self.skipped.add(f"{match.group()} {self.word()}")
            while self.peek(_WORD) is None and not self.text.startswith("[", self.at):
                self.at += 1  # (EXTERNPROTO's url follows its interface)
            self.skip_balanced("[", "]")
            if match.group() == "PROTO":
                self.skip_balanced("{", "}")
            else:
                self.value()
            return None
        if match and match.group() == "ROUTE":
            self.at = match.end()
            self.skipped.add("ROUTE")
            for _ in range(3):  # ROUTE a.b TO c.d
                self.space()
                end = self.at
                while end < len(self.text) and not self.text[end].isspace():
                    end += 1
                self.at = end
            return None
        return self.value()

    def skip_balanced(self, opening: str, closing: str) -> None:
        self.expect(opening)
        depth = 1
        while depth:
            if self.at >= len(self.text):
                raise self.fail(f"unbalanced {opening!r}")
            char = self.text[self.at]
            if char == '"':
                match = _STRING.match(self.text, self.at)
                self.at = match.end() if match else len(self.text)
                continue
            if char == "#":
                self.space()
                continue
            depth += (char == opening) - (char == closing)
            self.at += 1

    def value(self) -> Value:
        self.space()
        if self.at >= len(self.text):
            raise self.fail("the file ends inside a node")
        char = self.text[self.at]
        if char == "[":
            return self.list_value()
        if char == '"' or _NUMBER.match(self.text, self.at):
            return self.scalars()
        name = self.word()
        if name in ("TRUE", "FALSE"):
            self.at -= len(name)
            return self.scalars()
        if name == "NULL":
            return None
        if name == "USE":
            used = self.word()
            if used not in self.names:
                raise self.fail(f"USE of undefined name {used!r}")
            return self.names[used]
        defined = None
        if name == "DEF":
            defined, name = self.word(), self.word()
        node = Node(name)
        if defined is not None:
            self.names[defined] = node
        self.expect("{")
        while True:
            self.space()
            if self.text.startswith("}", self.at):
                self.at += 1
                return node
            key = self.word()
            if key in ("ROUTE", "PROTO", "EXTERNPROTO"):
                self.at -= len(key)
                self.statement()
                continue
            if key in ("eventIn", "eventOut"):  # a Script's interface: type and name
                self.word()
                self.word()
                continue
            if key in ("field", "exposedField"):
                self.word()
                key = self.word()
            node.fields[key] = self.value()

    def list_value(self) -> Value:
        self.expect("[")
        match = _NUMERIC_LIST.match(self.text, self.at)
        end = match.end() if match else -1
        if end >= 0 and self.text.startswith("]", end):
            chunk = self.text[self.at : end]
            if "#" in chunk:
                chunk = re.sub(r"#[^\n\r]*", " ", chunk)
            try:
                numbers = np.array(chunk.replace(",", " ").split(), dtype=np.float64)
            except ValueError:
                raise self.fail("malformed number in a list") from None
            self.at = end + 1
            return numbers
        items: list[Value] = []
        while True:
            self.space()
            if self.text.startswith("]", self.at):
                self.at += 1
                break
            item = self.value()
            items.extend(item if isinstance(item, list) else [item])
        return items

    def scalars(self) -> Value:
        """Parse a run of numbers, strings or booleans: one value, or a list of several."""
        items: list[Value] = []
        while True:
            self.space()
            if self.text.startswith('"', self.at):
                match = _STRING.match(self.text, self.at)
                if match is None:
                    raise self.fail("unterminated string")
                items.append(re.sub(r"\\(.)", r"\1", match.group(1)))
            elif (match := _NUMBER.match(self.text, self.at)) is not None:
                number = match.group()
                items.append(float(int(number, 16)) if "x" in number.lower() else float(number))
            elif (match := _WORD.match(self.text, self.at)) is not None and match.group() in (
                "TRUE",
                "FALSE",
            ):
                items.append(match.group() == "TRUE")
            else:
                break
            self.at = match.end()
        if all(isinstance(i, float) for i in items) and len(items) > 1:
            return np.array(items, dtype=np.float64)
        return items[0] if len(items) == 1 else items
