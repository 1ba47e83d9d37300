"""A shift from its audit file: one pass over the records into bounded tallies (``Tally``), then
the finished ``ShiftReport``.

Definitions (docs/report.md says them for the operator):

- A *cycle* is one pick that reached an outcome: an outcome record of a pick (not of a place, a
  named-pose move or a connect), whatever its status; dry runs and ``abandoned`` outcomes are
  counted apart. The cycles' statuses sum to the cycles; ``no-candidate`` is a ``refused``
  outcome whose error is a plan refusal (no candidate passed every check).
- A *fault* is an outcome of any operation with status fault, dropped or aborted: the cell
  halts. An operator's stop request (outcome ``stopped``) halts it too, and is listed with the
  faults though not counted as one. The *halt* either starts ends at the next ``resume`` record
  with status ready, or at the first plan after it if there is none before (a new session
  starts unhalted); a halt still open at the end of the window lasts to the end. A fault while
  the cell already stands halted, and a failed connect (no session ran, so none halted), are
  listed but start no halt.
- *Stops* are the outcomes ``stopped`` (a stop request) and ``interrupted`` (Ctrl-C, SIGTERM).
- *Cycle time* is the time from one completed pick's outcome (placed or picked) to the next:
  the time per part, waits for parts and refused candidates included. An interval that holds a
  fault, a stop or an abandoned outcome is left out (the cell was not producing); so is one
  that starts before the window.

Times are seconds since the epoch inside, printed in the zone ``tz`` (the machine's own when
None). Memory: counts, one bucket per hour, the first and last ``KEPT_FAULTS`` faults in full,
and every cycle time as a float64 (8 bytes a completed pick: 8 MB for a million) for an exact
median and p90.
"""

from __future__ import annotations

import math
from array import array
from collections import Counter, deque
from dataclasses import dataclass
from datetime import datetime, timezone, tzinfo
from pathlib import Path

from handeye_pick.audit import TornLine
from handeye_pick.errors import Status

FAULTS = frozenset(s.value for s in (Status.FAULT, Status.DROPPED, Status.ABORTED))
"""Outcome statuses of a robot error: the cell halts until ``resume``."""
HALTING = FAULTS | {Status.STOPPED.value}
"""Outcome statuses that halt the cell: the faults and an operator's stop request."""
COMPLETED = frozenset(s.value for s in (Status.PLACED, Status.PICKED))
"""Pick outcomes with a part in the gripper or placed: what a cycle time runs between."""
PLAN_REFUSALS = frozenset({"NoFeasibleCandidate", "PreflightRefusal"})
"""The error types of a ``refused`` pick outcome whose reply was ``no-candidate`` (the
subclasses of ``errors.PlanRefused``; tests/unit/test_report.py keeps the two lists equal)."""
STATUSES = tuple(
    s.value
    for s in (
        Status.PLACED,
        Status.PICKED,
        Status.MISSED,
        Status.REFUSED,
        Status.NO_CANDIDATE,
        Status.HALTED,
        Status.FAULT,
        Status.DROPPED,
        Status.ABORTED,
        Status.STOPPED,
        Status.INTERRUPTED,
    )
)
"""The cycle statuses every report lists, zero or not (others appear when they occur)."""
KEPT_FAULTS = 50
"""Faults kept in full: the first and the last this many; the rest are counted."""
KEPT_UNKNOWN_KINDS = 20
"""Distinct unknown record kinds named in the report; further ones count as ``other``."""
HISTOGRAM_BINS = 20
"""Cycle-time histogram bins up to the 99th percentile; longer cycles count as ``over``."""
KNOWN_EVENTS = frozenset({"capture", "plan", "outcome", "resume", "line"})
"""Record kinds the report knows; ``line`` (a line command, docs/line.md) counts in none."""
# The statuses the hot path compares with, as plain strings (an enum's .value costs a call).
_ABANDONED = "abandoned"
_DONE, _DRY_RUN, _HALTED = Status.DONE.value, Status.DRY_RUN.value, Status.HALTED.value
_INTERRUPTED, _REFUSED = Status.INTERRUPTED.value, Status.REFUSED.value
_STOPPED = Status.STOPPED.value
_NO_CANDIDATE, _READY = Status.NO_CANDIDATE.value, Status.READY.value


