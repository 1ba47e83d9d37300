"""The line state (``handeye_pick.line.state.Line``) driven in-process on a session against the
simulated controller through the real ur_rtde: the states each door reads, the hold, the
immediate stop, the resume handed to the cell's thread, and the ``line`` audit record of each
command. ``tests/integration/test_line.py`` drives the same through ``handeye-pick run``; this
file holds what mutation testing can see (it traces only in-process calls)."""

from __future__ import annotations

import json
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from handeye_pick.cell.session import Cell
from handeye_pick.errors import Status
from handeye_pick.line.counters import AuditCounters
from handeye_pick.line.io import WiredHandshake, outputs_for
from handeye_pick.line.state import CommandResult, ItemState, Line, LineView, OperationMode
from handeye_pick.runner import Runner
from tests.integration.test_pick_cli import TCP_OFFSET
from tests.integration.test_run_loop import SimFactory, _unlock_protective_stop, loop_config


@pytest.fixture
def cell_line(sim_controller: SimFactory, tmp_path: Path) -> Iterator[tuple[Line, Any]]:
    """A connected cell, its runner and its line state, as ``run`` makes them."""
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    with Cell(loop_config(tmp_path, ctl.host)) as cell:
        yield line_of(cell), ctl


def line_of(cell: Cell) -> Line:
    """The line state of ``cell`` on a new runner, wired as ``run`` wires them."""
    runner = Runner(cell)
    line = Line(cell, runner, AuditCounters.from_now(cell.config.audit.file))
    runner.line = line
    return line


def line_records(line: Line) -> list[dict[str, Any]]:
    """The ``line`` records of the cell's audit file, in order."""
    records = [json.loads(text) for text in line.counters.path.read_text().splitlines()]
    return [record for record in records if record.get("event") == "line"]


def test_a_ready_cell_is_not_executing_in_processing_mode(cell_line: tuple[Line, Any]) -> None:
    line, _ = cell_line
    view = line.view()
    assert (view.state, view.held, view.held_by, view.halted_reason, view.request) == (
        ItemState.NOT_EXECUTING, False, None, None, None,
    )  # fmt: skip
    assert (view.mode, view.mode.title, view.state.title) == (
        OperationMode.PROCESSING, "Processing", "NotExecuting",
    )  # fmt: skip
    assert view.ready
    assert 0 <= view.heartbeat_s < 600  # whole seconds since the line started, not a clock
    assert line.status_fields() == {"held": False, "held_by": None, "line_state": "NotExecuting"}
    assert line.held_s() == 0.0


def test_a_cycle_stop_holds_for_every_door_until_a_release(cell_line: tuple[Line, Any]) -> None:
    line, _ = cell_line
    held = line.cycle_stop("opcua alice")
    assert (held.ok, held.text) == (True, "held: no request runs")
    assert line.held() == "opcua alice"
    view = line.view()
    assert (view.held, view.held_by, view.ready) == (True, "opcua alice", False)
    assert line.status_fields() == {
        "held": True, "held_by": "opcua alice", "line_state": "NotExecuting",
    }  # fmt: skip
    again = line.cycle_stop("input DI4")
    assert (again.ok, again.text) == (True, "held already by opcua alice")
    assert line.held() == "opcua alice"  # the first hold is the one in force
    # A motion request from the vision program is answered held and never runs.
    reply = line.runner.handle(json.dumps({"id": "m", "op": "move", "pose": "home"}))
    assert (reply["ok"], reply["status"], reply["held_by"]) == (False, "held", "opcua alice")
    assert 0.0 < line.held_s() < 600.0  # seconds held so far, not a clock reading
    released = line.release("input DI4")
    assert (released.ok, released.text) == (True, "released (held by opcua alice)")
    assert (line.held(), line.view().ready) == (None, True)
    spent = line.held_s()
    assert 0.0 < spent < 600.0
    assert line.held_s() == spent  # a released hold no longer counts
    assert line.release("opcua bob").text == "released: not held"
    records = line_records(line)
    assert [(r["command"], r["by"], r["ok"], r["held"], r["halted"]) for r in records] == [
        ("cycle-stop", "opcua alice", True, True, None),
        ("cycle-stop", "input DI4", True, True, None),
        ("release", "input DI4", True, False, None),
        ("release", "opcua bob", True, False, None),
    ]  # fmt: skip
    assert records[0]["message"] == "held: no request runs"


