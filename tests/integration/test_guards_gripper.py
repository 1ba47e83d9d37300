"""Gripper guards a one-line change could remove unnoticed (issue 21), through the Cell and the real
ur_rtde against the simulated controller and its simulated Robotiq: a grasp counts as held only
when the gripper says so within the part's width, a feedback input confirms the release too,
and a grasp nothing can confirm still carries the part's payload and is never called confirmed.
"""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from handeye_pick import Cell, load_detection
from handeye_pick.errors import GripperFault
from mocks.ur_controller import SimulatedController
from tests.integration.test_gripper_pick import (
    DIGITAL,
    FEEDBACK,
    OBJECT,
    PART_MM,
    PLACE,
    TOOL_PAYLOAD,
    robotiq_config,
)
from tests.integration.test_pick_cli import (
    DEMO,
    TCP_OFFSET,
    audit_records,
    motion_commands,
    write_config,
)

SimFactory = Callable[..., SimulatedController]
DETECTION = DEMO / "detection.yaml"
TOOL_OUT_0, TOOL_IN_0, STANDARD_OUT_7 = 16, 16, 7  # bits of the controller's IO words


def _gripper_commands(tmp_path: Path) -> list[dict[str, Any]]:
    """What the last outcome in the audit says the gripper did and sensed."""
    commands: list[dict[str, Any]] = audit_records(tmp_path)[-1]["gripper"]["commands"]
    return commands


def _payloads(ctl: SimulatedController) -> list[float]:
    """The masses (kg) of every setPayload the controller ran, in order."""
    return [c["mass"] for c in ctl.commands if c["kind"] == "setPayload"]


# --- Robotiq: contact, and at the part's width ----------------------------------------------------


@pytest.mark.parametrize("part_mm", [20.0, 60.0], ids=["narrower", "wider"])
def test_a_robotiq_contact_far_from_the_expected_width_is_missed(
    sim_controller: SimFactory, tmp_path: Path, part_mm: float
) -> None:
    """Guards ``if obj == OBJ_CONTACT_CLOSING and low <= width_mm <= high`` in Robotiq2F.close
    (gripper/robotiq.py): fingers stopped on something 20 mm or 60 mm wide, with 38..42 mm
    expected (a wrong part, one caught at an edge), are a missed grasp: the gripper opens, the
    arm retreats, the payload stays the empty tool's (never the part's), nothing is placed."""
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True, part_width_mm=part_mm)
    config = robotiq_config(tmp_path, ctl.host, place=PLACE)
    with Cell(config) as cell:
        result = cell.pick(load_detection(DETECTION))
    assert result.status == "missed"
    commands = _gripper_commands(tmp_path)
    assert [c["command"] for c in commands] == ["close", "open", "set_payload"]
    assert commands[0]["grasp"] == "missed"
    assert commands[2]["payload"] == "empty tool"
    assert _payloads(ctl) == [1.0]
    assert len(motion_commands(ctl)) == 3  # approach, grasp, retreat: no place


# --- a feedback input confirms the release --------------------------------------------------------


def _switch_on_standard_output(host: str, index: int) -> None:
    """Another RTDE client (as a PLC or the pendant would) switches a standard output on; the
    controller keeps it on after that client left."""
    script = "import rtde_io, sys; io = rtde_io.RTDEIOInterface(sys.argv[1]); "
    script += f"sys.exit(0 if io.setStandardDigitalOut({index}, True) else 1)"
    subprocess.run([sys.executable, "-c", script, host], check=True, timeout=30)


