"""The line's parts on their own (docs/line.md): the ``line.io`` config, the OPC UA users file,
the error codes, the outputs each state shows, and the counters against ``report`` on the same
audit file."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from handeye_pick.audit import AuditLog
from handeye_pick.errors import ConfigError, InputError, Status
from handeye_pick.line.codes import ERROR_CODES, MAX_TEXT_CHARS, UNKNOWN_CODE, line_error
from handeye_pick.line.counters import AuditCounters
from handeye_pick.line.io import outputs_for
from handeye_pick.line.state import ItemState, LineView, OperationMode
from handeye_pick.line.users import hashed_line, read_users
from handeye_pick.report.shift import shift_report
from tests.unit.test_config_gripper import _load

ROOT = Path(__file__).resolve().parents[2]
INPUTS = {"cycle_stop": 4, "stop": 5, "resume": 6}
OUTPUTS = {"ready": 0, "executing": 1, "held": 2, "halted": 7, "heartbeat": 6}


def test_line_io_reads_inputs_and_outputs_by_meaning(tmp_path: Path) -> None:
    config = _load(tmp_path, line={"io": {"inputs": INPUTS, "outputs": OUTPUTS}})
    assert config.line.io is not None
    assert (config.line.io.inputs, config.line.io.outputs) == (INPUTS, OUTPUTS)
    assert _load(tmp_path).line.io is None


@pytest.mark.parametrize(
    ("io", "message"),
    [
        ({"outputs": {"ready": 3}}, "line.io.outputs.ready: standard digital output 3 is the "
                                    "gripper's"),
        ({"inputs": {"stop": 1, "resume": 1}}, "line.io.inputs.resume: standard digital 1 is"),
        ({"inputs": {"stop": 8}}, "line.io.inputs.stop: must be between 0 and 7"),
        ({"inputs": {"pause": 2}}, "line.io.inputs.pause: unknown key"),
        ({}, "line.io: give inputs, outputs or both"),
    ],
)
def test_line_io_refuses_the_grippers_bits_and_bad_numbers(
    tmp_path: Path, io: dict[str, Any], message: str
) -> None:
    with pytest.raises(ConfigError, match=re.escape(message)):
        _load(tmp_path, line={"io": io})


def test_line_io_refuses_the_grippers_feedback_input(tmp_path: Path) -> None:
    gripper = {"bank": "standard", "index": 3, "close_value": True,
               "confirm_input": {"bank": "standard", "index": 5, "value": True}}
    with pytest.raises(ConfigError, match=r"inputs\.stop: standard digital input 5 is the "
                                          "gripper's feedback"):
        _load(tmp_path, robot__gripper=gripper, line={"io": {"inputs": {"stop": 5}}})


def test_a_users_file_accepts_the_password_and_nothing_else(tmp_path: Path) -> None:
    path = tmp_path / "users"
    path.write_text("# the line's panels\n" + hashed_line("panel", "s3cret-enough") + "\n")
    users = read_users(path)
    assert users["panel"].accepts("s3cret-enough")
    assert not users["panel"].accepts("s3cret-enougH")
    assert "s3cret" not in path.read_text()


@pytest.mark.parametrize(
    "text", ["panel:plain:secret\n", "", "panel:scrypt:16384:8:1:zz:00\n"]
)
def test_a_users_file_with_no_hashed_user_is_refused(tmp_path: Path, text: str) -> None:
    path = tmp_path / "users"
    path.write_text(text)
    with pytest.raises(InputError, match="--opcua-users"):
        read_users(path)


def test_a_short_password_is_refused() -> None:
    with pytest.raises(InputError, match="at least 8"):
        hashed_line("panel", "short")


def test_every_failure_status_has_its_own_stable_code() -> None:
    assert len(set(ERROR_CODES.values())) == len(ERROR_CODES)
    failing = {s.value for s in Status} - {
        "placed", "picked", "dry-run", "done", "moved", "captured", "ready", "bye", "busy",
        "bad-request", "held",
    }
    assert failing <= set(ERROR_CODES)
    assert line_error("fault", "RobotFault: x\nmore").text == "RobotFault: x"
    assert len(line_error("fault", "y" * 999).text) == MAX_TEXT_CHARS
    assert line_error("newer", "z").code == UNKNOWN_CODE


@pytest.mark.parametrize(
    ("state", "held", "shown"),
    [
        (ItemState.NOT_EXECUTING, False, {"ready"}),
        (ItemState.NOT_EXECUTING, True, {"held"}),
        (ItemState.EXECUTING, True, {"executing", "held"}),
        (ItemState.OUT_OF_SERVICE, False, {"halted"}),
        (ItemState.NOT_AVAILABLE, False, {"halted"}),
    ],
)
def test_each_state_shows_its_outputs(state: ItemState, held: bool, shown: set[str]) -> None:
    view = LineView(state, held, "x" if held else None, None, OperationMode.PROCESSING, None, 3)
    outputs = outputs_for(view)
    assert {name for name, on in outputs.items() if on and name != "heartbeat"} == shown
    assert outputs["heartbeat"] != outputs_for(LineView(
        state, held, None, None, OperationMode.PROCESSING, None, 4))["heartbeat"]


def _outcome(log: AuditLog, status: str, **extra: Any) -> None:
    log.next_pick().append({"event": "outcome", "status": status, "request_id": "r", **extra})


def test_the_counters_are_the_reports_numbers_read_as_the_file_grows(tmp_path: Path) -> None:
    path = tmp_path / "free-picks.jsonl"  # records by hand: no schema check (tests/audit_schema.py)
    log = AuditLog(path)
    counters = AuditCounters(path, 0, 0.0)
    _outcome(log, "placed")
    _outcome(log, "placed")
    assert counters.snapshot().outcomes["placed"] == 2
    error = {"type": "RobotFault", "message": "protective stop during grasp"}
    _outcome(log, "fault", error=error, step="grasp")
    with path.open("ab") as file:  # a record still being written waits for its newline
        file.write(b'{"schema": 2, "timestamp": "2026-01-01T00:00:00+00:00"')
    middle = counters.snapshot()
    assert (middle.last_error.code, middle.last_error.text) == (
        401, "RobotFault: protective stop during grasp")
    with path.open("ab") as file:
        file.write(b', "pick_id": "p", "event": "capture"}\n')
    log.next_pick().append({"event": "resume", "request_id": "r", "status": "ready",
                            "halted": "x", "problems": []})
    _outcome(log, "missed", missed="no part sensed on input 5")
    _outcome(log, "placed")
    seen = counters.snapshot()
    report = shift_report(path)
    assert seen.outcomes == {name: report.statuses.get(name, 0) for name in seen.outcomes}
    assert (seen.cycles, seen.halted_s, seen.resumes) == (
        report.cycles, report.halted_s, report.resumes)
    assert seen.cycle_median_s == report.cycle_times.median_s
    assert (seen.last_error.code, seen.last_error.text) == (501, "no part sensed on input 5")
    assert json.loads(path.read_text().splitlines()[-1])["status"] == "placed"


def test_run_help_loads_no_opcua() -> None:
    probe = ("import sys; from handeye_pick.cli import main\n"
             "try: main(['run', '--help'])\nexcept SystemExit: pass\n"
             "print('asyncua' in sys.modules, file=sys.stderr)")
    result = subprocess.run([sys.executable, "-c", probe], cwd=ROOT, capture_output=True,
                            text=True, timeout=120, check=False)
    assert result.stderr.strip().splitlines()[-1] == "False", result.stderr


class _BrokenLine:
    """A line state whose reading fails: what a defect behind the server would look like."""

    cell = None
    cycle_stop = release = stop = resume = None

    def view(self) -> LineView:
        raise RuntimeError("a defect behind the server")


def test_a_crash_of_the_opcua_server_ends_only_the_server_with_one_warning(
    loopback_host: str, caplog: pytest.LogCaptureFixture
) -> None:
    from handeye_pick.line.opcua import LineServer

    server = LineServer(_BrokenLine(), loopback_host, 0, None, None,  # type: ignore[arg-type]
                        {"cell": "test"}).start()
    server._thread.join(timeout=30)
    assert not server._thread.is_alive()
    warnings = [r.getMessage() for r in caplog.records if r.name == "handeye_pick.line.opcua"]
    assert warnings == ["OPC UA server stopped (RuntimeError: a defect behind the server); the "
                        "cell goes on without it"]
    server.close()  # safe after the crash