def test_a_second_hold_adds_to_the_time_held(cell_line: tuple[Line, Any]) -> None:
    line, _ = cell_line
    line.cycle_stop("a")
    line.release("a")
    first = line.held_s()
    line.cycle_stop("b")
    line.release("b")
    assert line.held_s() > first


def test_the_vision_programs_commands_reply_with_the_hold(cell_line: tuple[Line, Any]) -> None:
    line, _ = cell_line
    assert line.command("cycle-stop", "request 7") == {
        "ok": True, "status": Status.HELD, "held": True, "message": "held: no request runs",
    }  # fmt: skip
    assert line.command("release", "request 8") == {
        "ok": True, "status": Status.READY, "held": False,
        "message": "released (held by request 7)",
    }  # fmt: skip


def test_an_immediate_stop_halts_until_a_resume_run_by_the_cells_thread(
    cell_line: tuple[Line, Any],
) -> None:
    line, _ = cell_line
    stopped = line.stop("input DI5")
    assert (stopped.ok, stopped.text) == (True, "stopped")
    view = line.view()
    assert (view.state, view.state.title, view.halted_reason) == (
        ItemState.OUT_OF_SERVICE, "OutOfService", "stopped by input DI5",
    )  # fmt: skip
    assert not view.ready
    # Another door's resume waits until the cell's thread takes it between requests.
    results: list[Any] = []
    door = threading.Thread(target=lambda: results.append(line.resume("opcua alice", 30.0)))
    door.start()
    while door.is_alive():
        line.runner.idle()  # the cell's thread between requests
        door.join(0.01)
    (resumed,) = results
    assert (resumed.ok, resumed.text) == (True, "resumed: the cell is ready")
    assert (line.view().state, line.cell.halted) == (ItemState.NOT_EXECUTING, None)
    records = line_records(line)
    assert [(r["command"], r["by"], r["ok"], r["halted"]) for r in records] == [
        ("stop", "input DI5", True, "stopped by input DI5"),
        ("resume", "opcua alice", True, None),
    ]  # fmt: skip
    assert records[1]["message"] == "resumed: the cell is ready"


def test_a_resume_during_a_protective_stop_is_refused_saying_why(
    cell_line: tuple[Line, Any],
) -> None:
    line, ctl = cell_line
    ctl.inject("protective-stop")
    line.stop("opcua alice")
    assert line.resume("opcua alice", 0) == CommandResult(True, "handed to the cell")
    line.run_pending()
    records = line_records(line)
    assert (records[-1]["command"], records[-1]["ok"]) == ("resume", False)
    assert "protective" in records[-1]["message"].lower()
    assert line.cell.halted is not None
    _unlock_protective_stop(ctl.host)
    line.resume("opcua alice", 0)
    line.run_pending()
    assert (line_records(line)[-1]["ok"], line.cell.halted) == (True, None)


def test_resumes_past_the_bound_are_not_taken(cell_line: tuple[Line, Any]) -> None:
    line, _ = cell_line
    line.stop("opcua alice")
    taken = [line.resume(f"door {n}", 0) for n in range(5)]
    assert [r.text for r in taken[:4]] == ["handed to the cell"] * 4
    assert (taken[4].ok, taken[4].text) == (
        False, "resumes are waiting already: this one was not taken",
    )  # fmt: skip
    line.run_pending()
    assert [r["by"] for r in line_records(line) if r["command"] == "resume"] == [
        "door 0", "door 1", "door 2", "door 3",
    ]  # fmt: skip


def test_a_resume_nobody_takes_ends_after_its_wait(cell_line: tuple[Line, Any]) -> None:
    line, _ = cell_line
    late = line.resume("opcua alice", 0.05)
    assert (late.ok, late.text) == (False, "the cell did not finish the resume within 0.05 s")


