"""Append-only pick log: one JSON object per line, on disk before ``append`` returns.

Nothing may move without its audit record, so a record that cannot be written raises ``AuditError``
instead of being dropped. Every record gets ``schema`` (the format version, ``SCHEMA_VERSION``;
docs/audit.schema.json describes every record kind), ``timestamp`` (ISO 8601, UTC) and ``pick_id``
(shared by the records of one pick). Readers take records of this version and older (records without
``schema`` were written before versions existed) and refuse a newer one with ``AuditError``: a
record they do not know must not be taken for one they do. Numpy arrays become lists, paths strings,
enums their values, dataclasses mappings; non-finite floats become the strings "nan", "inf", "-inf"
so every line stays strict JSON.

Opening: a command or session calls ``open_audit(path)`` once, before anything connects to a
robot. It checks the file can be appended and fsynced (``AuditError``, one line, otherwise),
closes the picks a killed process left unfinished, and returns the log and warnings to show::

    audit, warnings = open_audit(config.audit.file)   # AuditError: exit 2, nothing connected
    for warning in warnings:
        log.warning("%s", warning)
    ...                                               # first pick: audit.pick_id
    audit = audit.next_pick()                         # each further cycle: a new pick_id

What survives a power cut (or SIGKILL) mid-write: every record whose ``append`` returned (it was
fsynced), and the fragment of the one being written, if any, as a line of its own. Every append
starts on a fresh line, so the next record is never glued to a fragment; ``read_audit`` yields
the complete records and reports the fragments (``TornLine``). A plan whose process died before
its outcome is closed at the next ``open_audit`` by an outcome with ``status: abandoned``.
"""

from __future__ import annotations

import dataclasses
import enum
import fcntl
import json
import math
import os
import uuid
from collections.abc import Callable, Iterator, Mapping
from datetime import datetime, timezone
from pathlib import Path
from typing import BinaryIO

import numpy as np

from handeye_pick.errors import InputError

SCHEMA_VERSION = 2
"""The audit format's version (2 added the ``resume`` record). Adding an optional field keeps it;
renaming or removing a field, changing a field's meaning or unit, or a new record kind raises it
(docs/files-and-frames.md)."""

RESERVED_KEYS = ("schema", "timestamp", "pick_id")

SCAN_LIMIT_BYTES = 16_000_000
"""``open_audit`` looks for unfinished plans in at most this many bytes at the end of the file
(some 5000 picks' plans and outcomes), reading backwards only as far as the last plan that has
its outcome; every start closes what it finds, so older plans were closed by earlier starts."""


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
    """Appends records to a JSON-lines file; one instance per pick (one ``pick_id``).

    ``AuditLog(path)`` just appends; ``open_audit(path)`` is how a command starts (checks, lock,
    unfinished picks). ``next_pick()`` gives the log for the next pick of a session.
    """

    def __init__(self, path: Path, pick_id: str | None = None) -> None:
        self.path = Path(path)
        self.pick_id = pick_id if pick_id is not None else uuid.uuid4().hex
        self._lock: _Lock | None = None
        self.on_append: Callable[[str], None] | None = None
        """Hears each record's JSON line (no newline) once it is on disk; must not raise."""
        self.records_written = 0
        """How many records of this ``pick_id`` are on disk (``append`` returned): a report
        names the pick id only when there is one, never for a record that failed to write."""

    def next_pick(self) -> AuditLog:
        """A log for the next pick: same file (and ``open_audit``'s lock and ``on_append``), a
        new ``pick_id``."""
        sibling = AuditLog(self.path)
        sibling._lock = self._lock
        sibling.on_append = self.on_append
        return sibling

    def close(self) -> None:
        """Release ``open_audit``'s lock (for every log of this session); appends still work."""
        if self._lock is not None:
            self._lock.release()

    def __enter__(self) -> AuditLog:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def append(self, record: Mapping[str, object]) -> None:
        """Write ``record`` as one line and fsync it; raises ``AuditError`` if that fails.

        The line starts on a fresh line even when the file ends with a fragment (a write cut
        short): the fragment stays a line of its own, recognisable and never merged.
        """
        clash = [k for k in RESERVED_KEYS if k in record]
        if clash:
            raise AuditError(f"audit record: keys {clash} are set by the audit log itself")
        stamped = {
            "schema": SCHEMA_VERSION,
            "timestamp": datetime.now(timezone.utc).isoformat(timespec="microseconds"),
            "pick_id": self.pick_id,
            **record,
        }
        line = json.dumps(_jsonable(stamped, "record"), allow_nan=False)
        try:
            _append_fsynced(self.path, (line + "\n").encode("utf-8"))
        except OSError as exc:
            raise AuditError(
                f"audit: cannot append to {self.path} ({exc.strerror or exc}); "
                "refusing to go on without a record"
            ) from None
        self.records_written += 1
        if self.on_append is not None:
            self.on_append(line)


