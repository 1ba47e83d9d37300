"""Grippers that report back, against the simulated controller through the real ur_rtde client:
the Robotiq 2F on its URCap socket, a digital gripper with and without a feedback input, grasp
confirmation, missed and dropped parts, gripper faults, and the payload the controller received
(its command record and the payload it publishes)."""

from __future__ import annotations

import json
import socket
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from handeye_pick.cell.session import Cell
from handeye_pick.detection import load_detection
from handeye_pick.errors import GripperFault, PartDropped
from handeye_pick.geometry import ur_pose_to_matrix
from handeye_pick.runner import Runner
from mocks.ur_controller import SimulatedController
from tests.integration.test_pick_cli import (
    DEMO,
    TCP_OFFSET,
    audit_records,
    run_json,
    write_config,
)

SimFactory = Callable[..., SimulatedController]
PART_MM = 40.0
ROBOTIQ = (
    "  gripper:\n    type: robotiq-2f\n    expected_width_mm: [38, 42]\n"
    "    speed_pct: 100\n    force_pct: 40\n    timeout_s: 0.5\n"
)
TOOL_PAYLOAD = "  tool_payload: {mass_kg: 1.0, cog_mm: [0, 0, 50]}\n"
OBJECT = "  mass_kg: 0.5\n  cog_mm: [0, 0, 30]\n"
PLACE = "  poses: [[-0.3, 0.35, 0.15, 3.14159265, 0, 0]]\n  approach_mm: 80\n  retreat_mm: 80\n"
FEEDBACK = (
    "  gripper:\n    type: digital-output\n    bank: tool\n    index: 0\n    close_value: true\n"
    "    settle_s: 0\n    confirm_input: {bank: tool, index: 0, value: true}\n"
    "    confirm_timeout_s: 0.3\n"
)
DIGITAL = "  gripper: {bank: tool, index: 0, close_value: true, settle_s: 0}\n"


def robotiq_config(tmp_path: Path, host: str, **sections: str) -> Path:
    return write_config(
        tmp_path, host, robot_extra=ROBOTIQ + TOOL_PAYLOAD, object=OBJECT, **sections
    )


def commands(ctl: SimulatedController) -> list[tuple[str, Any]]:
    """(kind, payload mass or nothing) of every motion, stop and payload command, in order."""
    return [(c["kind"], c.get("mass")) for c in ctl.commands]


def pick(config: Path) -> Any:
    with Cell(config) as cell:
        return cell.pick(load_detection(DEMO / "detection.yaml"))


def test_confirmed_pick_carries_the_part_payload_until_its_release(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True, part_width_mm=PART_MM)
    result = pick(robotiq_config(tmp_path, ctl.host, place=PLACE))
    assert result.status == "placed"
    # The part's payload before the retreat, the empty tool's after the release, before the
    # place retreat; the controller took both.
    assert commands(ctl) == [
        ("moveL", None),  # approach
        ("moveL", None),  # grasp
        ("setPayload", 1.5),
        ("moveL", None),  # retreat
        ("moveL", None),  # place approach
        ("moveL", None),  # place
        ("setPayload", 1.0),
        ("moveL", None),  # place retreat
    ]
    held = next(c for c in ctl.commands if c["kind"] == "setPayload")
    # tool 1 kg at 50 mm, part 0.5 kg 30 mm beyond the TCP (120 mm): (1 * 50 + 0.5 * 150) / 1.5
    np.testing.assert_allclose(held["cog"], [0.0, 0.0, 0.125 / 1.5], atol=1e-9)
    snapshot = ctl.snapshot()
    assert snapshot.payload_kg == 1.0
    np.testing.assert_allclose(snapshot.payload_cog, [0.0, 0.0, 0.05], atol=1e-9)
    assert snapshot.gripper_position == 0  # released
    outcome = audit_records(tmp_path)[-1]
    assert outcome["status"] == "placed"
    gripper = outcome["gripper"]
    assert gripper["kind"] == "robotiq-2f"
    assert [c["command"] for c in gripper["commands"]] == [
        "close",
        "set_payload",
        "open",
        "set_payload",
    ]
    assert gripper["commands"][0]["grasp"] == "confirmed"
    assert gripper["commands"][2]["release"] == "confirmed"
    assert [c.get("mass_kg") for c in gripper["commands"]] == [None, 1.5, None, 1.0]


def test_missed_grasp_opens_retreats_and_exits_5(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)  # no part
    config = robotiq_config(tmp_path, ctl.host, place=PLACE)
    status, report = run_json(config, "--detection", str(DEMO / "detection.yaml"))
    assert (status, report["status"]) == (5, "missed"), report
    # the tool's payload again after the miss (it never carried the part), no place
    assert [kind for kind, _ in commands(ctl)] == ["moveL", "moveL", "setPayload", "moveL"]
    assert commands(ctl)[2][1] == pytest.approx(1.0)
    assert ur_pose_to_matrix(list(ctl.snapshot().tcp_pose)) == pytest.approx(
        ur_pose_to_matrix(report["reached"]["retreat"]), abs=1e-6
    )
    assert ctl.snapshot().gripper_position == 0  # opened again
    outcome = audit_records(tmp_path)[-1]
    assert outcome["status"] == "missed"
    assert [c["command"] for c in outcome["gripper"]["commands"]] == [
        "close",
        "open",
        "set_payload",
    ]
    assert outcome["gripper"]["commands"][0]["grasp"] == "missed"
    assert outcome["gripper"]["commands"][2]["payload"] == "empty tool"