@dataclass
class Fault:
    """One outcome that halts the cell (a fault, or a stop request: ``HALTING``) and the halt it
    started. Times are seconds since the epoch."""

    time: float
    status: str  # fault, dropped, aborted or stopped
    operation: str  # pick, place, move <pose>, connect
    step: str | None  # the step running when it happened (None: not recorded)
    reason: str  # the error's type and message
    request_id: str | None
    pick_id: str
    started_halt: bool  # False: the cell already stood halted, or the connect failed
    halt_end: float | None = None  # when the halt ended (None: still open at the end)
    ended_by: str | None = None  # "resume", "plan" (a new session) or None


@dataclass(frozen=True)
class Hour:
    """One hour of the shift (local hour start, seconds since the epoch)."""

    start: float
    picks: int  # completed picks: placed or picked
    cycles: int
    faults: int


@dataclass(frozen=True)
class CycleTimes:
    """Cycle times (s): exact median and p90 (linear between ranks), and a histogram of
    ``HISTOGRAM_BINS`` bins of ``bin_s`` from ``low_s``, which span the 1st to the 99th
    percentile; shorter and longer cycles are counted in ``under`` and ``over``."""

    count: int
    median_s: float | None
    p90_s: float | None
    low_s: float
    bin_s: float
    counts: list[int]
    under: int
    over: int


@dataclass(frozen=True)
class ShiftReport:
    """The shift as the report prints it; times in seconds since the epoch, durations in s."""

    path: Path
    tz: tzinfo | None  # zone the times are printed in (None: the machine's)
    since: float | None
    until: float | None
    start: float | None  # the window's start: ``since``, else the first record's time
    end: float | None  # the window's end: ``until``, else the last record's time
    cycles: int
    statuses: dict[str, int]
    dry_runs: int
    places_done: int  # place requests (after a pick without place) that put a part down
    abandoned: int
    faults: int
    connect_faults: int  # of ``faults``: connects that failed (no session, no halt)
    stops: int  # stop requests and interrupts: ``stop_requests`` + ``interrupts``
    stop_requests: int  # stopped outcomes of any operation (run's stop request)
    interrupts: int  # interrupted outcomes of any operation (Ctrl-C, SIGTERM)
    halted_refusals: int  # outcomes of any operation refused because the cell stood halted
    halts: int
    halted_s: float
    resumes: int
    resumes_not_ready: int
    hours: list[Hour]
    cycle_times: CycleTimes
    fault_list: list[Fault]
    faults_left_out: int  # between the first and the last KEPT_FAULTS
    torn: int
    torn_offsets: list[int]  # the first few, for the warning
    unknown_kinds: dict[str, int]
    bad_records: int  # JSON objects without an event or a readable timestamp

    @property
    def span_s(self) -> float:
        if self.start is None or self.end is None:
            return 0.0
        return max(0.0, self.end - self.start)

    @property
    def halted_share(self) -> float:
        return self.halted_s / self.span_s if self.span_s > 0 else 0.0

    def local(self, t: float) -> datetime:
        """``t`` (s since the epoch) as an aware time in the report's zone."""
        return datetime.fromtimestamp(t, timezone.utc).astimezone(self.tz)