def test_a_stop_while_a_request_runs_says_which(cell_line: tuple[Line, Any]) -> None:
    """The stop's text names the request running; the state reads Executing meanwhile."""
    line, _ = cell_line
    seen: list[Any] = []

    def at_step(step: str) -> None:
        if not seen:
            seen.append(line.view())
            seen.append(line.cycle_stop("opcua alice"))
            seen.append(line.stop("input DI5"))

    line.cell.watch_steps(at_step)
    reply = line.runner.handle(json.dumps({"id": "m9", "op": "move", "pose": "home"}))
    view, held, stopped = seen
    assert (view.state, view.request["id"], view.request["op"]) == (
        ItemState.EXECUTING, "m9", "move",
    )  # fmt: skip
    assert held.text == "holding after request m9 (move)"
    assert stopped.text == "stopped while request m9 ran move"
    assert line.cell.halted == "stopped by input DI5 while request m9 ran move"
    assert reply["ok"] is False


def test_a_closed_session_is_not_available(cell_line: tuple[Line, Any]) -> None:
    line, _ = cell_line
    line.cell.close()
    assert line.view().state is ItemState.NOT_AVAILABLE


def test_a_resume_request_running_is_not_executing(cell_line: tuple[Line, Any]) -> None:
    """A resume runs as a request (it reconnects) but moves nothing: the line never reads it
    as Executing."""
    line, _ = cell_line
    views: list[Any] = []
    resume = threading.Thread(
        target=lambda: line.runner.handle(json.dumps({"id": "r", "op": "resume"}))
    )
    resume.start()
    while resume.is_alive():
        view = line.view()
        if view.request is not None:
            views.append(view)
        resume.join(0.002)
    assert views, "the resume ended before the line was read while it ran"
    assert {v.request["op"] for v in views} == {"resume"}
    # NotAvailable while the link is reopened, NotExecuting once it is up; never Executing.
    assert {v.state for v in views} <= {ItemState.NOT_AVAILABLE, ItemState.NOT_EXECUTING}


def test_a_resume_whose_audit_record_cannot_be_written_fails_saying_why(
    cell_line: tuple[Line, Any], caplog: pytest.LogCaptureFixture
) -> None:
    line, _ = cell_line
    line.stop("opcua alice")
    audit = line.counters.path
    audit.unlink()
    audit.mkdir()  # the audit file is gone and cannot be made again
    results: list[Any] = []
    door = threading.Thread(target=lambda: results.append(line.resume("opcua bob", 30.0)))
    door.start()
    while door.is_alive():
        line.runner.idle()  # the cell's thread between requests
        door.join(0.01)
    (result,) = results
    assert result.ok is False
    assert result.text.startswith("audit: cannot append to ")
    # The command took effect; its own record could not be written either: said in the log.
    assert f"line resume by opcua bob: {result.text}" in caplog.messages
    assert "line resume by opcua bob: audit: cannot append" in "\n".join(caplog.messages)


IO = (
    "  io:\n    inputs: {cycle_stop: 4, stop: 5, resume: 6}\n"
    "    outputs: {ready: 4, executing: 5, held: 6, halted: 7, heartbeat: 3}\n"
)


def _looks_until(handshake: Any, done: Any) -> None:
    """Look (``step``) until ``done()``: the inputs reach the cell with the next RTDE sample."""
    for _ in range(400):
        handshake.step()
        if done():
            return
        threading.Event().wait(0.005)
    raise AssertionError("the handshake never saw the input")