def test_part_dropped_during_retreat_stops_the_arm_and_halts_the_runner(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    # Real-time motion: the part slips out a third of the way up the retreat.
    ctl = sim_controller(
        tcp_offset=TCP_OFFSET, part_width_mm=PART_MM, inject=("gripper-drop@move:3:0.3",)
    )
    config = robotiq_config(tmp_path, ctl.host)
    detection = load_detection(DEMO / "detection.yaml")
    with Cell(config) as cell:
        capture = cell.capture()
        T_cam_obj_mm = detection.T_cam_obj[:3, 3] * 1000.0
        request = {
            "id": "1",
            "op": "pick",
            "capture_id": capture.capture_id,
            "candidates": [{"position_mm": T_cam_obj_mm.tolist()}],
        }
        runner = Runner(cell)
        reply = runner.handle(json.dumps(request))
        assert (reply["ok"], reply["status"]) == (False, "dropped"), reply
        assert "lost the part" in str(reply["error"])
        assert cell.halted is not None
        again = runner.handle(json.dumps({**request, "id": "2"}))
        assert again["status"] == "halted"
    # The retreat was stopped, the payload is the empty tool's again, and no motion followed.
    assert [kind for kind, _ in commands(ctl)] == [
        "moveL",
        "moveL",
        "setPayload",
        "moveL",
        "stopL",
        "setPayload",
    ]
    assert [value for _, value in commands(ctl)][-1] == pytest.approx(1.0)
    dropped, halted = audit_records(tmp_path)[-2:]  # the second request was refused
    assert (dropped["status"], dropped["step"]) == ("dropped", "retreat")
    assert halted["status"] == "halted"
    outcome = dropped
    assert outcome["error"]["type"] == PartDropped.__name__
    last = outcome["gripper"]["commands"][-1]
    assert (last["command"], last["payload"], last["mass_kg"]) == ("set_payload", "empty tool", 1.0)
    assert ctl.snapshot().payload_kg == 1.0  # not the 1.5 kg of tool and part


def test_a_part_held_between_pick_and_place_is_watched_on_every_move(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    # pick without placing (motions 1-3), move home (4), then place: the part slips out on the
    # way home, and the move that carries it is stopped like the pick's own.
    ctl = sim_controller(
        tcp_offset=TCP_OFFSET, part_width_mm=PART_MM, inject=("gripper-drop@move:4:0.3",)
    )
    home = "  home: {tcp_pose: [-0.45, -0.1, 0.4, 3.14159265, 0, 0]}\n"
    config = robotiq_config(tmp_path, ctl.host, place=PLACE, poses=home)
    with Cell(config) as cell:
        picked = cell.pick(load_detection(DEMO / "detection.yaml"), place=False)
        assert picked.status == "picked"
        with pytest.raises(PartDropped, match="lost the part"):
            cell.move_to("home")
        assert cell.halted is not None
    assert [kind for kind, _ in commands(ctl)][-3:] == ["moveL", "stopL", "setPayload"]
    assert ctl.snapshot().payload_kg == 1.0  # the empty tool's again
    assert audit_records(tmp_path)[-1]["status"] == "dropped"


def test_a_part_placed_by_a_later_pick_is_no_longer_watched(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    # pick without placing, then a pick that places: the gripper is empty afterwards, and the
    # next move must not take the open gripper for a dropped part.
    ctl = sim_controller(tcp_offset=TCP_OFFSET, part_width_mm=PART_MM, instant=True)
    home = "  home: {tcp_pose: [-0.45, -0.1, 0.4, 3.14159265, 0, 0]}\n"
    config = robotiq_config(tmp_path, ctl.host, place=PLACE, poses=home)
    detection = load_detection(DEMO / "detection.yaml")
    with Cell(config) as cell:
        capture = cell.capture()
        assert cell.pick(detection, capture, place=False).status == "picked"
        assert cell.pick(detection, capture).status == "placed"
        cell.move_to("home")
        assert cell.halted is None


@pytest.mark.parametrize(
    ("fault", "message"),
    [("gripper-fault:8", r"0x08 \(maximum operating temperature"), ("gripper-silent", "silent")],
)
def test_gripper_fault_or_silence_ends_in_a_clear_error(
    sim_controller: SimFactory, tmp_path: Path, fault: str, message: str
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True, part_width_mm=PART_MM)
    config = robotiq_config(tmp_path, ctl.host)
    with Cell(config) as cell:
        ctl.inject(f"{fault}@move:2:0.5")  # on the way down: the fingers were ready before
        with pytest.raises(GripperFault, match=message):
            cell.pick(load_detection(DEMO / "detection.yaml"))
        assert cell.halted is not None
    assert commands(ctl) == [("moveL", None)] * 2  # approach, grasp: no retreat, no payload
    outcome = audit_records(tmp_path)[-1]
    assert (outcome["status"], outcome["step"]) == ("fault", "gripper close")


def test_digital_gripper_confirms_only_through_its_feedback_input(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(
        tcp_offset=TCP_OFFSET, instant=True, part_width_mm=PART_MM, feedback_input=(16, 16)
    )
    # Every pick starts where the arm stood at first (the detection is seen from there).
    start = f"  start: {{tcp_pose: {list(ctl.snapshot().tcp_pose)}}}\n"

    def pick_from_start(gripper: str) -> str:
        with Cell(write_config(tmp_path, ctl.host, robot_extra=gripper, poses=start)) as cell:
            cell.move_to("start")
            result = cell.pick(load_detection(DEMO / "detection.yaml"))
        grasp: str = audit_records(tmp_path)[-1]["gripper"]["commands"][0]["grasp"]
        return f"{result.status} {grasp}"

    # Without the input in the config: the part is there, and still never "confirmed".
    assert pick_from_start(DIGITAL) == "picked unconfirmed"
    assert pick_from_start(FEEDBACK) == "picked confirmed"
    ctl.set_part(None)
    assert pick_from_start(FEEDBACK) == "missed missed"


def test_the_run_loop_answers_missed_and_stays_ready(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)  # no part
    T_cam_obj_mm = load_detection(DEMO / "detection.yaml").T_cam_obj[:3, 3] * 1000.0
    with Cell(robotiq_config(tmp_path, ctl.host)) as cell:
        runner = Runner(cell)
        captured = runner.handle('{"id": "1", "op": "capture"}')
        pick_request = {
            "id": "2",
            "op": "pick",
            "capture_id": captured["capture_id"],
            "candidates": [{"position_mm": T_cam_obj_mm.tolist()}],
        }
        reply = runner.handle(json.dumps(pick_request))
        assert (reply["ok"], reply["status"]) == (False, "missed"), reply
        # Why, in the reply the vision program reads, and in the audit's command record.
        assert "without touching anything (OBJ 3)" in str(reply["error"]), reply
        assert "the arm retreated" in str(reply["error"]), reply
        close = [c for c in _outcome_commands(tmp_path) if c["command"] == "close"]
        assert close == [{"command": "close", "grasp": "missed", "why": close[0]["why"]}]
        assert "without touching anything" in close[0]["why"]
        status = runner.handle('{"id": "3", "op": "status"}')
        assert (status["ready"], status["halted"]) == (True, False), status


def test_a_pick_with_the_fingers_left_closed_by_a_drop_is_refused_until_they_are_opened(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """Found by the chaos soak: after a dropped part and a resume, the next pick came down on
    the part with the fingers still closed (the simulator then said ``missed``; a real cell
    crashes the fingers into the part). Guards the ``ready_to_grasp`` refusal in
    ``Cell._prepare_pick`` (cell/session.py), before the plan record and any motion."""
    ctl = sim_controller(
        tcp_offset=TCP_OFFSET,
        instant=True,
        part_width_mm=PART_MM,
        inject=("gripper-drop@move:3:0.5",),
    )
    T_cam_obj_mm = load_detection(DEMO / "detection.yaml").T_cam_obj[:3, 3] * 1000.0
    with Cell(robotiq_config(tmp_path, ctl.host)) as cell:
        runner = Runner(cell)
        captured = runner.handle('{"id": "c", "op": "capture"}')

        def pick_once(rid: str) -> Any:
            request = {
                "id": rid,
                "op": "pick",
                "capture_id": captured["capture_id"],
                "candidates": [{"position_mm": T_cam_obj_mm.tolist()}],
            }
            return runner.handle(json.dumps(request))

        assert pick_once("1")["status"] == "dropped"
        ctl.set_part(PART_MM)  # the operator puts the part back and resumes
        assert runner.handle('{"id": "r", "op": "resume"}')["status"] == "ready"
        motions = len(ctl.motions)
        refused = pick_once("2")
        assert refused["status"] == "refused", refused
        assert "fingers are 0.0 mm apart" in str(refused["error"])
        assert len(ctl.motions) == motions  # no approach
        assert cell.halted is None
        _robotiq(ctl.host, "SET POS 0 GTO 1")  # opened on the pendant
        picked = pick_once("3")
        assert picked["status"] == "picked", picked


def _robotiq(host: str, request: str) -> str:
    """One request on the simulated Robotiq's socket, as the pendant's URCap sends it."""
    with socket.create_connection((host, 63352), timeout=2.0) as sock:
        sock.sendall(request.encode() + b"\n")
        return sock.makefile("r").readline().strip()


def _outcome_commands(tmp_path: Path) -> list[dict[str, Any]]:
    """The gripper's commands in the last outcome record of the audit file."""
    outcome = [r for r in audit_records(tmp_path) if r["event"] == "outcome"][-1]
    commands: list[dict[str, Any]] = outcome["gripper"]["commands"]
    return commands