class Tally:
    """The report's tallies, fed one record at a time in file order (``add``)."""

    def __init__(
        self, path: Path, since: float | None, until: float | None, tz: tzinfo | None
    ) -> None:
        self.path, self.since, self.until, self.tz = path, since, until, tz
        self.first: float | None = None
        self.last: float | None = None
        self.statuses: Counter[str] = Counter()
        self.counts: Counter[str] = Counter()  # dry runs, places, faults, stops, ...
        self.hours: dict[float, Counter[str]] = {}
        self._current_hour: tuple[float, Counter[str]] = (math.inf, Counter())
        self.cycle_times = array("d")
        self.previous_done: float | None = None
        self.open_halt: Fault | None = None
        self.halted_s = 0.0
        self.first_faults: list[Fault] = []
        self.last_faults: deque[Fault] = deque(maxlen=KEPT_FAULTS)
        self.torn_offsets: list[int] = []
        self.unknown: Counter[str] = Counter()

    def add(self, entry: dict[str, object] | TornLine) -> None:
        """Fold one entry of ``lines.read_records`` into the tallies."""
        if isinstance(entry, TornLine):
            self.counts["torn"] += 1
            if len(self.torn_offsets) < 5:
                self.torn_offsets.append(entry.offset)
            return
        event, t = entry.get("event"), _seconds(entry.get("timestamp"))
        if not isinstance(event, str) or t is None:
            self.counts["bad"] += 1
            return
        if event not in KNOWN_EVENTS:
            self._unknown(event)
            return
        inside = self._in_window(t)
        if inside:
            self.first = t if self.first is None else self.first
            self.last = t
        if event == "outcome":
            self._outcome(entry, t, inside)
        elif event == "resume":
            self._resume(entry, t, inside)
        elif event == "plan" and self.open_halt is not None:
            self._end_halt(t, "plan")

    def _unknown(self, event: str) -> None:
        name = event if event in self.unknown or len(self.unknown) < KEPT_UNKNOWN_KINDS else "other"
        self.unknown[name] += 1

    def _outcome(self, record: dict[str, object], t: float, inside: bool) -> None:
        status = str(record.get("status"))
        if status in HALTING:
            self._fault(record, status, t, inside)
        if status in (_INTERRUPTED, _ABANDONED):
            self.previous_done = None  # the cell was not producing across it
        if not inside:
            return
        operation = record.get("operation")
        if status == _ABANDONED:
            self.counts["abandoned"] += 1
        elif status == _INTERRUPTED:
            self.counts["interrupts"] += 1
        elif status == _STOPPED:
            self.counts["stop_requests"] += 1
        elif status == _HALTED:
            self.counts["halted_refusals"] += 1
        if operation == "place" and status == _DONE:
            self.counts["places_done"] += 1
        if operation is None and status != _ABANDONED and record.get("step") != "connect":
            self._cycle(record, status, t)

    def _cycle(self, record: dict[str, object], status: str, t: float) -> None:
        if status == _DRY_RUN:
            self.counts["dry_runs"] += 1
            return
        if status == _REFUSED and _error_type(record) in PLAN_REFUSALS:
            status = _NO_CANDIDATE
        self.statuses[status] += 1
        hour = self._hour(t)
        hour["cycles"] += 1
        if status not in COMPLETED:
            return
        hour["picks"] += 1
        if self.previous_done is not None and t >= self.previous_done:
            self.cycle_times.append(t - self.previous_done)
        self.previous_done = t

    def _fault(self, record: dict[str, object], status: str, t: float, inside: bool) -> None:
        self.previous_done = None
        operation = _operation(record)
        fault = Fault(
            time=t,
            status=status,
            operation=operation,
            step=_optional_str(record.get("step")),
            reason=_reason(record),
            request_id=_optional_str(record.get("request_id")),
            pick_id=str(record.get("pick_id")),
            started_halt=self.open_halt is None and operation != "connect",
        )
        if fault.started_halt:
            self.open_halt = fault
        if not inside:
            return
        if status in FAULTS:
            self.counts["faults"] += 1
            self.counts["connect_faults"] += operation == "connect"
            self._hour(t)["faults"] += 1
        if len(self.first_faults) < KEPT_FAULTS:
            self.first_faults.append(fault)
        else:
            self.last_faults.append(fault)

    def _resume(self, record: dict[str, object], t: float, inside: bool) -> None:
        ready = record.get("status") == _READY
        if inside:
            self.counts["resumes" if ready else "resumes_not_ready"] += 1
        if ready and self.open_halt is not None:
            self._end_halt(t, "resume")

    def _end_halt(self, t: float, ended_by: str) -> None:
        halt = self.open_halt
        assert halt is not None
        halt.halt_end, halt.ended_by = t, ended_by
        overlap = self._overlap(halt.time, t)
        self.halted_s += overlap
        if overlap > 0 or self._in_window(halt.time):
            self.counts["halts"] += 1
        self.open_halt = None

    def _overlap(self, begin: float, end: float) -> float:
        """Seconds of [begin, end] inside the window."""
        low = begin if self.since is None else max(begin, self.since)
        high = end if self.until is None else min(end, self.until)
        return max(0.0, high - low)

    def _in_window(self, t: float) -> bool:
        return (self.since is None or t >= self.since) and (self.until is None or t < self.until)

    def _hour(self, t: float) -> Counter[str]:
        start, bucket = self._current_hour
        if not start <= t < start + 3600.0:  # most records fall in the hour of the one before
            start = _hour_start(t, self.tz)
            bucket = self.hours.setdefault(start, Counter())
            self._current_hour = (start, bucket)
        return bucket

    def finish(self, now: float | None = None) -> ShiftReport:
        """The report of every entry added so far; ``now`` (s since the epoch) ends a window
        without ``until`` instead of the last record (the line's live counters)."""
        start = self.since if self.since is not None else self.first
        end = self.until if self.until is not None else (now if now is not None else self.last)
        halted_s, halts = self.halted_s, self.counts["halts"]
        still_open = self.open_halt
        if still_open is not None and (self.until is None or still_open.time < self.until):
            halts += 1  # it lasts to the end of the window
            halted_s += self._overlap(still_open.time, end if end is not None else still_open.time)
        statuses = {status: self.statuses.get(status, 0) for status in STATUSES}
        statuses.update(self.statuses)
        kept = self.first_faults + list(self.last_faults)
        return ShiftReport(
            path=self.path,
            tz=self.tz,
            since=self.since,
            until=self.until,
            start=start,
            end=end,
            cycles=sum(self.statuses.values()),
            statuses=statuses,
            dry_runs=self.counts["dry_runs"],
            places_done=self.counts["places_done"],
            abandoned=self.counts["abandoned"],
            faults=self.counts["faults"],
            connect_faults=self.counts["connect_faults"],
            stops=self.counts["stop_requests"] + self.counts["interrupts"],
            stop_requests=self.counts["stop_requests"],
            interrupts=self.counts["interrupts"],
            halted_refusals=self.counts["halted_refusals"],
            halts=halts,
            halted_s=halted_s,
            resumes=self.counts["resumes"],
            resumes_not_ready=self.counts["resumes_not_ready"],
            hours=self._every_hour(),
            cycle_times=_cycle_times(self.cycle_times),
            fault_list=kept,
            faults_left_out=self.counts["faults"] + self.counts["stop_requests"] - len(kept),
            torn=self.counts["torn"],
            torn_offsets=self.torn_offsets,
            unknown_kinds=dict(self.unknown),
            bad_records=self.counts["bad"],
        )

    def _every_hour(self) -> list[Hour]:
        """One ``Hour`` from the first hour with a cycle to the last, empty hours included."""
        if not self.hours:
            return []
        hours, t, last = [], min(self.hours), max(self.hours)
        while t <= last:
            bucket = self.hours.get(t, Counter())
            hours.append(Hour(t, bucket["picks"], bucket["cycles"], bucket["faults"]))
            t = _hour_start(t + 3600.0 + 1.0, self.tz)  # +1 s: past a daylight-saving repeat
        return hours