def test_a_part_still_sensed_after_the_release_ends_the_place_as_a_fault(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """Guards the release check of DigitalOutputGripper.open (gripper/digital.py, ``if not
    self._wait_for_input(held=False): raise GripperFault``): the suction is off, yet its vacuum
    switch still reads the part held (it sticks to the cup), so the place is a fault: no
    empty-tool payload, no retreat with a part that may still hang there. The simulated switch
    is wired to a standard output another client left on, so switching the cup off cannot
    clear it."""
    ctl = sim_controller(
        tcp_offset=TCP_OFFSET,
        instant=True,
        part_width_mm=PART_MM,
        feedback_input=(STANDARD_OUT_7, TOOL_IN_0),
    )
    _switch_on_standard_output(ctl.host, STANDARD_OUT_7)
    deadline = time.monotonic() + 5.0
    while not ctl.snapshot().standard_digital_out >> STANDARD_OUT_7 & 1:
        assert time.monotonic() < deadline, "the controller never showed the output on"
        time.sleep(0.01)
    config = write_config(
        tmp_path, ctl.host, robot_extra=FEEDBACK + TOOL_PAYLOAD, object=OBJECT, place=PLACE
    )
    with Cell(config) as cell:
        with pytest.raises(GripperFault, match="still reads the part held"):
            cell.pick(load_detection(DETECTION))
        assert cell.halted is not None
    assert not ctl.snapshot().tool_digital_out & 1  # the cup was switched off
    outcome = audit_records(tmp_path)[-1]
    assert (outcome["status"], outcome["step"]) == ("fault", "gripper open")
    assert _payloads(ctl) == [1.5]  # the part's; the empty tool's never followed
    # approach, grasp, retreat, place approach, place: no place retreat
    assert len(motion_commands(ctl)) == 5


def test_a_release_the_feedback_input_saw_is_reported_confirmed(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """Guards DigitalOutputGripper.open's ``return True`` after the input cleared (and ``if
    feedback is None: return False`` before it, gripper/digital.py): the switch read the part
    held after the grasp and let go after the release, and the audit says both."""
    ctl = sim_controller(
        tcp_offset=TCP_OFFSET,
        instant=True,
        part_width_mm=PART_MM,
        feedback_input=(TOOL_OUT_0, TOOL_IN_0),
    )
    config = write_config(
        tmp_path, ctl.host, robot_extra=FEEDBACK + TOOL_PAYLOAD, object=OBJECT, place=PLACE
    )
    with Cell(config) as cell:
        assert cell.pick(load_detection(DETECTION)).status == "placed"
    commands = _gripper_commands(tmp_path)
    assert [c["command"] for c in commands] == ["close", "set_payload", "open", "set_payload"]
    assert (commands[0]["grasp"], commands[2]["release"]) == ("confirmed", "confirmed")
    assert _payloads(ctl) == [1.5, 1.0]


# --- a grasp nothing confirms ---------------------------------------------------------------------


def test_an_unconfirmed_grasp_carries_the_part_payload_and_is_never_confirmed(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """Guards the unconfirmed path of the sequence and the gripper: DigitalOutputGripper.close
    ``return GraspState.UNCONFIRMED`` without a feedback input (gripper/digital.py), _Run.grip's
    ``if self.grasp is GraspState.MISSED`` / ``else: _set_payload(... part ...)``
    (cell/sequence.py) and Cell._finish_pick's ``elif done.grasp is GraspState.MISSED``
    (cell/session.py). A gripper that senses nothing closed on the part: it is carried as
    held (picked, the part's payload on the controller before the retreat), reported
    ``unconfirmed``, and the place that follows releases it and sets the empty tool's payload."""
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True, part_width_mm=PART_MM)
    config = write_config(
        tmp_path, ctl.host, robot_extra=DIGITAL + TOOL_PAYLOAD, object=OBJECT, place=PLACE
    )
    with Cell(config) as cell:
        picked = cell.pick(load_detection(DETECTION), place=False)
        assert picked.status == "picked"
        assert [c["kind"] for c in ctl.commands] == ["moveL", "moveL", "setPayload", "moveL"]
        assert _payloads(ctl) == [1.5]  # tool 1 kg with the 0.5 kg part, before the retreat
        commands = _gripper_commands(tmp_path)
        assert [c["command"] for c in commands] == ["close", "set_payload"]
        assert commands[0]["grasp"] == "unconfirmed"
        cell.place()
        assert cell.halted is None
    commands = _gripper_commands(tmp_path)
    assert [c["command"] for c in commands] == ["open", "set_payload"]
    assert commands[0]["release"] == "unconfirmed"
    assert _payloads(ctl) == [1.5, 1.0]
    assert "confirmed" not in [
        c.get("grasp")
        for r in audit_records(tmp_path)
        for c in r.get("gripper", {}).get("commands", [])
    ]