def _append_fsynced(path: Path, data: bytes) -> None:
    """Append ``data`` (on a fresh line) and fsync the file, creating it if needed."""
    is_new = not path.exists()
    fd = os.open(path, os.O_RDWR | os.O_APPEND | os.O_CREAT, 0o644)
    try:
        size = os.fstat(fd).st_size
        if data and size > 0 and os.pread(fd, 1, size - 1) != b"\n":
            data = b"\n" + data  # the file ends with a fragment: keep it on its own line
        view = memoryview(data)
        while view:
            view = view[os.write(fd, view) :]
        os.fsync(fd)
    finally:
        os.close(fd)
    if is_new:
        # A new file's directory entry must reach the disk too, or a power cut loses it.
        _fsync_directory(path.parent)


def check_appendable(path: Path) -> None:
    """Raise ``AuditError`` (one line) unless ``path`` can be appended to and fsynced.

    Call it before connecting to a robot: an unwritable audit file (a read-only disk, a missing
    folder, a folder named as the file) must stop a command before anything is sent. Creates an
    empty file if there is none.
    """
    path = Path(path)
    if path.is_dir():
        raise AuditError(
            f"audit: {path} is a folder, not a file: name a file in it (audit.file); "
            "refusing to start without a record"
        )
    try:
        _append_fsynced(path, b"")
    except OSError as exc:
        raise AuditError(
            f"audit: cannot append to {path} ({exc.strerror or exc}); "
            "refusing to start without a record"
        ) from None


@dataclasses.dataclass(frozen=True)
class TornLine:
    """A line that is not a complete record: what a write cut short (power cut) leaves."""

    offset: int  # byte offset of the line's start in the file
    text: str  # its first 80 characters, undecodable bytes replaced

    @classmethod
    def of(cls, raw: bytes, offset: int) -> TornLine:
        """The torn line ``raw`` (without its newline) that starts at byte ``offset``."""
        text = raw.decode("utf-8", errors="replace")
        return cls(offset, text if len(text) <= 80 else text[:77] + "...")

    def describe(self, path: Path) -> str:
        return (
            f"audit {path}: an incomplete line at byte {self.offset} (a write cut short, e.g. "
            f"by a power cut) is kept as it is: {self.text!r}"
        )


LineParser = Callable[[bytes, int, Path], "dict[str, object] | TornLine | None"]
"""Turns one line (without its newline), its byte offset and the file's path into an entry."""


def read_audit(
    path: Path, parse: LineParser | None = None
) -> Iterator[dict[str, object] | TornLine]:
    """Every line of the audit file in order: a record (a dict), or a ``TornLine`` for a line
    that is not one complete JSON object. Blank lines are skipped. Reads line by line, each
    with ``parse`` (default ``parse_line``; a reader that needs less of some records may bring
    its own, falling back to ``parse_line``)."""
    parse_one = parse_line if parse is None else parse
    offset = 0
    with Path(path).open("rb") as file:
        for raw in file:
            entry = parse_one(raw.rstrip(b"\n"), offset, path)
            offset += len(raw)
            if entry is not None:
                yield entry


def parse_line(raw: bytes, offset: int, path: Path) -> dict[str, object] | TornLine | None:
    """One line as a record, a ``TornLine`` when it is not one JSON object, None when blank;
    ``AuditError`` for a record in a format version this reader does not know."""
    if not raw.strip():
        return None
    try:
        record = json.loads(raw)
    except (UnicodeDecodeError, ValueError):
        record = None
    if isinstance(record, dict):
        check_version(record.get("schema", 0), offset, path)
        return record
    return TornLine.of(raw, offset)


def open_audit(path: Path) -> tuple[AuditLog, list[str]]:
    """Start using the audit file ``path``; the one entry point for a command or a session.

    1. ``check_appendable``: ``AuditError`` (one line, exit 2) before anything connects.
    2. A shared lock on the file for the life of the returned log (``close()`` or the process's
       end releases it), so two processes never take each other's live picks for dead ones.
    3. If no other process holds the file: every plan at the end of the file without an
       outcome (same ``pick_id``) gets an outcome ``{"event": "outcome", "status": "abandoned",
       ...}``, and one warning each says which pick (plan time, host, dry run or not). Torn
       lines met on the way get a warning each. See ``SCAN_LIMIT_BYTES`` for how far it reads.

    Returns the log for the first pick (``next_pick()`` for each further one) and the warnings,
    one line each, for the caller to show.
    """
    path = Path(path)
    check_appendable(path)
    lock = _Lock(path)
    warnings: list[str] = []
    try:
        if lock.exclusive():
            plans, torn = _unfinished_plans(path)
            warnings += [line.describe(path) for line in torn]
            warnings += [_abandon(path, plan) for plan in plans]
        else:
            warnings.append(
                f"audit {path}: another process is using this file, so its unfinished picks "
                "are left for it (not closed as abandoned)"
            )
        lock.share()
    except OSError as exc:
        lock.release()
        raise AuditError(f"audit: cannot lock or read {path} ({exc.strerror or exc})") from None
    except BaseException:
        lock.release()
        raise
    audit = AuditLog(path)
    audit._lock = lock
    return audit, warnings


