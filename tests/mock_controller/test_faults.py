"""Every injectable fault, observed through ur_rtde the way a real controller shows it.

Clients that see their connection drop or their stream stall run in a subprocess: ur_rtde 1.6.5
may loop reconnecting and crash the process that holds them.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import dashboard_client
import pytest
import rtde_control
import rtde_receive

from mocks.ur_controller import SimulatedController
from tests.mock_controller.helpers import wait_for

Factory = Callable[..., SimulatedController]


def dashboard(host: str) -> dashboard_client.DashboardClient:
    d = dashboard_client.DashboardClient(host)
    d.connect()
    return d


@contextmanager
def clients(host: str) -> Iterator[
    tuple[rtde_control.RTDEControlInterface, rtde_receive.RTDEReceiveInterface,
          dashboard_client.DashboardClient]
]:
    """Control, receive and dashboard clients on `host`, disconnected on exit."""
    c = rtde_control.RTDEControlInterface(host)
    r = rtde_receive.RTDEReceiveInterface(host)
    d = dashboard(host)
    try:
        yield c, r, d
    finally:
        d.disconnect()
        r.disconnect()
        c.disconnect()


def shifted(pose: list[float], dz: float) -> list[float]:
    moved = list(pose)
    moved[2] += dz
    return moved


def test_protective_stop_during_a_move(sim_controller: Factory) -> None:
    ctl = sim_controller(inject=("protective-stop@move:1:0.5",))
    with clients(ctl.host) as (c, r, d):
        start = r.getActualTCPPose()
        target = shifted(start, -0.1)
        assert not c.moveL(target, 0.25, 1.2)
        snap = ctl.snapshot()
        assert snap.safety_mode == 3
        assert not snap.moving
        # Halted about halfway (the trapezoid is symmetric: half the time, half the way).
        assert start[2] - 0.07 < snap.tcp_pose[2] < start[2] - 0.03
        wait_for(r.isProtectiveStopped)
        assert r.getSafetyMode() == 3
        assert r.getSafetyStatusBits() & (1 << 2)
        assert not c.moveL(target, 0.25, 1.2)  # refused until unlocked
        assert d.safetystatus() == "Safetystatus: PROTECTIVE_STOP"
        d.unlockProtectiveStop()
        wait_for(lambda: not r.isProtectiveStopped())
        assert c.moveL(target, 0.25, 1.2)
        assert ctl.snapshot().tcp_pose[2] == pytest.approx(target[2], abs=1e-9)


def test_trigger_protective_stop(sim_controller: Factory) -> None:
    ctl = sim_controller(instant=True)
    c = rtde_control.RTDEControlInterface(ctl.host)
    try:
        c.triggerProtectiveStop()
        assert ctl.snapshot().safety_mode == 3
        assert ctl.commands[-1]["kind"] == "triggerProtectiveStop"
        with pytest.raises(RuntimeError):
            c.getTCPOffset()  # fails while protective stopped
    finally:
        c.disconnect()


def test_emergency_stop_and_recovery(sim_controller: Factory) -> None:
    ctl = sim_controller(instant=True)
    with clients(ctl.host) as (c, r, d):
        ctl.inject("emergency-stop")
        wait_for(r.isEmergencyStopped)
        assert r.getSafetyMode() == 7
        assert r.getRobotMode() == 3  # powered off
        assert r.getRuntimeState() == 1
        assert not c.moveJ(list(r.getActualQ()))
        d.restartSafety()
        d.powerOn()
        d.brakeRelease()
        wait_for(lambda: r.getRobotMode() == 7 and r.getSafetyMode() == 1)
        assert c.reuploadScript()
        wait_for(c.isProgramRunning)
        assert c.moveJ(list(r.getActualQ()))


def test_safeguard_stop_pauses_the_program(sim_controller: Factory) -> None:
    ctl = sim_controller(instant=True)
    with clients(ctl.host) as (c, r, d):
        ctl.inject("safeguard-stop@now")
        wait_for(lambda: r.getSafetyMode() == 5)
        assert r.getRuntimeState() == 4  # PAUSED
        assert r.getSafetyStatusBits() & (1 << 4)
        assert not c.moveL(shifted(r.getActualTCPPose(), -0.01))
        d.closeSafetyPopup()
        d.play()
        wait_for(lambda: r.getRuntimeState() == 2 and r.getSafetyMode() == 1)
        # The control interface reads its own RTDE stream, which may show the resume a cycle
        # after the receive interface's.
        wait_for(c.isProgramRunning)
        assert c.moveL(shifted(r.getActualTCPPose(), -0.01))


def test_program_stopped_from_the_pendant_mid_move(sim_controller: Factory) -> None:
    ctl = sim_controller(inject=("stop-program@move:1:0.3",))
    c = rtde_control.RTDEControlInterface(ctl.host)
    try:
        start = ctl.snapshot().tcp_pose
        assert not c.moveL(shifted(list(start), -0.1), 0.25, 1.2)
        snap = ctl.snapshot()
        assert snap.runtime_state == 1
        assert not snap.program_running
        assert not snap.moving
        assert start[2] - 0.1 < snap.tcp_pose[2] < start[2]
        assert not c.isProgramRunning()
    finally:
        c.disconnect()


def test_remote_control_off(sim_controller: Factory) -> None:
    ctl = sim_controller(instant=True)
    ctl.inject("remote-control-off")
    d = dashboard(ctl.host)
    try:
        assert not d.isInRemoteControl()
        with pytest.raises(RuntimeError, match="remote control"):
            rtde_control.RTDEControlInterface(ctl.host)
    finally:
        d.disconnect()


def test_refused_start(sim_controller: Factory) -> None:
    ctl = sim_controller(instant=True, inject=("refuse-start",))
    refused = rtde_receive.RTDEReceiveInterface(ctl.host)
    assert not refused.isConnected()
    refused.disconnect()
    accepted = rtde_receive.RTDEReceiveInterface(ctl.host)  # the fault refuses one start
    assert accepted.isConnected()
    accepted.disconnect()


def test_slow_controller_acknowledges_late(sim_controller: Factory) -> None:
    ctl = sim_controller(instant=True)
    c = rtde_control.RTDEControlInterface(ctl.host)
    try:
        ctl.inject("slow:1.5")
        results: list[bool] = []
        call = threading.Thread(target=lambda: results.append(c.setTcp([0, 0, 0.1, 0, 0, 0])))
        call.start()
        call.join(0.5)
        assert call.is_alive()  # not answered yet
        call.join(10.0)
        assert results == [True]
        assert ctl.snapshot().tcp_offset[2] == 0.1
    finally:
        c.disconnect()


_WATCH_RECEIVE = """
    import sys, time
    import rtde_receive
    r = rtde_receive.RTDEReceiveInterface(sys.argv[1])
    print("connected", r.isConnected(), flush=True)
    sys.stdin.readline()
    deadline = time.monotonic() + 5.0  # the client's reader thread notices a drop shortly after
    while r.isConnected() and time.monotonic() < deadline:
        time.sleep(0.01)
    print("after", r.isConnected(), flush=True)
