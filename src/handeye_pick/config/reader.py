"""The strict YAML reader behind every input file the cell reads: the cell config, detection files
(``detection.py``) and calibration pose lists (``calibration/pose_list.py``).

``read_yaml_mapping`` parses one file with bounded, safe YAML; ``Fields`` opens one mapping of it,
refuses unknown keys and reads typed values. Every error is the caller's ``InputError`` subclass,
one line naming the file and the dotted key path (``motion.speed_mps``).
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import NoReturn

import numpy as np
import yaml
from numpy.typing import NDArray

from handeye_pick.errors import InputError
from handeye_pick.inputfiles import BoundedLoader, read_input_bytes, shown, yaml_problem


def read_yaml_mapping(path: Path, error: type[InputError], what: str = "file") -> object:
    """Parse ``path`` (a ``what``: "cell config", "detection file") as YAML with
    ``inputfiles.BoundedLoader``: safe constructors only, duplicate keys refused, size, values
    and nesting bounded.

    Raises ``error`` with one line naming the file (and the line and column of a YAML error).
    """
    data = read_input_bytes(path, what, error)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise error(f"{path}: not UTF-8 text (a binary file?)") from None
    try:
        return yaml.load(text, Loader=BoundedLoader)  # a SafeLoader subclass: safe
    except yaml.YAMLError as exc:
        raise error(f"{path}: not valid YAML: {yaml_problem(exc)}") from None


@dataclass(frozen=True)
class Number:
    """What one number key accepts: its unit, its bounds and, for an optional key, its default.

    The unit is the one in the key's name (``_mm``, ``_s``); it is only shown in messages.
    """

    unit: str  # as messages show it: "mm", "m/s", "deg", "%"
    minimum: float | None = None  # lowest accepted value (inclusive), or None
    above: float | None = None  # the value must be greater than this (exclusive), or None
    maximum: float | None = None  # highest accepted value (inclusive), or None
    default: float | None = None  # the value when the key is absent; None: the key is required


class Fields:
    """Typed access to one YAML mapping; every error names the source file and the key path.

    Unknown keys are refused when the mapping is opened, so a misspelt key never falls back to a
    default.
    """

    def __init__(
        self,
        data: object,
        *,
        source: str,
        prefix: str,
        allowed: Collection[str],
        error: type[InputError],
    ) -> None:
        self.source = source
        self.prefix = prefix
        self.error = error
        if not isinstance(data, dict):
            self.fail("", f"expected a mapping of keys, got {describe(data)}")
        self.data: dict[object, object] = data
        for key in data:
            if key not in allowed:
                name = str(key)[:80]  # a hostile file's key may be a megabyte long
                hint = difflib.get_close_matches(name, list(allowed), n=1)
                also = f"; did you mean {hint[0]!r}?" if hint else ""
                self.fail(name, f"unknown key (expected one of {', '.join(sorted(allowed))}){also}")

    def path(self, key: str) -> str:
        """The dotted key path, e.g. ``motion.speed_mps``."""
        if not self.prefix:
            return key
        return f"{self.prefix}.{key}" if key else self.prefix

    def fail(self, key: str, message: str) -> NoReturn:
        where = self.path(key) or "top level"
        raise self.error(f"{self.source}: {where}: {message}")

    def has(self, key: str) -> bool:
        return key in self.data

    def raw(self, key: str) -> object:
        """The value of a required key."""
        if key not in self.data:
            self.fail(key, "missing (required)")
        return self.data[key]

    def section(self, key: str, allowed: Collection[str]) -> Fields:
        """A nested mapping (required)."""
        return Fields(
            self.raw(key),
            source=self.source,
            prefix=self.path(key),
            allowed=allowed,
            error=self.error,
        )

    def number(self, key: str, numbers: Mapping[str, Number]) -> float:
        """A finite number (int or float, never bool) within the bounds ``numbers[key]`` gives,
        or its default when the key is absent and it has one."""
        spec = numbers[key]
        if spec.default is not None and key not in self.data:
            return spec.default
        value = self._to_float(key, self.raw(key))
        if spec.minimum is not None and value < spec.minimum:
            self.fail(key, f"must be at least {spec.minimum:g} {spec.unit}, got {value:g}")
        if spec.above is not None and value <= spec.above:
            self.fail(key, f"must be greater than {spec.above:g} {spec.unit}, got {value:g}")
        if spec.maximum is not None and value > spec.maximum:
            self.fail(key, f"must be at most {spec.maximum:g} {spec.unit}, got {value:g}")
        return value

    def integer(self, key: str, *, minimum: int, maximum: int) -> int:
        value = self.raw(key)
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(key, f"expected an integer, got {describe(value)}")
        if not minimum <= value <= maximum:
            self.fail(key, f"must be between {minimum} and {maximum}, got {value}")
        return value

    def boolean(self, key: str, *, default: bool | None = None) -> bool:
        if default is not None and key not in self.data:
            return default
        value = self.raw(key)
        if not isinstance(value, bool):
            self.fail(key, f"expected true or false, got {describe(value)}")
        return value

    def string(self, key: str, *, choices: Collection[str] | None = None) -> str:
        value = self.raw(key)
        if not isinstance(value, str) or not value.strip():
            self.fail(key, f"expected a non-empty string, got {describe(value)}")
        if choices is not None and value not in choices:
            self.fail(key, f"expected one of {', '.join(choices)}, got {value!r}")
        return value

    def vector(self, key: str, length: int) -> NDArray[np.float64]:
        """A list of ``length`` finite numbers."""
        value = self.raw(key)
        if not isinstance(value, list) or len(value) != length:
            self.fail(key, f"expected a list of {length} numbers, got {describe(value)}")
        return np.array([self._to_float(f"{key}[{i}]", v) for i, v in enumerate(value)])

    def matrix(self, key: str, rows: int, cols: int) -> NDArray[np.float64]:
        """A list of ``rows`` lists of ``cols`` finite numbers."""
        value = self.raw(key)
        if not isinstance(value, list) or len(value) != rows:
            self.fail(key, f"expected {rows} rows of {cols} numbers, got {describe(value)}")
        out = np.empty((rows, cols))
        for i, row in enumerate(value):
            if not isinstance(row, list) or len(row) != cols:
                self.fail(f"{key}[{i}]", f"expected a row of {cols} numbers, got {describe(row)}")
            out[i] = [self._to_float(f"{key}[{i}][{j}]", v) for j, v in enumerate(row)]
        return out

    def _to_float(self, key: str, value: object) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            hint = ""
            if isinstance(value, str) and _parses_as_float(value):
                if "e" in value.lower():
                    # YAML 1.1 (PyYAML) reads 1e-3 and 1.0e3 as text: it needs a dot and a sign.
                    hint = (
                        " (YAML reads an exponent as a number only with a dot and a sign: "
                        "write 1.0e-3 or 1.0e+3, not 1e-3 or 1.0e3)"
                    )
                else:
                    hint = " (remove the quotes around the number)"
            self.fail(key, f"expected a number, got {describe(value)}{hint}")
        number = float(value)
        if not math.isfinite(number):
            self.fail(key, f"expected a finite number, got {number}")
        return number


def describe(value: object) -> str:
    """A YAML value as an error message names it: its kind, and a scalar's repr (cut to 80
    characters)."""
    if value is None:
        return "nothing (null)"
    if isinstance(value, bool):
        return f"boolean {value}"
    if isinstance(value, str):
        return f"string {shown(value)}"
    if isinstance(value, list):
        return f"a list of {len(value)} items"
    if isinstance(value, dict):
        return "a mapping"
    return f"{type(value).__name__} {shown(value)}"


def _parses_as_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


MAX_PART_MM = 1000.0  # a part bigger than a metre is one written in metres (or in microns)


def part_size_mm(fields: Fields, key: str) -> tuple[float, float, float]:
    """A part's box at ``key`` (a detection's ``size_mm``, ``grasp.part_size_mm``): three edge
    lengths in mm, each in (0, ``MAX_PART_MM``]."""
    size = fields.vector(key, 3)
    if not all(0.0 < v <= MAX_PART_MM for v in size):
        fields.fail(
            key,
            f"every size must lie in (0, {MAX_PART_MM:g}] mm, got {size.tolist()} (metres given?)",
        )
    return float(size[0]), float(size[1]), float(size[2])