def test_the_wired_handshake_turns_input_edges_into_commands_and_shows_the_state(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """``WiredHandshake.step`` on the cell's own thread: DI4 held high holds the cell, low
    releases it; a DI5 rising edge stops it; a DI6 rising edge hands a resume over; DO4-DO7
    show ready, executing, held, halted; the inputs and outputs are the simulator's."""
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    with Cell(loop_config(tmp_path, ctl.host, line=IO)) as cell:
        line = line_of(cell)
        runner = line.runner
        io = cell.config.line.io
        assert io is not None
        handshake = WiredHandshake(line, io)

        def outputs() -> dict[int, bool]:
            bits = ctl.snapshot().standard_digital_out
            return {bit: bool(bits >> bit & 1) for bit in (4, 5, 6, 7)}

        _looks_until(handshake, lambda: outputs() == {4: True, 5: False, 6: False, 7: False})
        ctl.set_inputs({4: True})
        _looks_until(handshake, lambda: line.held() is not None)
        assert line.held() == "input DI4 (cycle stop)"
        _looks_until(handshake, lambda: outputs() == {4: False, 5: False, 6: True, 7: False})
        handshake.step()  # the level stays high: no second command
        ctl.set_inputs({4: False})
        _looks_until(handshake, lambda: line.held() is None)
        ctl.set_inputs({5: True})
        _looks_until(handshake, lambda: cell.halted is not None)
        assert cell.halted == "stopped by input DI5 (stop)"
        _looks_until(handshake, lambda: outputs() == {4: False, 5: False, 6: False, 7: True})
        ctl.set_inputs({5: False, 6: True})
        _looks_until(handshake, lambda: not line._resumes.empty())
        runner.idle()  # the cell's thread takes the resume between requests
        assert cell.halted is None
        _looks_until(handshake, lambda: outputs() == {4: True, 5: False, 6: False, 7: False})
        handshake.close()
        assert outputs() == {4: False, 5: False, 6: False, 7: False}
    commands = [(r["command"], r["by"]) for r in line_records(line)]
    assert commands == [
        ("cycle-stop", "input DI4 (cycle stop)"),
        ("release", "input DI4 (cycle stop)"),
        ("stop", "input DI5 (stop)"),
        ("resume", "input DI6 (resume)"),
    ]


def _view(heartbeat_s: int) -> LineView:
    return LineView(ItemState.NOT_EXECUTING, False, None, None, OperationMode.PROCESSING, None,
                    heartbeat_s)  # fmt: skip


def test_the_heartbeat_output_toggles_every_second() -> None:
    assert [outputs_for(_view(s))["heartbeat"] for s in range(4)] == [True, False, True, False]


def test_the_handshake_thread_looks_by_itself_and_writes_only_configured_outputs(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """Started as ``run`` starts it (no heartbeat output configured): it shows ready on DO4 by
    itself, holds on DI4, and ``close`` switches its outputs off."""
    io = "  io:\n    inputs: {cycle_stop: 4}\n    outputs: {ready: 4, held: 6}\n"
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    with Cell(loop_config(tmp_path, ctl.host, line=io)) as cell:
        line = line_of(cell)
        assert cell.config.line.io is not None
        handshake = WiredHandshake(line, cell.config.line.io).start()

        def wait_for(done: Any) -> None:
            for _ in range(1000):
                if done():
                    return
                threading.Event().wait(0.005)
            raise AssertionError("the handshake thread never got there")

        def out(bit: int) -> bool:
            return bool(ctl.snapshot().standard_digital_out >> bit & 1)

        wait_for(lambda: out(4))
        ctl.set_inputs({4: True})
        wait_for(lambda: out(6) and not out(4))
        assert line.held() == "input DI4 (cycle stop)"
        handshake.close()
        assert (out(4), out(6)) == (False, False)


def test_a_wired_resume_reaches_a_cell_whose_link_is_closed(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """A resume the controller refused (a protective stop) leaves the session closed: the
    handshake then reads the inputs from outside, so DI6's edge still hands a resume over once
    the stop is cleared."""
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    with Cell(loop_config(tmp_path, ctl.host, line=IO)) as cell:
        line = line_of(cell)
        runner = line.runner
        assert cell.config.line.io is not None
        handshake = WiredHandshake(line, cell.config.line.io)
        ctl.inject("protective-stop")
        line.stop("opcua alice")
        line.resume("opcua alice", 0)
        line.run_pending()
        assert (cell.connected, line.view().state) == (False, ItemState.NOT_AVAILABLE)
        _unlock_protective_stop(ctl.host)
        handshake.step()  # reads DI6 low from outside
        ctl.set_inputs({6: True})
        _looks_until(handshake, lambda: not line._resumes.empty())
        runner.idle()
        assert (cell.connected, cell.halted) == (True, None), line_records(line)[-1]["message"]
    assert [r["by"] for r in line_records(line) if r["command"] == "resume"][-1] == (
        "input DI6 (resume)"
    )
