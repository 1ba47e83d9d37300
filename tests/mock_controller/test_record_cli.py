"""The command record file and the command line of the simulated controller."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest
import rtde_control
import rtde_receive

from mocks.ur_controller import SimulatedController
from mocks.ur_controller.faults import FaultSpec, parse_fault
from mocks.ur_controller.options import EXIT_CANNOT_LISTEN
from tests.conftest import next_loopback_host
from tests.mock_controller.helpers import HOME_Q

REPO_ROOT = Path(__file__).resolve().parents[2]


def test_record_file_holds_exactly_the_commands(
    sim_controller: Callable[..., SimulatedController], tmp_path: Path,
) -> None:
    path = tmp_path / "commands.jsonl"
    ctl = sim_controller(instant=True, record_path=path)
    c = rtde_control.RTDEControlInterface(ctl.host)
    try:
        pose = list(ctl.snapshot().tcp_pose)
        pose[2] -= 0.05
        assert c.moveL(pose, 0.2, 1.0)
        assert c.moveJ(HOME_Q, 0.5, 0.7, True)
        c.stopJ(4.0)
        assert c.getTCPOffset() == [0.0] * 6  # not a motion or stop: not recorded
        lines = path.read_text().splitlines()  # flushed per line: readable while running
    finally:
        c.disconnect()
    entries = [json.loads(line) for line in lines]
    assert entries == ctl.commands
    assert [{k: v for k, v in e.items() if k != "t"} for e in entries] == [
        {"kind": "moveL", "target": pose, "speed": 0.2, "accel": 1.0, "async": False},
        {"kind": "moveJ", "target": HOME_Q, "speed": 0.5, "accel": 0.7, "async": True},
        {"kind": "stopJ", "accel": 4.0, "async": False},
    ]
    assert 0.0 < entries[0]["t"] <= entries[1]["t"] <= entries[2]["t"]


@pytest.mark.parametrize(
    ("spec", "expected"),
    [
        ("protective-stop", FaultSpec("protective-stop")),
        ("drop-connection@now", FaultSpec("drop-connection")),
        ("stall:2.5@move:3:0.25", FaultSpec("stall", 2.5, 3, 0.25)),
        ("slow:0.2", FaultSpec("slow", 0.2)),
    ],
)
def test_fault_specs_parse(spec: str, expected: FaultSpec) -> None:
    assert parse_fault(spec) == expected


@pytest.mark.parametrize(
    "spec",
    ["explode", "stall", "stall:-1", "protective-stop:3", "emergency-stop@move:0:0.5",
     "safeguard-stop@move:1:1.5", "refuse-start@later"],
)
def test_bad_fault_specs_are_refused(spec: str) -> None:
    with pytest.raises(ValueError, match="fault"):
        parse_fault(spec)


def _start_cli(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "mocks.ur_controller", *args],
        cwd=REPO_ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )


def _start_ready_cli(*args: str) -> tuple[str, subprocess.Popen[str]]:
    """Start the command line on a free loopback address; returns it once `ready` is printed."""
    for _ in range(20):
        host = next_loopback_host()
        process = _start_cli("--host", host, *args)
        assert process.stdout is not None
        ready = process.stdout.readline()
        if ready.startswith("ready"):
            assert host in ready
            return host, process
        process.wait(timeout=10)
        assert process.returncode == EXIT_CANNOT_LISTEN  # taken by another test session
    raise AssertionError("no free loopback address after 20 tries")


@pytest.mark.parametrize("stop_signal", [signal.SIGTERM, signal.SIGINT])
def test_cli_prints_ready_serves_and_stops_on_signal(stop_signal: signal.Signals) -> None:
    host, process = _start_ready_cli("--instant", "--model", "ur10e",
                                     "--initial-q", *map(str, HOME_Q))
    try:
        r = rtde_receive.RTDEReceiveInterface(host)
        assert r.getActualQ() == pytest.approx(HOME_Q)
        r.disconnect()
        process.send_signal(stop_signal)
        assert process.wait(timeout=10) == 0
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()


def test_cli_refuses_a_bad_fault_spec() -> None:
    process = _start_cli("--host", next_loopback_host(), "--inject", "explode@now")
    out, err = process.communicate(timeout=30)
    assert process.returncode == 2
    assert out == ""
    assert "explode" in err