class _Lock:
    """An advisory lock (flock) on the audit file, held through its own file descriptor."""

    def __init__(self, path: Path) -> None:
        try:
            self._fd: int | None = os.open(path, os.O_RDONLY)
        except OSError as exc:
            raise AuditError(f"audit: cannot open {path} ({exc.strerror or exc})") from None

    def exclusive(self) -> bool:
        """Whether no other process holds the file (then this one holds it alone); raises
        ``OSError`` where the file system has no locks."""
        if self._fd is None:
            return False
        try:
            fcntl.flock(self._fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            return False
        return True

    def share(self) -> None:
        if self._fd is not None:
            fcntl.flock(self._fd, fcntl.LOCK_SH)

    def release(self) -> None:
        if self._fd is not None:
            os.close(self._fd)  # closing the descriptor releases the lock
            self._fd = None


def check_version(version: object, offset: int, path: Path) -> None:
    """Refuse (``AuditError``, one line) a record's ``schema`` this reader does not know:
    newer than ``SCHEMA_VERSION``, or not an integer. A record without one (written before
    versions existed) is version 0."""
    if not (isinstance(version, int) and not isinstance(version, bool)):
        raise AuditError(f"audit {path}: the record at byte {offset} has schema {version!r}")
    if version > SCHEMA_VERSION:
        raise AuditError(
            f"audit {path}: the record at byte {offset} is in audit format version {version}, "
            f"newer than this handeye-pick reads ({SCHEMA_VERSION}): read it with the "
            "handeye-pick that wrote it, or give this one a new audit file"
        )


def _unfinished_plans(path: Path) -> tuple[list[dict[str, object]], list[TornLine]]:
    """Plans without an outcome after the last plan that has one (file order), and the torn
    lines met reading back to it."""
    finished: set[object] = set()
    plans: list[dict[str, object]] = []
    torn: list[TornLine] = []
    with path.open("rb") as file:
        for offset, raw in _lines_from_end(file, SCAN_LIMIT_BYTES):
            entry = parse_line(raw, offset, path)
            if isinstance(entry, TornLine):
                torn.append(entry)
            elif entry is not None and entry.get("event") == "outcome":
                finished.add(entry.get("pick_id"))
            elif entry is not None and entry.get("event") == "plan":
                if entry.get("pick_id") in finished:
                    break  # a clean end: everything before was closed when it was written
                plans.append(entry)
    return plans[::-1], torn[::-1]


def _lines_from_end(file: BinaryIO, limit: int) -> Iterator[tuple[int, bytes]]:
    """(byte offset, line without its newline) from the last line back to the first, reading
    at most ``limit`` bytes from the end (a line cut by that limit is not yielded)."""
    position = file.seek(0, os.SEEK_END)
    stop = max(0, position - limit)
    pending = b""  # the start of a line whose beginning lies before ``position``
    while position > stop:
        start = max(stop, position - 65536)
        file.seek(start)
        lines = (file.read(position - start) + pending).split(b"\n")
        position = start
        pending = lines[0]
        offset = position + len(pending) + 1
        complete = []
        for line in lines[1:]:
            complete.append((offset, line))
            offset += len(line) + 1
        yield from reversed(complete)
    if position == 0 and pending:
        yield 0, pending


def _abandon(path: Path, plan: Mapping[str, object]) -> str:
    """Append the abandoned outcome of ``plan``; return the warning that says what it was."""
    pick_id = str(plan.get("pick_id"))
    planned_at = plan.get("timestamp")
    AuditLog(path, pick_id=pick_id).append(
        {
            "event": "outcome",
            "status": "abandoned",
            "dry_run": plan.get("dry_run"),
            "plan_timestamp": planned_at,
            "detail": "no outcome was written: the process ended after its plan (killed, "
            "crashed or a power cut); what the robot did is not recorded",
        }
    )
    kind = "dry run" if plan.get("dry_run") is True else "pick"
    return (
        f"audit {path}: {kind} {pick_id} planned at {planned_at} on {plan.get('host')} "
        f"(config {plan.get('config')}) has no outcome: its process ended without one (killed, "
        "crashed or a power cut); recorded as abandoned. Check where the robot is before moving it"
    )


def _fsync_directory(folder: Path) -> None:
    fd = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