def shift_report(
    path: Path,
    since: datetime | None = None,
    until: datetime | None = None,
    tz: tzinfo | None = None,
) -> ShiftReport:
    """Read the audit file at ``path`` once, line by line, and report the records from
    ``since`` (inclusive) to ``until`` (exclusive), both aware times. ``tz`` is the zone hours
    are counted and times printed in (None: the machine's). Raises ``AuditError`` for a record
    in a newer format version and ``OSError`` when the file cannot be read."""
    from handeye_pick.report.lines import read_records

    tally = Tally(
        path,
        None if since is None else since.timestamp(),
        None if until is None else until.timestamp(),
        tz,
    )
    for entry in read_records(path):
        tally.add(entry)
    return tally.finish()


def _cycle_times(values: array[float]) -> CycleTimes:
    import numpy as np

    times = np.frombuffer(values, dtype=np.float64) if len(values) else np.zeros(0)
    if times.size == 0:
        return CycleTimes(0, None, None, 0.0, 1.0, [0] * HISTOGRAM_BINS, 0, 0)
    p1, median, p90, p99 = (float(p) for p in np.percentile(times, [1.0, 50.0, 90.0, 99.0]))
    # One bin fewer than drawn, so that rounding the start down still reaches the 99th.
    bin_s = _nice_step((p99 - p1) / (HISTOGRAM_BINS - 1))
    low = math.floor(p1 / bin_s) * bin_s
    high = low + bin_s * HISTOGRAM_BINS
    counts, _ = np.histogram(times, bins=HISTOGRAM_BINS, range=(low, high))
    under = int(np.count_nonzero(times < low))
    over = int(np.count_nonzero(times > high))
    return CycleTimes(int(times.size), median, p90, low, bin_s, counts.tolist(), under, over)


