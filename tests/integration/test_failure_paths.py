"""Failure endings docs/field-experience.md and the README promise, through the real ur_rtde against
the simulated controller: whatever ends a move, the arm is stopped where it still listens, and
nothing is ever unlocked or re-sent by itself.
"""

from __future__ import annotations

import contextlib
import socket
import subprocess
import threading
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from handeye_pick.errors import RobotConnectionError, RobotFault
from handeye_pick.geometry import Transform
from handeye_pick.robot.port import OutputBank, RuntimeState, SafetyMode
from handeye_pick.robot.ur.arm import URRtdeArm
from mocks.ur_controller import SimulatedController
from tests.conftest import TEST_WATCHDOG_S
from tests.integration.test_pick_cli import (
    CLI,
    DEMO,
    ROOT,
    TCP_OFFSET,
    audit_records,
    run_json,
    write_config,
)

SimFactory = Callable[..., SimulatedController]


def _lowered(T_base_tcp: Transform, metres: float) -> Transform:
    T = T_base_tcp.copy()
    T[2, 3] -= metres
    return T


def test_an_unexpected_error_during_a_move_stops_the_arm(sim_controller: SimFactory) -> None:
    # Not a RobotError nor Ctrl-C: a progress callback that fails (a closed terminal, a bug).
    # The error must propagate, and the arm must not finish the move on its own.
    ctl = sim_controller(speed_factor=1.0)

    def fail_halfway(fraction: float) -> None:
        if fraction > 0.2:
            raise RuntimeError("progress output is gone")

    with URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S) as arm:
        with pytest.raises(RuntimeError, match="progress output is gone"):
            arm.move_linear(_lowered(arm.tcp_pose(), 0.10), 0.25, 1.2, 5.0, fail_halfway)
        assert arm.status().runtime_state == RuntimeState.PLAYING  # session still usable
    assert [c["kind"] for c in ctl.commands] == ["moveL", "stopL"]
    assert not ctl.snapshot().moving


def test_a_controller_silent_at_connect_is_a_bounded_connection_error(loopback_host: str) -> None:
    # Port 30004 accepts but never answers (a hung controller, a wrong device): ur_rtde would
    # wait for the RTDE handshake forever; the connection must end with a typed error. The
    # dashboard, asked first, answers as a 5.15 controller in Remote Control would.
    with (
        socket.create_server((loopback_host, 30004)) as server,
        socket.create_server((loopback_host, 29999)) as dashboard,
    ):
        server.settimeout(5.0)
        threading.Thread(target=_serve_dashboard, args=(dashboard,), daemon=True).start()
        with pytest.raises(RobotConnectionError, match="no answer to connect"):
            URRtdeArm(loopback_host, watchdog_s=TEST_WATCHDOG_S, connect_timeout_s=2.0)


def _serve_dashboard(server: socket.socket) -> None:
    """Answer one dashboard connection: a banner, then PolyScope 5.15 in Remote Control."""
    answers = {
        "PolyscopeVersion": "URSoftware 5.15.0.1234 (Jul 12 2023)",
        "is in remote control": "true",
    }
    with contextlib.suppress(OSError):  # the test closed the port: nothing more to serve
        conn, _ = server.accept()
        with conn, conn.makefile("r") as lines:
            conn.sendall(b"Connected: Universal Robots Dashboard Server\n")
            for line in lines:
                answer = answers.get(line.strip(), f"Could not understand: '{line.strip()}'")
                conn.sendall((answer + "\n").encode())


