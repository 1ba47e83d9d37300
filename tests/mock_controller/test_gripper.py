"""The simulated Robotiq 2F on port 63352 (the URCap's ASCII protocol), the scripted part, the
gripper faults, and a digital feedback input that follows the part."""

from __future__ import annotations

import socket
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import pytest
import rtde_control
import rtde_io
import rtde_receive

from mocks.ur_controller import SimulatedController
from tests.mock_controller.helpers import wait_for

Factory = Callable[..., SimulatedController]
ROBOTIQ_PORT = 63352
STROKE_MM = 85.0


class Gripper:
    """A line-by-line client of the Robotiq URCap socket."""

    def __init__(self, sock: socket.socket):
        self.sock = sock
        self.reader = sock.makefile("r", encoding="ascii", newline="\n")

    def ask(self, request: str) -> str:
        self.sock.sendall((request + "\n").encode())
        return self.reader.readline().strip()

    def get(self, name: str) -> int:
        reply = self.ask(f"GET {name}")
        label, value = reply.split()
        assert label == name
        return int(value)


@contextmanager
def gripper(host: str) -> Iterator[Gripper]:
    with socket.create_connection((host, ROBOTIQ_PORT), timeout=5.0) as sock:
        yield Gripper(sock)


def activated(g: Gripper) -> Gripper:
    assert g.ask("SET ACT 1") == "ack"
    wait_for(lambda: g.get("STA") == 3, timeout_s=10.0)
    return g


def test_activation_takes_its_time_and_leaves_the_fingers_open(sim_controller: Factory) -> None:
    ctl = sim_controller(instant=True)
    with gripper(ctl.host) as g:
        assert (g.get("ACT"), g.get("STA")) == (0, 0)
        assert g.ask("SET ACT 1") == "ack"
        assert g.get("STA") in (1, 3)  # activating (instant: done within two cycles)
        activated(g)
        assert (g.get("POS"), g.get("FLT")) == (0, 0)


def test_go_to_before_activation_is_a_fault(sim_controller: Factory) -> None:
    ctl = sim_controller(instant=True)
    with gripper(ctl.host) as g:
        assert g.ask("SET POS 255 GTO 1") == "ack"
        assert g.get("FLT") == 0x07  # the activation bit must be set prior to action
        assert g.get("POS") == 0


def test_fingers_move_at_the_commanded_speed(sim_controller: Factory) -> None:
    ctl = sim_controller(speed_factor=4.0)
    with gripper(ctl.host) as g:
        activated(g)
        assert g.ask("SET SPE 0 FOR 100 POS 255") == "ack"  # SPE 0: 20 mm/s
        assert g.ask("SET GTO 1") == "ack"
        wait_for(lambda: ctl.snapshot().gripper_position > 20)
        first = ctl.snapshot()
        wait_for(lambda: ctl.snapshot().gripper_position > first.gripper_position + 40)
        second = ctl.snapshot()
    mm = (second.gripper_position - first.gripper_position) * STROKE_MM / 255
    speed_mmps = mm / (second.time_s - first.time_s) / 4.0  # controller time, speed factor 4
    assert speed_mmps == pytest.approx(20.0, rel=0.05)  # position reads are whole counts


def test_closing_on_a_part_stops_at_its_width(sim_controller: Factory) -> None:
    ctl = sim_controller(instant=True, part_width_mm=40.0)
    with gripper(ctl.host) as g:
        activated(g)
        assert g.ask("SET POS 255 SPE 255 FOR 150 GTO 1") == "ack"
        wait_for(lambda: g.get("OBJ") != 0)
        assert g.get("OBJ") == 2  # stopped by contact while closing
        assert g.get("PRE") == 255
        assert g.get("POS") == round(255 * (1 - 40.0 / STROKE_MM))
        assert g.ask("SET POS 0") == "ack"  # open again: a new request while GTO is set
        wait_for(lambda: g.get("OBJ") == 3)
        assert g.get("POS") == 0


def test_closing_on_nothing_reaches_the_requested_position(sim_controller: Factory) -> None:
    ctl = sim_controller(instant=True)
    with gripper(ctl.host) as g:
        activated(g)
        assert g.ask("SET POS 255 GTO 1") == "ack"
        wait_for(lambda: g.get("OBJ") != 0)
        assert (g.get("OBJ"), g.get("POS")) == (3, 255)


def test_a_part_slipping_out_during_a_move(sim_controller: Factory) -> None:
    ctl = sim_controller(speed_factor=4.0, part_width_mm=30.0, inject=("gripper-drop@move:1:0.5",))
    with gripper(ctl.host) as g:
        activated(g)
        assert g.ask("SET POS 255 SPE 255 GTO 1") == "ack"
        wait_for(lambda: g.get("OBJ") == 2)
        control = rtde_control.RTDEControlInterface(ctl.host)
        try:
            target = list(ctl.snapshot().tcp_pose)
            target[2] += 0.05
            assert control.moveL(target, 0.25, 1.2)  # the retreat
        finally:
            control.disconnect()
        wait_for(lambda: g.get("OBJ") == 3)  # lost: the fingers closed to the request
        assert g.get("POS") == 255
        assert not ctl.snapshot().part_present


@pytest.mark.parametrize("code", [0x0E, 0x0A])
def test_an_injected_fault_code_is_reported_and_stops_the_fingers(
    sim_controller: Factory, code: int,
) -> None:
    ctl = sim_controller(instant=True)
    with gripper(ctl.host) as g:
        activated(g)
        ctl.inject(f"gripper-fault:{code}")
        assert g.get("FLT") == code
        assert g.ask("SET POS 255 GTO 1") == "ack"
        assert g.get("POS") == 0  # no motion while faulted
        assert g.ask("SET ACT 0") == "ack"  # a reset clears it
        assert g.get("FLT") == 0


def test_a_silent_gripper_never_answers(sim_controller: Factory) -> None:
    ctl = sim_controller(instant=True, inject=("gripper-silent",))
    with gripper(ctl.host) as g:
        g.sock.settimeout(0.5)
        with pytest.raises(TimeoutError):
            g.ask("GET STA")


def test_unknown_requests_are_answered_with_a_question_mark(sim_controller: Factory) -> None:
    ctl = sim_controller(instant=True)
    with gripper(ctl.host) as g:
        assert [g.ask(r) for r in ("GET XYZ", "SET POS 300", "SET STA 1", "HELLO")] == ["?"] * 4


def test_a_feedback_input_follows_the_output_and_the_part(sim_controller: Factory) -> None:
    ctl = sim_controller(instant=True, part_width_mm=20.0, feedback_input=(16, 3))  # tool DO0
    io = rtde_io.RTDEIOInterface(ctl.host)
    receive = rtde_receive.RTDEReceiveInterface(ctl.host)
    try:
        assert not receive.getDigitalInState(3)
        assert io.setToolDigitalOut(0, True)  # close the gripper on the part
        wait_for(lambda: receive.getDigitalInState(3))
        ctl.inject("gripper-drop")
        wait_for(lambda: not receive.getDigitalInState(3))
        ctl.set_part(20.0)  # a new part
        wait_for(lambda: receive.getDigitalInState(3))
        assert io.setToolDigitalOut(0, False)
        wait_for(lambda: not receive.getDigitalInState(3))
    finally:
        receive.disconnect()
        io.disconnect()
