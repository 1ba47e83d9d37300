"""Append-only pick log: one JSON object per line, on disk before ``append`` returns.

Nothing may move without its audit record, so a record that cannot be written raises
``AuditError`` instead of being dropped. Every record gets ``timestamp`` (ISO 8601, UTC) and
``pick_id`` (shared by the records of one pick). Numpy arrays become lists, paths strings, enums
their values, dataclasses mappings; non-finite floats become the strings "nan", "inf", "-inf" so
every line stays strict JSON.
"""

from __future__ import annotations

import dataclasses
import enum
import json
import math
import os
import uuid
from collections.abc import Mapping
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from handeye_pick.errors import InputError

RESERVED_KEYS = ("timestamp", "pick_id")


class AuditError(InputError):
    """The audit file cannot be written (or a record cannot be serialised); nothing may move."""


def _jsonable(value: object, key: str) -> object:
    """``value`` as plain JSON types; ``key`` names where it sits for the error message."""
    if value is None or isinstance(value, (bool, str, int)):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else str(value)
    if isinstance(value, enum.Enum):
        return _jsonable(value.value, key)
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist(), key)
    if isinstance(value, np.generic):
        return _jsonable(value.item(), key)
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, datetime):
        return value.isoformat()
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        fields = {f.name: getattr(value, f.name) for f in dataclasses.fields(value)}
        return _jsonable(fields, key)
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v, f"{key}.{k}") for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v, f"{key}[{i}]") for i, v in enumerate(value)]
    raise AuditError(
        f"audit record: cannot write {key} of type {type(value).__name__} as JSON "
        "(expected numbers, strings, lists, mappings, arrays, paths, enums or dataclasses)"
    )


class AuditLog:
    """Appends records to a JSON-lines file; one instance per pick (one ``pick_id``)."""

    def __init__(self, path: Path, pick_id: str | None = None) -> None:
        self.path = Path(path)
        self.pick_id = pick_id if pick_id is not None else uuid.uuid4().hex

    def append(self, record: Mapping[str, object]) -> None:
        """Write ``record`` as one line and fsync it; raises ``AuditError`` if that fails."""
        clash = [k for k in RESERVED_KEYS if k in record]
        if clash:
            raise AuditError(f"audit record: keys {clash} are set by the audit log itself")
        stamped = {
            "timestamp": datetime.now(timezone.utc).isoformat(timespec="microseconds"),
            "pick_id": self.pick_id,
            **record,
        }
        line = json.dumps(_jsonable(stamped, "record"), allow_nan=False) + "\n"
        try:
            is_new = not self.path.exists()
            with self.path.open("a", encoding="utf-8") as file:
                file.write(line)
                file.flush()
                os.fsync(file.fileno())
            if is_new:
                # A new file's directory entry must reach the disk too, or a power cut loses it.
                _fsync_directory(self.path.parent)
        except OSError as exc:
            raise AuditError(
                f"audit: cannot append to {self.path} ({exc.strerror or exc}); "
                "refusing to go on without a record"
            ) from None


def _fsync_directory(folder: Path) -> None:
    fd = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
