"""The shift report: exact figures from an audit file of known contents written by the real
AuditLog (its clock scripted), the window, what is skipped, the JSON and the picture, the
one-line errors, and a report of records written by the real Cell (fault, halt, resume)."""

from __future__ import annotations

import json
from collections.abc import Callable
from datetime import datetime, timedelta, timezone
from pathlib import Path

import pytest

from handeye_pick import audit as audit_module
from handeye_pick.audit import AuditLog, read_audit
from handeye_pick.cli import main
from handeye_pick.errors import CellHalted, PlanRefused, RobotFault
from handeye_pick.report.lines import read_records
from handeye_pick.report.output import report_json
from handeye_pick.report.shift import PLAN_REFUSALS, ShiftReport, Tally, shift_report

DAY = datetime(2026, 12, 2, tzinfo=timezone.utc)
UTC = timezone.utc
Write = Callable[..., Path]


def at(clock: str) -> datetime:
    hours, minutes, seconds = (int(part) for part in clock.split(":"))
    return DAY + timedelta(hours=hours, minutes=minutes, seconds=seconds)


class _Clock:
    """The audit writer's clock, set before each append."""

    now_value = DAY

    @classmethod
    def now(cls, tz: object = None) -> datetime:
        return cls.now_value


@pytest.fixture
def write(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> Write:
    """``write(clock, record)``: append ``record`` to tmp_path/free-shift.jsonl at that time (UTC),
    through the real AuditLog."""
    monkeypatch.setattr(audit_module, "datetime", _Clock)
    path = tmp_path / "free-shift.jsonl"  # short records: not checked against the schema

    def append(clock: str, record: dict[str, object], pick_id: str = "p") -> Path:
        _Clock.now_value = at(clock)
        AuditLog(path, pick_id=pick_id).append(record)
        return path

    return append


def _pick(write: Write, clock_plan: str, clock_outcome: str, status: str, **extra: object) -> Path:
    write(clock_plan, {"event": "plan", "cycle": 1, "request_id": "r", "checks": []})
    return write(
        clock_outcome,
        {"event": "outcome", "cycle": 1, "request_id": "r", "dry_run": False, "status": status}
        | extra,
    )


def _known_shift(write: Write) -> Path:
    """A shift whose figures are worked out by hand in the tests below."""
    _pick(write, "6:00:00", "6:00:02", "placed")
    _pick(write, "6:00:05", "6:00:07", "placed")  # 5 s after the one before
    write("6:00:09", {"event": "capture", "cycle": 2, "capture_id": "c2"})
    no_candidate = {"type": "NoFeasibleCandidate", "message": "none passed"}
    write("6:00:10", {"event": "outcome", "status": "refused", "error": no_candidate})
    _pick(write, "6:00:12", "6:00:14", "missed")
    _pick(write, "6:00:15", "6:00:17", "picked")  # 10 s after the last completed one
    fault = {"type": "RobotFault", "message": "protective stop", "safety_mode": 3}
    _pick(write, "6:00:18", "6:00:20", "fault", step="grasp", error=fault)  # halts: 60 s
    write("6:00:30", {"event": "outcome", "status": "halted", "error": {"type": "CellHalted"}})
    write("6:01:20", {"event": "resume", "request_id": "r9", "status": "ready", "halted": "x"})
    _pick(write, "6:01:25", "6:01:27", "placed")  # after a halt: no cycle time
    _pick(write, "6:01:30", "6:01:33", "placed")  # 6 s
    write("6:30:00", {"event": "plan", "operation": "move home", "checks": []})
    write("6:30:02", {"event": "outcome", "operation": "move home", "status": "done"})
    write("6:40:00", {"event": "plan", "operation": "place", "checks": []})
    write("6:40:02", {"event": "outcome", "operation": "place", "status": "done"})
    write("6:59:00", {"event": "outcome", "status": "interrupted", "error": {"type": "X"}})
    _pick(write, "7:00:00", "7:00:03", "placed")  # after a stop: no cycle time
    _pick(write, "7:00:05", "7:00:08", "placed")  # 5 s
    aborted = {"type": "SequenceAborted", "message": "stands at 'approach'"}
    write("7:10:00", {"event": "plan", "operation": "move home", "checks": []})
    write(
        "7:10:01",
        {"event": "outcome", "operation": "move home", "status": "aborted", "step": "home"}
        | {"error": aborted},
    )  # halts to the end: 599 s
    return write(
        "7:20:00", {"event": "outcome", "status": "halted", "error": {"type": "CellHalted"}}
    )


def test_the_figures_of_a_known_shift(write: Write) -> None:
    report = shift_report(_known_shift(write), tz=UTC)
    assert report.cycles == 13
    assert report.statuses == {
        "placed": 6,
        "picked": 1,
        "missed": 1,
        "refused": 0,
        "no-candidate": 1,
        "halted": 2,
        "fault": 1,
        "dropped": 0,
        "aborted": 0,
        "stopped": 0,
        "interrupted": 1,
    }
    assert (report.places_done, report.dry_runs, report.abandoned) == (1, 0, 0)
    assert (report.faults, report.stops, report.halts, report.halted_refusals) == (2, 1, 2, 2)
    assert (report.interrupts, report.stop_requests, report.connect_faults) == (1, 0, 0)
    assert (report.resumes, report.resumes_not_ready) == (1, 0)
    assert (report.start, report.end) == (at("6:00:00").timestamp(), at("7:20:00").timestamp())
    assert report.halted_s == 60.0 + 599.0
    assert report.halted_share == pytest.approx(659.0 / (80 * 60))
    assert [(h.picks, h.cycles, h.faults) for h in report.hours] == [(5, 10, 1), (2, 3, 1)]
    assert [h.start for h in report.hours] == [at("6:00:00").timestamp(), at("7:00:00").timestamp()]
    times = report.cycle_times
    assert times.count == 4  # 5, 10, 6 and 5 s
    assert times.median_s == 5.5
    assert times.p90_s == pytest.approx(6.0 + 0.7 * 4.0)  # linear between the ranks
    assert sum(times.counts) + times.under + times.over == 4
    first, second = report.fault_list
    assert (first.status, first.operation, first.step) == ("fault", "pick", "grasp")
    assert first.reason == "RobotFault: protective stop"
    assert (first.halt_end, first.ended_by) == (at("6:01:20").timestamp(), "resume")
    assert (second.status, second.operation, second.step) == ("aborted", "move home", "home")
    assert (second.halt_end, second.ended_by) == (None, None)  # still halted at the end
    assert report_json(report)["fault_list"][1]["stood_s"] == 599.0


def test_a_halt_without_a_resume_ends_at_the_next_plan(write: Write) -> None:
    # A new session starts unhalted (or a file from before resume records existed).
    _pick(write, "6:00:00", "6:00:10", "dropped", step="place_approach", error={"type": "D"})
    _pick(write, "6:05:10", "6:05:12", "placed")
    report = shift_report(write("6:05:20", {"event": "capture", "cycle": 3}), tz=UTC)
    (fault,) = report.fault_list
    assert (fault.ended_by, fault.halt_end) == ("plan", at("6:05:10").timestamp())
    assert report.halted_s == 300.0


def test_a_fault_while_halted_starts_no_halt_of_its_own(write: Write) -> None:
    _pick(write, "6:00:00", "6:00:10", "fault", step="grasp", error={"type": "RobotFault"})
    connect = {"event": "outcome", "step": "connect", "reached": {}, "status": "fault"}
    write("6:01:00", connect | {"error": {"type": "RobotConnectionError", "message": "no"}})
    path = write("6:02:10", {"event": "resume", "request_id": None, "status": "ready"})
    report = shift_report(path, tz=UTC)
    assert (report.faults, report.halts, report.halted_s) == (2, 1, 120.0)
    assert [f.started_halt for f in report.fault_list] == [True, False]
    assert report.fault_list[1].operation == "connect"
    assert report.cycles == 1  # a failed connect is no cycle


def test_a_stop_request_halts_the_cell_and_counts_as_a_stop_not_a_fault(
    write: Write, capsys: pytest.CaptureFixture[str]
) -> None:
    _pick(write, "6:00:00", "6:00:02", "placed")
    stop = {"type": "StopRequested", "message": "stopped by request 7"}
    _pick(write, "6:00:05", "6:00:06", "stopped", step="approach", error=stop)
    write("6:00:30", {"event": "outcome", "status": "halted", "error": {"type": "CellHalted"}})
    write("6:01:06", {"event": "resume", "request_id": "r8", "status": "ready"})
    _pick(write, "6:01:10", "6:01:12", "placed")  # after a stop: no cycle time
    path = _pick(write, "6:01:15", "6:01:20", "placed")
    report = shift_report(path, tz=UTC)
    assert report.statuses["stopped"] == 1
    assert (report.stops, report.stop_requests, report.interrupts) == (1, 1, 0)
    assert (report.faults, report.halts, report.halted_s, report.halted_refusals) == (0, 1, 60.0, 1)
    (stopped,) = report.fault_list
    assert (stopped.status, stopped.started_halt, stopped.ended_by) == ("stopped", True, "resume")
    assert report.cycle_times.count == 1  # 8 s; the interval across the stop is left out
    assert main(["report", str(path)]) == 0
    out = capsys.readouterr().out
    assert "faults 0, stops 1 (1 stop request, 0 Ctrl-C or SIGTERM), halts 1" in out
    assert "stood 0:01:00 until resume: StopRequested: stopped by request 7" in out


def test_a_failed_connect_is_a_fault_that_halts_nothing(
    write: Write, capsys: pytest.CaptureFixture[str]
) -> None:
    # A one-shot pick that could not connect ran no session: no cell stood halted after it.
    _pick(write, "6:00:00", "6:00:02", "placed")
    connect = {"event": "outcome", "step": "connect", "reached": {}, "status": "fault"}
    write("6:00:30", connect | {"error": {"type": "RobotConnectionError", "message": "refused"}})
    path = _pick(write, "6:10:00", "6:10:02", "placed")
    report = shift_report(path, tz=UTC)
    assert (report.faults, report.connect_faults, report.halts, report.halted_s) == (1, 1, 0, 0.0)
    assert [(f.operation, f.started_halt) for f in report.fault_list] == [("connect", False)]
    assert main(["report", str(path)]) == 0
    out = capsys.readouterr().out
    assert "faults 1 (1 failing to connect)" in out
    assert "connect            no session, no halt: RobotConnectionError: refused" in out


def test_the_text_says_one_pick_and_a_halt_still_open(
    write: Write, capsys: pytest.CaptureFixture[str]
) -> None:
    _pick(write, "6:00:00", "6:00:02", "placed")
    path = _pick(write, "6:00:05", "6:00:07", "fault", step="grasp", error={"type": "RobotFault"})
    write("6:00:37", {"event": "outcome", "status": "halted", "error": {"type": "CellHalted"}})
    assert main(["report", str(path), "--since", "2026-12-02T06:00:00+00:00"]) == 0
    out = capsys.readouterr().out
    assert "pick outcomes 3: placed 1," in out
    assert "    1 pick       3 outcomes      1 fault" in out
    assert "stood 0:00:30, still halted at the end: RobotFault" in out


def test_since_and_until_count_the_window_and_clip_the_halts(write: Write) -> None:
    report = shift_report(_known_shift(write), at("6:01:00"), at("7:00:05"), tz=UTC)
    assert report.cycles == 4  # placed 6:01:27, 6:01:33, 7:00:03; interrupted 6:59
    assert report.statuses["placed"] == 3
    assert report.cycle_times.count == 1  # 6 s; 7:00:03 follows a stop
    assert report.faults == 0  # the fault at 6:00:20 lies before the window ...
    assert report.halts == 1  # ... but its halt reaches into it
    assert report.halted_s == 20.0
    assert report.span_s == 59 * 60 + 5


def test_torn_lines_and_unknown_kinds_are_counted_and_skipped(write: Write) -> None:
    path = _known_shift(write)
    expected = report_json(shift_report(path, tz=UTC))
    write("7:20:01", {"event": "shift-start", "operator": "kim"})
    with path.open("ab") as file:
        file.write(b"not json at all\n")
    write("7:20:02", {"event": "shift-start", "operator": "lee"})
    with path.open("ab") as file:  # a writer killed mid-line
        file.write(b'{"schema": 2, "timestamp": "2026-12-02T07:20:03+00:00", "pick_id": "p", "ev')
    report = shift_report(path, tz=UTC)
    assert report.torn == 2
    assert report.unknown_kinds == {"shift-start": 2}
    got = report_json(report)
    skipped = {"torn_lines": 2, "unknown_kinds": {"shift-start": 2}, "bad_records": 0}
    assert got["skipped"] == skipped
    for key in ("cycles", "statuses", "faults", "halted_s", "picks_per_hour", "cycle_time_s"):
        assert got[key] == expected[key], key


def test_a_torn_plan_that_ends_in_a_brace_is_read_by_its_head(tmp_path: Path) -> None:
    # A cut right after a nested object's brace looks closed; its head (all the report takes
    # of a plan) is intact, so it counts as a plan, and every other cut as a torn line.
    line = '{"schema": 2, "timestamp": "2026-12-02T06:00:00+00:00", "pick_id": "p", "event": "plan"'
    path = tmp_path / "free-plan.jsonl"
    path.write_text(line + ', "motion": {"speed_mps": 0.2}\n' + line + ', "motion": {"spe\n')
    first, second = read_records(path)
    assert first == {"event": "plan", "timestamp": "2026-12-02T06:00:00+00:00"}
    assert isinstance(second, audit_module.TornLine)


def test_reading_by_the_head_gives_the_report_of_reading_every_record_whole(write: Write) -> None:
    path = _known_shift(write)
    write("7:30:00", {"event": "outcome", "operation": 'move "odd" pose', "status": "done"})
    write("7:30:01", {"event": "outcome", "status": "dry-run", "dry_run": True})
    write("7:30:02", {"event": "outcome", "status": "abandoned", "dry_run": None})
    fast = report_json(shift_report(path, tz=UTC))
    whole = Tally(path, None, None, UTC)
    for entry in read_audit(path):
        whole.add(entry)
    assert report_json(whole.finish()) == fast
    assert fast["dry_runs"] == 1
    assert fast["abandoned"] == 1


def test_the_plan_refusals_are_the_subclasses_of_plan_refused() -> None:
    import handeye_pick.cell.plan
    import handeye_pick.safety  # noqa: F401  (PreflightRefusal)

    def subclasses(kind: type) -> set[str]:
        return {name for sub in kind.__subclasses__() for name in {sub.__name__, *subclasses(sub)}}

    assert subclasses(PlanRefused) == PLAN_REFUSALS


def test_json_prints_the_report_as_one_object(
    write: Write, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _known_shift(write)
    assert main(["report", str(path), "--json", "--until", "2026-12-02T09:00:00+00:00"]) == 0
    out, err = capsys.readouterr()
    report = json.loads(out)
    assert err == ""
    assert report["cycles"] == 13
    assert report["until"].startswith("2026-12-02T")
    assert set(report) >= {
        "statuses",
        "faults",
        "stops",
        "halts",
        "halted_s",
        "halted_share",
        "picks_per_hour",
        "cycle_time_s",
        "fault_list",
        "skipped",
    }
    assert set(report["cycle_time_s"]) == {"count", "median", "p90", "histogram"}
    assert report["fault_list"][0]["ended_by"] == "resume"


def test_the_command_warns_once_for_what_it_skipped(
    write: Write, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _known_shift(write)
    with path.open("ab") as file:
        file.write(b'{"schema": 2, "timest')
    assert main(["report", str(path)]) == 0
    out, err = capsys.readouterr()
    assert "pick outcomes 13: placed 6" in out
    assert len(err.strip().splitlines()) == 1
    assert "1 torn or non-JSON lines" in err


def test_the_plot_is_a_png(
    write: Write, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    picture = tmp_path / "shift.png"
    assert main(["report", str(_known_shift(write)), "--plot", str(picture)]) == 0
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert f"drawn to {picture}" in capsys.readouterr().out


def test_the_plot_of_a_shift_without_a_cycle_time(write: Write, tmp_path: Path) -> None:
    picture = tmp_path / "one-pick.png"
    path = _pick(write, "6:00:00", "6:00:02", "placed")
    assert main(["report", str(path), "--plot", str(picture)]) == 0
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("problem", ["missing", "folder", "newer", "time", "window", "plot"])
def test_bad_input_ends_in_one_line_and_exit_2(
    problem: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "free-a.jsonl"
    path.write_text(json.dumps({"schema": 2, "timestamp": DAY.isoformat(), "event": "plan"}) + "\n")
    argv = {
        "missing": ["report", str(tmp_path / "nothing.jsonl")],
        "folder": ["report", str(tmp_path)],
        "newer": ["report", str(path)],
        "time": ["report", str(path), "--since", "yesterday"],
        "window": ["report", str(path), "--since", "2026-12-02T08:00", "--until", "2026-12-02T07"],
        "plot": ["report", str(path), "--plot", str(tmp_path / "no" / "folder.png")],
    }[problem]
    if problem == "newer":
        path.write_text(json.dumps({"schema": 3, "timestamp": DAY.isoformat()}) + "\n")
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ")
    assert len(err.strip().splitlines()) == 1
    assert "Traceback" not in err


def test_a_report_of_what_the_cell_wrote(tmp_path: Path) -> None:
    from tests.unit.test_cell_session import ScriptedArm, _cell, _config, _detection

    config = _config(tmp_path)
    arm = ScriptedArm(config.audit.file)
    arm.fail_on_move = 2
    cell = _cell(config, arm)
    with pytest.raises(RobotFault):
        cell.pick(_detection())
    with pytest.raises(CellHalted):
        cell.pick(_detection())
    arm.fail_on_move = None
    cell.resume(request_id="r1")
    cell.pick(_detection())
    cell.close()
    report: ShiftReport = shift_report(config.audit.file)
    assert report.cycles == 3
    assert {k: v for k, v in report.statuses.items() if v} == {
        "fault": 1,
        "halted": 1,
        "picked": 1,
    }
    assert (report.faults, report.halts, report.resumes, report.halted_refusals) == (1, 1, 1, 1)
    (fault,) = report.fault_list
    assert (fault.step, fault.ended_by) == ("grasp", "resume")
    assert "protective stop" in fault.reason