def _nice_step(at_least: float) -> float:
    """The smallest of 1, 2, 5 times a power of ten that is at least ``at_least`` (min 0.01)."""
    if at_least <= 0.01:
        return 0.01
    power = 10.0 ** math.floor(math.log10(at_least))
    return next(f * power for f in (1.0, 2.0, 5.0, 10.0) if f * power >= at_least)


def _seconds(stamp: object) -> float | None:
    """An ISO 8601 timestamp as seconds since the epoch (naive: UTC, as the writer's are)."""
    if not isinstance(stamp, str):
        return None
    try:
        moment = datetime.fromisoformat(stamp)
    except ValueError:
        return None
    if moment.tzinfo is None:
        moment = moment.replace(tzinfo=timezone.utc)
    seconds = moment.timestamp()
    return seconds if math.isfinite(seconds) else None


def _hour_start(t: float, tz: tzinfo | None) -> float:
    moment = datetime.fromtimestamp(t, timezone.utc).astimezone(tz)
    return moment.replace(minute=0, second=0, microsecond=0).timestamp()


def _error_type(record: dict[str, object]) -> str | None:
    error = record.get("error")
    return _optional_str(error.get("type")) if isinstance(error, dict) else None


def _reason(record: dict[str, object]) -> str:
    error = record.get("error")
    if not isinstance(error, dict):
        return "no error recorded"
    kind, message = error.get("type", "?"), error.get("message")
    return f"{kind}: {message}" if message else str(kind)


def _operation(record: dict[str, object]) -> str:
    if record.get("step") == "connect":
        return "connect"
    operation = record.get("operation")
    return operation if isinstance(operation, str) else "pick"


def _optional_str(value: object) -> str | None:
    return value if isinstance(value, str) else None


def counted(n: int, noun: str, width: int = 1) -> str:
    """``n`` (right-aligned in ``width``) and ``noun``, plural unless ``n`` is 1: how the text
    and the picture count."""
    return f"{n:{width}d} {noun}" + ("s" if n != 1 else "")
