"""The next pick checked while the place before it still moves (docs/motion.md, "The next pick
checked under motion"), against the simulated controller through the real ur_rtde: a queued
pick is checked during the place and runs as checked once its start pose is confirmed; one whose
arm ended elsewhere (a stop) is planned again; a fault during the place leaves the pre-checked
pick unrun and answered ``halted``."""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from handeye_pick.cell.ahead import AheadRequest
from handeye_pick.cell.session import Cell
from handeye_pick.cli.run import _Loop
from handeye_pick.detection import detection_from_data
from handeye_pick.errors import Status, StopRequested
from handeye_pick.geometry import ur_pose_to_matrix
from handeye_pick.runner import Runner
from tests.audit_schema import invalid_records
from tests.integration.test_pick_cli import TCP_OFFSET, audit_records, motion_commands
from tests.integration.test_run_loop import (
    OBJECT_BASE_M,
    SimFactory,
    detection_for,
    loop_config,
)


def _line(request: dict[str, Any]) -> bytes:
    return json.dumps(request).encode() + b"\n"


def _pick(rid: str, capture: dict[str, Any], **extra: Any) -> bytes:
    T_capture = ur_pose_to_matrix(capture["flange_pose_ur"])
    candidates = [detection_for(T_capture, OBJECT_BASE_M)]
    request = {"id": rid, "op": "pick", "capture_id": capture["capture_id"], **extra}
    return _line({**request, "candidates": candidates})


def _of(records: list[dict[str, Any]], request_id: str) -> list[dict[str, Any]]:
    return [r for r in records if r.get("request_id") == request_id]


def test_a_queued_pick_is_checked_while_the_place_runs_and_runs_as_checked(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """Two picks queued: the second is checked while the first places, its plan record is on
    disk before the first's outcome, with every check the first had; the arm is confirmed where
    it was checked to start, and it runs as checked (one plan record, not planned again)."""
    ctl = sim_controller(tcp_offset=TCP_OFFSET)  # real-time motion
    out = io.StringIO()
    with Cell(loop_config(tmp_path, ctl.host)) as cell:
        runner = Runner(cell)
        captured = runner.handle(_line({"id": "c", "op": "capture"}))
        requests = _Loop(runner, out)
        requests.read(iter([_pick("p1", captured), _pick("p2", captured)]))
        requests.run()
    replies = [json.loads(line) for line in out.getvalue().splitlines()]
    assert [(r["id"], r["status"], r["place"]["index"]) for r in replies] == [
        ("p1", "placed", 0),
        ("p2", "placed", 1),
    ]
    records = audit_records(tmp_path)
    first, second = _of(records, "p1"), _of(records, "p2")
    assert [r["event"] for r in second] == ["plan", "outcome"]
    plan = second[0]
    assert records.index(plan) < records.index(first[1])  # checked while the place ran
    assert "replanned" not in plan
    np.testing.assert_allclose(
        ur_pose_to_matrix(plan["checked_ahead"]["start_pose"]),
        ur_pose_to_matrix(list(first[1]["reached"].values())[-1]),  # where the place ended
        atol=1e-3,
    )
    assert [c["name"] for c in plan["checks"]] == [c["name"] for c in first[0]["checks"]]
    assert invalid_records(tmp_path) == []


def test_a_pick_checked_ahead_is_planned_again_when_the_arm_stopped_elsewhere(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """A stop as the place's retreat starts leaves the arm short of where the next pick was
    checked to start: after the resume that pick is planned again from where the arm stands
    (a second plan record saying why) and placed."""
    ctl = sim_controller(tcp_offset=TCP_OFFSET, speed_factor=4.0)
    with Cell(loop_config(tmp_path, ctl.host)) as cell:
        capture = cell.capture()
        assert capture.T_base_flange is not None
        data = detection_for(capture.T_base_flange, OBJECT_BASE_M)
        detection = detection_from_data(data, "test")
        waiting = [AheadRequest("p2", (detection,), capture, True, "p2")]
        cell.look_ahead(lambda: waiting.pop() if waiting else None)

        def stop_at_retreat(step: str) -> None:
            if step == "place-retreat":
                cell.request_stop("stopped by the test")

        cell.watch_steps(stop_at_retreat)
        with pytest.raises(StopRequested):
            cell.pick([detection], capture, request_id="p1")
        cell.watch_steps(lambda step: None)
        cell.resume()
        result = cell.pick([detection], capture, request_id="p2", ahead_key="p2")
    assert result.status is Status.PLACED
    second = _of(audit_records(tmp_path), "p2")
    assert [r["event"] for r in second] == ["plan", "plan", "outcome"]
    assert "checked_ahead" in second[0]
    assert "from where the pick was checked to start" in second[1]["replanned"]
    assert second[2]["status"] == "placed"
    assert invalid_records(tmp_path) == []


def test_a_fault_during_the_place_leaves_the_checked_pick_unrun_and_halted(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """A protective stop while the first pick places: the second, checked meanwhile (its plan
    record on disk), is answered ``halted`` and sends no motion; its audit ends ``halted``."""
    ctl = sim_controller(tcp_offset=TCP_OFFSET, speed_factor=2.0)
    with Cell(loop_config(tmp_path, ctl.host)) as cell:
        runner = Runner(cell)
        captured = runner.handle(_line({"id": "c", "op": "capture"}))
        second = _pick("p2", captured)
        waiting = [second]
        runner.watch_queue(lambda: waiting[0] if waiting else None)

        def fault_at_place(event: dict[str, object]) -> None:
            if event.get("step") == "place":
                ctl.inject("protective-stop")

        runner.events = fault_at_place
        first = runner.handle(_pick("p1", captured, events=True))
        sent = len(motion_commands(ctl))
        answered = runner.handle(waiting.pop())
    assert first["status"] == "fault", first
    assert answered["status"] == "halted", answered
    assert len(motion_commands(ctl)) == sent
    records = _of(audit_records(tmp_path), "p2")
    assert [r["event"] for r in records] == ["plan", "outcome"]
    assert "checked_ahead" in records[0]
    assert records[1]["status"] == "halted"
    assert invalid_records(tmp_path) == []
