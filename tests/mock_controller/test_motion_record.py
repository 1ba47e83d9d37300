"""The motion record (controller time spent moving per motion command), the command record's
payload entries, and the refused-move fault, through the real ur_rtde client."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
import rtde_control
import rtde_receive

from mocks.ur_controller import SimulatedController
from tests.conftest import start_sim_controller
from tests.mock_controller.helpers import HOME_Q, wait_for


@pytest.fixture(scope="module")
def ctl() -> Iterator[SimulatedController]:
    controller = start_sim_controller(initial_q=HOME_Q, speed_factor=4.0)
    yield controller
    controller.stop()


def lowered(pose: list[float], dz_m: float) -> list[float]:
    moved = list(pose)
    moved[2] -= dz_m
    return moved


def test_each_motion_records_its_controller_time_moving(
    ctl: SimulatedController, control: rtde_control.RTDEControlInterface,
    receive: rtde_receive.RTDEReceiveInterface,
) -> None:
    before = len(ctl.motions)
    start = receive.getActualTCPPose()
    assert control.moveL(lowered(start, 0.1), 0.25, 1.2)
    assert control.moveL(start, 0.25, 1.2)
    first, second = ctl.motions[before:]
    # 0.1 m at 0.25 m/s, 1.2 m/s^2 takes 0.6083 s; at speed factor 4 that is 0.1521 s, which
    # ends in the 77th 2 ms control cycle after the one that started it.
    for record in (first, second):
        assert record["kind"] == "moveL"
        assert record["end"] == "reached"
        assert record["moving_s"] == pytest.approx(0.154, abs=1e-9)
        assert record["moving_s"] == pytest.approx(record["end_t"] - record["start_t"])
    assert first["motion"] + 1 == second["motion"]
    assert first["end_t"] <= second["start_t"]


def test_a_stopped_motion_counts_its_braking(
    ctl: SimulatedController, control: rtde_control.RTDEControlInterface,
    receive: rtde_receive.RTDEReceiveInterface,
) -> None:
    before = len(ctl.motions)
    start = receive.getActualTCPPose()
    assert control.moveL(lowered(start, 0.3), 0.25, 1.2, True)
    wait_for(lambda: receive.getActualTCPPose()[2] < start[2] - 0.05)
    control.stopL(0.5)  # synchronous: returns once the arm is still
    (record,) = ctl.motions[before:]
    assert record["end"] == "stopped"
    stop = ctl.commands[-1]
    assert stop["kind"] == "stopL"
    # Braking from 0.25 m/s at 0.5 m/s^2 takes 0.5 s of motion time, 0.125 s at speed factor 4,
    # so the arm is at rest in the 63rd 2 ms cycle after the one that ran stopL.
    assert record["end_t"] - stop["t"] == pytest.approx(0.126, abs=1e-9)


def test_payload_calls_are_recorded_and_applied(
    ctl: SimulatedController, control: rtde_control.RTDEControlInterface,
    receive: rtde_receive.RTDEReceiveInterface,
) -> None:
    assert control.setPayload(2.0, [0.0, 0.0, 0.08])
    assert control.setPayload(0.5, [0.0, 0.0, 0.0])  # a zero CoG keeps the current one
    entries = [{k: v for k, v in c.items() if k != "t"} for c in ctl.commands[-2:]]
    assert entries == [{"kind": "setPayload", "mass": 2.0, "cog": [0.0, 0.0, 0.08]},
                       {"kind": "setPayload", "mass": 0.5, "cog": [0.0, 0.0, 0.0]}]
    snap = ctl.snapshot()
    assert (snap.payload_kg, snap.payload_cog) == (0.5, (0.0, 0.0, 0.08))
    wait_for(lambda: receive.getPayload() == 0.5)
    assert list(receive.getPayloadCog()) == [0.0, 0.0, 0.08]


@pytest.mark.parametrize("when", ["run time", "start"])
def test_a_refused_move_returns_false_while_every_status_reads_normal(when: str) -> None:
    ctl = start_sim_controller(instant=True, inject=("refuse-move",) if when == "start" else ())
    try:
        control = rtde_control.RTDEControlInterface(ctl.host)
        receive = rtde_receive.RTDEReceiveInterface(ctl.host)
        try:
            if when == "run time":
                ctl.inject("refuse-move")
            start = receive.getActualTCPPose()
            assert not control.moveL(lowered(start, 0.05), 0.25, 1.2, True)
            # Within a cycle or two (each interface has its own stream) everything reads normal.
            wait_for(lambda: receive.getRobotStatus() == 3 and control.isProgramRunning())
            assert receive.getSafetyMode() == 1
            assert receive.getRobotMode() == 7
            assert receive.getRuntimeState() == 2
            assert not receive.isProtectiveStopped()
            assert not ctl.snapshot().moving
            assert receive.getActualTCPPose() == start
            refused = ctl.commands[-1]
            assert (refused["kind"], refused["refused"]) == ("moveL", True)
            assert control.moveL(lowered(start, 0.05), 0.25, 1.2)  # one move only
            assert ctl.snapshot().tcp_pose[2] == pytest.approx(start[2] - 0.05, abs=1e-9)
        finally:
            receive.disconnect()
            control.disconnect()
    finally:
        ctl.stop()
