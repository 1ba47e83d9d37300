"""The line's counters since ``run`` started, computed by the shift report's own code.

``AuditCounters`` reads the audit file from where it ended when ``run`` started, one complete
line at a time as the session appends them, and folds each record into the report's ``Tally``
with the window starting at that moment. So the counters are, by construction, the numbers
``handeye-pick report AUDIT --since START`` prints for the same records (docs/line.md): the
halt time of a halt still open runs to ``now``, as ``--until NOW`` would. The last error is
the latest outcome (or refused resume) that did not do what was asked, coded by ``codes``.

Reading is incremental and bounded: each ``update`` reads what was appended since the last one,
at most ``MAX_READ_BYTES``; a line still being written waits for its newline.
"""

from __future__ import annotations

import json
import os
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from handeye_pick.audit import TornLine
from handeye_pick.line.codes import NONE, LineError, line_error
from handeye_pick.report.lines import read_line
from handeye_pick.report.shift import COMPLETED, Tally

MAX_READ_BYTES = 4_000_000
"""Most bytes one update reads; the rest waits for the next (a plan is some 6 kB)."""
OUTCOMES = ("placed", "picked", "missed", "refused", "no-candidate", "fault", "dropped",
            "aborted", "stopped", "halted", "interrupted")
"""The pick outcomes the line counts, as the report names them."""
_FINE = frozenset({"placed", "picked", "done", "dry-run", "ready"})


@dataclass(frozen=True)
class Counters:
    """What the cell did since ``run`` started (times in s)."""

    outcomes: dict[str, int]  # pick outcome -> count, every one of ``OUTCOMES`` listed
    cycles: int  # picks that reached an outcome
    cycle_last_s: float | None  # the latest cycle time (completed pick to completed pick)
    cycle_median_s: float | None
    picks_per_hour: float  # completed picks (placed, picked) per hour since run started
    halted_s: float  # time the cell stood halted (report's definition)
    stop_requests: int
    resumes: int
    last_error: LineError


class AuditCounters:
    """Counters over the audit file at ``path`` from byte ``offset`` on, the window starting
    at ``started`` (s since the epoch). Safe from any thread."""

    def __init__(self, path: Path, offset: int, started: float) -> None:
        self.path = path
        self.started = started
        self._offset = offset
        self._tally = Tally(path, started, None, None)
        self._last_error = NONE
        self._lock = threading.Lock()

    @classmethod
    def from_now(cls, path: Path) -> AuditCounters:
        """Counters of what is appended to ``path`` from now on."""
        try:
            offset = os.path.getsize(path)
        except OSError:
            offset = 0
        return cls(path, offset, time.time())

    def snapshot(self) -> Counters:
        """Read what was appended, then the counters as they stand now."""
        with self._lock:
            self._update()
            now = time.time()
            report = self._tally.finish(now)
            times = self._tally.cycle_times
            completed = sum(report.statuses.get(status, 0) for status in COMPLETED)
            span_h = max(now - self.started, 1e-9) / 3600.0
            return Counters(
                outcomes={name: report.statuses.get(name, 0) for name in OUTCOMES},
                cycles=report.cycles,
                cycle_last_s=times[-1] if len(times) else None,
                cycle_median_s=report.cycle_times.median_s,
                picks_per_hour=completed / span_h,
                halted_s=report.halted_s,
                stop_requests=report.stop_requests,
                resumes=report.resumes,
                last_error=self._last_error,
            )

    def _update(self) -> None:
        try:
            with self.path.open("rb") as file:
                file.seek(self._offset)
                data = file.read(MAX_READ_BYTES)
        except OSError:
            return
        end = data.rfind(b"\n")
        if end < 0:
            return
        offset = self._offset
        for raw in data[: end + 1].split(b"\n")[:-1]:
            entry = read_line(raw, offset, self.path)
            offset += len(raw) + 1
            if entry is None:
                continue
            self._tally.add(entry)
            if not isinstance(entry, TornLine):
                self._note_error(entry, raw)
        self._offset = offset

    def _note_error(self, record: dict[str, object], raw: bytes) -> None:
        """The latest outcome or resume that failed becomes the last error."""
        if record.get("event") not in ("outcome", "resume"):
            return
        status = str(record.get("status"))
        if status in _FINE:
            return
        if status == "refused" and _error_type(record, raw) in ("NoFeasibleCandidate",
                                                                  "PreflightRefusal"):
            status = "no-candidate"
        self._last_error = line_error(status, _error_text(record, raw))


def _whole(record: dict[str, object], raw: bytes) -> dict[str, object]:
    """The record read whole (the report reads routine outcomes by their head only)."""
    if "error" in record or "problems" in record:
        return record
    try:
        whole = json.loads(raw)
    except ValueError:
        return record
    return whole if isinstance(whole, dict) else record


def _error_type(record: dict[str, object], raw: bytes) -> str | None:
    error = _whole(record, raw).get("error")
    kind = error.get("type") if isinstance(error, dict) else None
    return kind if isinstance(kind, str) else None


def _error_text(record: dict[str, object], raw: bytes) -> str:
    whole = _whole(record, raw)
    error = whole.get("error")
    if isinstance(error, dict):
        return f"{error.get('type', '?')}: {error.get('message', '')}"
    problems = whole.get("problems")
    if isinstance(problems, list) and problems:
        return f"resume refused: {problems[0]}"
    if whole.get("status") == "missed":
        return str(whole.get("missed") or "grasp missed: no part sensed")
    return str(whole.get("status"))
