"""The audit file streamed line by line for the shift report, fast enough for a million records.

Parsing every record whole would cost most of the report's time (a pick's plan is some 6 kB of
matrices and checks, its outcome 2 kB of reached poses), and the report needs little of most: a
plan's or a capture's time, a routine outcome's time, status and operation. So a line whose head
is the audit writer's own stamp (``{"schema": N, "timestamp": "...", "pick_id": "...", "event":
"plan"``, the order ``AuditLog.append`` writes) and whose last character closes the object is
read by that head when it is a plan or a capture, and by its head, ``status`` and ``operation``
when it is an outcome with a routine status (placed, picked, missed, done, dry-run). Such a
head-read record holds ``event`` and ``timestamp`` (and ``status`` and ``operation``) only.

The patterns are exact because of how JSON is written: inside a string every quote is escaped,
so ``, "status": "`` can only be a key, and ``status`` is a key of an outcome's top level only
(docs/audit.schema.json). Every other line is read whole by ``audit.parse_line``: a record, a
``TornLine`` for a line that is not one JSON object (a write cut short, any other text), and a
record in a newer format version than this reader knows refused with ``AuditError``.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

from handeye_pick.audit import SCHEMA_VERSION, TornLine, check_version, parse_line, read_audit

_HEAD = re.compile(
    rb'\{"schema": (\d+), "timestamp": "([^"\\]*)", "pick_id": "[^"\\]*", '
    rb'"event": "(plan|capture|outcome)"'
)
_ROUTINE_STATUS = re.compile(rb', "status": "(placed|picked|missed|done|dry-run)"[,}]')
_OPERATION = re.compile(rb', "operation": "([^"\\]*)"[,}]')
_ANY_OPERATION = b', "operation": '
_KNOWN_VERSIONS = frozenset(str(v).encode() for v in range(1, SCHEMA_VERSION + 1))


def read_records(path: Path) -> Iterator[dict[str, object] | TornLine]:
    """Every line of the audit file at ``path`` in file order: a record (some read by their
    head, see above) or a ``TornLine``; blank lines skipped. Opening or reading the file may
    raise ``OSError``: the caller names the file."""
    return read_audit(path, read_line)


def read_line(line: bytes, offset: int, path: Path) -> dict[str, object] | TornLine | None:
    """One line (without its newline) read by its head where that is enough, else whole."""
    head = _HEAD.match(line)
    if head is None or not line.endswith(b"}"):
        return parse_line(line, offset, path)
    event = head.group(3)
    record: dict[str, object] = {"event": event.decode(), "timestamp": head.group(2).decode()}
    if event == b"outcome":
        status = _ROUTINE_STATUS.search(line)
        operation = _OPERATION.search(line)
        if status is None or (operation is None and _ANY_OPERATION in line):
            return parse_line(line, offset, path)  # a failure, or an escaped operation name
        record["status"] = status.group(1).decode()
        if operation is not None:
            record["operation"] = operation.group(1).decode()
    if head.group(1) not in _KNOWN_VERSIONS:
        check_version(int(head.group(1)), offset, path)
    return record
