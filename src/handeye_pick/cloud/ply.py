"""PLY headers: what a file declares, read and checked before any of its data is; ours, written.

A PLY file is a text header (``ply``, ``format``, ``element NAME COUNT`` each followed by its
``property TYPE NAME`` or ``property list COUNT_TYPE TYPE NAME`` lines, ``comment`` and
``obj_info`` lines, ``end_header``) and then each element's records in header order: one text line
a record (``ascii``) or packed binary records (``binary_little_endian``, ``binary_big_endian``).

Parsing errors are ``ValueError`` with a short reason; the caller names the file.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any, BinaryIO

import numpy as np

MAX_HEADER_BYTES = 65_536
"""Longest header read. Real ones are a few hundred bytes; a file that is not a PLY (or has no
newline at all) must not be read whole to look for the end of a header."""

_TYPE_CODES = {
    "char": "i1",
    "int8": "i1",
    "uchar": "u1",
    "uint8": "u1",
    "short": "i2",
    "int16": "i2",
    "ushort": "u2",
    "uint16": "u2",
    "int": "i4",
    "int32": "i4",
    "uint": "u4",
    "uint32": "u4",
    "float": "f4",
    "float32": "f4",
    "double": "f8",
    "float64": "f8",
}
_TYPE_NAMES = {"f4": "float", "f8": "double", "u1": "uchar"}  # the names Open3D and Zivid write
_BYTE_ORDERS = {"ascii": None, "binary_little_endian": "<", "binary_big_endian": ">"}
_END_HEADER = re.compile(rb"(?:^|\n)end_header\r?\n")


@dataclass(frozen=True)
class PlyProperty:
    """One property of an element: ``type`` is a numpy type code without byte order ("f4")."""

    name: str
    type: str
    count_type: str | None = None  # type code of a list property's length; None for a scalar


@dataclass(frozen=True)
class PlyElement:
    """An element as the header declares it: ``count`` records of ``properties``."""

    name: str
    count: int
    properties: tuple[PlyProperty, ...]

    @property
    def has_lists(self) -> bool:
        return any(p.count_type is not None for p in self.properties)

    def record_dtype(self, byte_order: str) -> np.dtype[Any]:
        """The structured dtype of one binary record (elements without list properties only)."""
        return np.dtype([(p.name, byte_order + p.type) for p in self.properties])

    def min_bytes(self, binary: bool) -> int:
        """The fewest bytes the element's records can take in the file.

        Binary: every scalar plus every list's length field (lists may be empty). Text: a digit
        and a separator for each property of each record.
        """
        if not binary:
            return self.count * max(2 * len(self.properties), 1)
        fixed = [np.dtype(p.count_type or p.type).itemsize for p in self.properties]
        return self.count * sum(fixed)


@dataclass(frozen=True)
class PlyHeader:
    """A parsed header. ``byte_order`` is "<" or ">" for binary data, None for ascii."""

    byte_order: str | None
    elements: tuple[PlyElement, ...]
    size: int  # bytes from the start of the file to the first record

    def element(self, name: str) -> PlyElement | None:
        return next((e for e in self.elements if e.name == name), None)


def read_ply_header(file: BinaryIO) -> PlyHeader:
    """Parse the header at the start of ``file`` and leave ``file`` at the first record.

    Raises:
        ValueError: not a PLY header, or one this parser does not understand.
    """
    start = file.read(MAX_HEADER_BYTES)
    if not start.startswith(b"ply"):
        raise ValueError("it does not start with 'ply'")
    end = _END_HEADER.search(start)
    if end is None:
        raise ValueError(f"no end_header line in its first {MAX_HEADER_BYTES} bytes")
    try:
        lines = start[: end.start()].decode("ascii").splitlines()
    except UnicodeDecodeError:
        raise ValueError("its header is not ASCII text") from None
    if lines[0].strip() != "ply":
        raise ValueError("it does not start with a 'ply' line")
    file.seek(end.end())
    byte_order, elements = _parse_lines(lines[1:])
    return PlyHeader(byte_order, elements, end.end())


def _parse_lines(lines: list[str]) -> tuple[str | None, tuple[PlyElement, ...]]:
    byte_order: str | None = None
    seen_format = False
    elements: list[tuple[str, int, list[PlyProperty]]] = []
    for number, line in enumerate(lines, start=2):
        words = line.split()
        if not words or words[0] in ("comment", "obj_info"):
            continue
        if words[0] == "format" and len(words) == 3 and words[1] in _BYTE_ORDERS:
            byte_order, seen_format = _BYTE_ORDERS[words[1]], True
        elif words[0] == "element" and len(words) == 3 and words[2].isdigit():
            elements.append((words[1], int(words[2]), []))
        elif words[0] == "property" and elements:
            prop = _parse_property(words, number)
            if any(p.name == prop.name for p in elements[-1][2]):
                raise ValueError(f"header line {number} repeats property {prop.name!r}")
            elements[-1][2].append(prop)
        else:
            raise ValueError(f"header line {number} is not understood: {line.strip()[:80]!r}")
    if not seen_format:
        raise ValueError("its header has no 'format ascii|binary_little_endian|binary_big_endian'")
    return byte_order, tuple(PlyElement(n, c, tuple(p)) for n, c, p in elements)


def _parse_property(words: list[str], number: int) -> PlyProperty:
    if len(words) == 3 and words[1] in _TYPE_CODES:
        return PlyProperty(words[2], _TYPE_CODES[words[1]])
    if len(words) == 5 and words[1] == "list" and {words[2], words[3]} <= set(_TYPE_CODES):
        return PlyProperty(words[4], _TYPE_CODES[words[3]], _TYPE_CODES[words[2]])
    raise ValueError(f"header line {number} is not a property: {' '.join(words)[:80]!r}")


def check_size(header: PlyHeader, file_size: int) -> None:
    """Refuse a header that declares more records than the file can hold, before reading any.

    Raises:
        ValueError: naming the element that does not fit.
    """
    available = file_size - header.size
    needed = 0
    for element in header.elements:
        needed += element.min_bytes(binary=header.byte_order is not None)
        if needed > available:
            raise ValueError(
                f"its header declares {element.count} {element.name} records, which need at "
                f"least {needed} bytes, but only {available} bytes follow the header"
            )


def vertex_header(count: int, fields: list[tuple[str, str]], comment: str) -> bytes:
    """The header of a binary little-endian file of ``count`` vertices.

    ``fields`` are (property name, type code) pairs with codes "f4", "f8" or "u1".
    """
    lines = ["ply", "format binary_little_endian 1.0", f"comment {comment}"]
    lines.append(f"element vertex {count}")
    lines += [f"property {_TYPE_NAMES[code]} {name}" for name, code in fields]
    lines.append("end_header")
    return ("\n".join(lines) + "\n").encode("ascii")