def test_a_protective_stop_is_left_for_the_operator(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    # docs/field-experience.md, "Protective stop recovery": no automatic unlock, no retry. After the
    # pick ends with the fault, the controller is still protective-stopped, and nothing but stops
    # followed the faulted move.
    ctl = sim_controller(
        tcp_offset=TCP_OFFSET, speed_factor=4.0, inject=("protective-stop@move:2:0.5",)
    )
    status, report = run_json(
        write_config(tmp_path, ctl.host), "--detection", str(DEMO / "detection.yaml")
    )
    assert status == 4, report
    assert "protective stop" in report["error"]
    snapshot = ctl.snapshot()
    assert snapshot.safety_mode == SafetyMode.PROTECTIVE_STOP
    assert not snapshot.moving
    kinds = [c["kind"] for c in ctl.commands]
    assert kinds[:2] == ["moveL", "moveL"]
    assert set(kinds[2:]) <= {"stopL"}
    assert audit_records(tmp_path)[-1]["error"]["safety_mode"] == SafetyMode.PROTECTIVE_STOP


def test_a_pick_that_cannot_connect_is_audited(tmp_path: Path, loopback_host: str) -> None:
    # Nothing listens: exit 4, and the attempt is on disk although no session ever existed.
    status, report = run_json(
        write_config(tmp_path, loopback_host), "--detection", str(DEMO / "detection.yaml")
    )
    assert status == 4, report
    assert report["error_type"] == "RobotConnectionError"
    (outcome,) = audit_records(tmp_path)
    assert (outcome["event"], outcome["status"], outcome["step"]) == ("outcome", "fault", "connect")
    assert outcome["error"]["type"] == "RobotConnectionError"


def test_a_cell_refusing_the_control_program_is_audited(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    # Local control: the controller refuses ur_rtde's program at connect; exit 3, on disk.
    ctl = sim_controller(tcp_offset=TCP_OFFSET, remote_control=False, instant=True)
    status, report = run_json(
        write_config(tmp_path, ctl.host), "--detection", str(DEMO / "detection.yaml")
    )
    assert status == 3, report
    assert "Remote Control" in report["error"]
    (outcome,) = audit_records(tmp_path)
    assert (outcome["status"], outcome["step"]) == ("refused", "connect")
    assert ctl.commands == []


def test_the_flange_is_never_read_from_a_stalled_stream(sim_controller: SimFactory) -> None:
    # docs/field-experience.md, "Stale first sample": a pose must come from a sample newer
    # than the request. While the RTDE
    # stream pauses, ur_rtde still answers with its last cached pose; that must not pass.
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    with URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S) as arm:
        arm.flange_pose()
        ctl.inject("stall:1.5")
        with pytest.raises(RobotConnectionError, match="no RTDE sample newer"):
            arm.flange_pose()


def test_a_move_that_ends_away_from_its_target_is_a_fault(sim_controller: SimFactory) -> None:
    # The simulated controller always ends a move on target or with a state change, so the
    # end-of-move check is driven directly with a real sample against a target 2 mm away.
    ctl = sim_controller(instant=True)
    with URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S) as arm:
        sample = arm._sample("fresh_sample")
        arm._check_reached(sample, _lowered(arm.tcp_pose(), 0.0005))  # within 1 mm: fine
        with pytest.raises(RobotFault, match=r"ended 2\.0 mm") as caught:
            arm._check_reached(sample, _lowered(arm.tcp_pose(), 0.002))
    assert caught.value.safety_mode == SafetyMode.NORMAL
    assert caught.value.runtime_state == RuntimeState.PLAYING


@pytest.mark.parametrize(
    ("bank", "field"),
    [(OutputBank.TOOL, "tool_digital_out"), (OutputBank.STANDARD, "standard_digital_out")],
)
def test_a_gripper_output_is_confirmed_by_the_controller(
    sim_controller: SimFactory, bank: OutputBank, field: str
) -> None:
    # ur_rtde's IO setters return True once the package is written (docs/ur-rtde.md, "IO
    # interface"): True says nothing. The output counts as set when the controller's data shows it,
    # and an output that cannot be confirmed (the RTDE stream stalls) is an error, not a silent
    # True.
    ctl = sim_controller(instant=True)
    with URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S, with_io=True) as arm:
        arm.set_digital_output(bank, 1, True)
        assert getattr(ctl.snapshot(), field) == 0b10  # applied before the call returned
        ctl.inject("stall:1.5")
        with pytest.raises(RobotConnectionError, match="no RTDE sample newer"):
            arm.set_digital_output(bank, 1, False)


def test_a_pick_killed_mid_move_is_stopped_by_the_controller_watchdog(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    # SIGKILL leaves no chance to send stopL: the ur_rtde process sees its parent's pipe close,
    # stops kicking ur_rtde's watchdog, and the control script stops the program
    # (docs/field-experience.md, "A supervisor's SIGTERM, a crash, a power cut").
    # A 0.25 s window (the production default is 0.2 s, which trips spuriously when this shared
    # machine deschedules the simulator).
    window_s = 0.25
    ctl = sim_controller(tcp_offset=TCP_OFFSET, speed_factor=0.2)
    pick = subprocess.Popen(
        [
            *CLI,
            "pick",
            "--config",
            str(write_config(tmp_path, ctl.host, watchdog_s=str(window_s))),
            "--detection",
            str(DEMO / "detection.yaml"),
        ],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 30.0
        while not ctl.snapshot().moving and time.monotonic() < deadline:
            time.sleep(0.01)
        assert ctl.snapshot().moving, "the approach never started"
        pick.kill()
        at_kill = ctl.snapshot()
        pick.wait(timeout=10)
        deadline = time.monotonic() + 10.0
        while ctl.snapshot().moving and time.monotonic() < deadline:
            time.sleep(0.05)
    finally:
        if pick.poll() is None:
            pick.kill()
    after = ctl.snapshot()
    assert not after.moving
    assert after.runtime_state == RuntimeState.STOPPED  # the watchdog stopped the program
    assert "stopL" not in [c["kind"] for c in ctl.commands]  # nobody sent a stop
    # Within 0.5 s of the kill, told in controller time so the test does not time this machine:
    # the simulator records the stop at the control cycle it was due, window_s after the last
    # kick, even when it runs that cycle late.
    halted = ctl.motions[-1]
    assert halted["watchdog_min_frequency_hz"] == pytest.approx(1.0 / window_s)
    assert halted["end_t"] - halted["watchdog_last_update_t"] <= window_s + 0.005, halted
    assert halted["end_t"] - at_kill.time_s < 0.5, (halted, at_kill.time_s)
    approach_target = next(c for c in ctl.commands if c["kind"] == "moveL")["target"]
    assert np.linalg.norm(np.subtract(after.tcp_pose[:3], approach_target[:3])) > 0.005