"""


def _watch_receive(host: str) -> subprocess.Popen[str]:
    process = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(_WATCH_RECEIVE), host],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    assert process.stdout is not None
    assert process.stdout.readline().strip() == "connected True"
    return process


def _after(process: subprocess.Popen[str]) -> str:
    out, _ = process.communicate("check\n", timeout=30)
    return out.strip()


def test_stream_stall_kills_the_receive_stream(sim_controller: Factory) -> None:
    ctl = sim_controller(instant=True)
    watcher = _watch_receive(ctl.host)
    ctl.inject("stall:3")
    time.sleep(3.5)
    assert _after(watcher) == "after False"
    r = rtde_receive.RTDEReceiveInterface(ctl.host)  # streaming again
    assert r.isConnected()
    r.disconnect()


def test_connection_drop_closes_connections_while_motion_goes_on(
    sim_controller: Factory,
) -> None:
    ctl = sim_controller()
    c = rtde_control.RTDEControlInterface(ctl.host)
    start = ctl.snapshot().tcp_pose
    # About 7.5 s: long enough to outlast the disconnect and the watcher's start on a busy machine.
    assert c.moveL(shifted(list(start), -0.3), 0.04, 1.0, True)
    c.disconnect()  # the program and its motion outlive the client
    watcher = _watch_receive(ctl.host)
    ctl.inject("drop-connection")
    assert _after(watcher) == "after False"
    snap = ctl.snapshot()
    assert snap.program_running
    assert snap.moving
    r = rtde_receive.RTDEReceiveInterface(ctl.host)  # still listening
    try:
        assert r.isConnected()
        # The move ends where it was headed, as the receive stream shows.
        wait_for(lambda: abs(r.getActualTCPPose()[2] - (start[2] - 0.3)) < 1e-9, timeout_s=15.0)
        # The stream can show the final pose a cycle before the motion is marked finished.
        wait_for(lambda: not ctl.snapshot().moving, timeout_s=5.0)
    finally:
        r.disconnect()
