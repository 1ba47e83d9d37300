"""The audit file streamed line by line for the shift report, fast enough for a million records.

A pick's plan is the largest record (some 6 kB of matrices and checks) and the report needs only
its time; parsing it whole would cost most of the report's time. So a ``plan`` or ``capture``
line whose head is the audit writer's own stamp (``{"schema": N, "timestamp": "...", "pick_id":
"...", "event": "plan"``, in the order ``AuditLog.append`` writes) and whose last character
closes the object is read by that head alone: a dict of those four keys. Every other line is
read whole by ``audit.parse_line``: a record, a ``TornLine`` for a line that is not one JSON
object (a write cut short, any other text), and a record in a newer format version than this
reader knows refused with ``AuditError`` (one line).
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

from handeye_pick.audit import TornLine, check_version, parse_line, read_audit

HEAD_ONLY_EVENTS = ("plan", "capture")
"""Record kinds the report reads by their head alone (it needs only their time)."""

_HEAD = re.compile(
    rb'\{"schema": (\d+), "timestamp": "([^"\\]*)", "pick_id": "([^"\\]*)", '
    rb'"event": "(' + b"|".join(e.encode() for e in HEAD_ONLY_EVENTS) + rb')"'
)


def read_records(path: Path) -> Iterator[dict[str, object] | TornLine]:
    """Every line of the audit file at ``path`` in file order: a record (plan and capture
    records by their head only) or a ``TornLine``; blank lines skipped. Opening or reading the
    file may raise ``OSError``: the caller names the file."""
    return read_audit(path, _head_or_whole)


def _head_or_whole(line: bytes, offset: int, path: Path) -> dict[str, object] | TornLine | None:
    head = _HEAD.match(line)
    if head is None or not line.rstrip().endswith(b"}"):
        return parse_line(line, offset, path)
    version = int(head.group(1))
    check_version(version, offset, path)
    return {
        "schema": version,
        "timestamp": head.group(2).decode("utf-8", errors="replace"),
        "pick_id": head.group(3).decode("utf-8", errors="replace"),
        "event": head.group(4).decode(),
    }
