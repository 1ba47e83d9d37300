"""Every ending of `python -m mocks.ur_controller` is one line on stderr and the exit status its
README gives (0 stopped, 2 bad arguments or record file, 3 cannot listen), never a traceback:
each test runs the simulator as a subprocess on its own 127.0.0.N."""

from __future__ import annotations

import signal
import subprocess
from collections.abc import Callable
from pathlib import Path

import pytest

from mocks.ur_controller import SimulatedController
from mocks.ur_controller.record import CommandRecord
from tests.conftest import next_loopback_host
from tests.mock_controller.helpers import run_client
from tests.mock_controller.test_admin_cli import run_module
from tests.mock_controller.test_record_cli import _start_cli, _start_ready_cli


def _stop(process: subprocess.Popen[str], *signals: signal.Signals) -> tuple[int, str]:
    """Send the signals back to back; the exit status and everything on stderr."""
    try:
        for stop_signal in signals:
            process.send_signal(stop_signal)
        _, err = process.communicate(timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    return process.returncode, err


def _last_line_alone(err: str) -> str:
    """The ending line, after making sure no traceback came with it."""
    assert "Traceback" not in err, err
    return err.splitlines()[-1]


def test_the_documented_record_command_creates_its_folder(tmp_path: Path) -> None:
    record = tmp_path / "out" / "commands.jsonl"  # docs/simulator.md's out/, which a clone lacks
    host, process = _start_ready_cli("--tcp-offset", "0", "0", "0.12", "0", "0", "0",
                                     "--record", str(record))
    status, err = _stop(process, signal.SIGTERM)
    assert status == 0
    assert _last_line_alone(err) == (f"stopped by SIGTERM: the simulated controller on {host} "
                                     "has closed its ports")
    assert record.is_file()


@pytest.mark.parametrize(("signals", "line"), [
    ((signal.SIGINT,), "stopped by SIGINT (Ctrl-C)"),
    ((signal.SIGTERM,), "stopped by SIGTERM"),
    ((signal.SIGINT, signal.SIGINT), "stopped by SIGINT (Ctrl-C)"),  # an impatient second Ctrl-C
])
def test_a_signal_ends_it_in_one_line_with_status_0(signals: tuple[signal.Signals, ...],
                                                   line: str) -> None:
    host, process = _start_ready_cli("--instant")
    status, err = _stop(process, *signals)
    assert status == 0
    assert _last_line_alone(err) == (f"{line}: the simulated controller on {host} has closed its "
                                     "ports")


def test_an_address_in_use_is_one_line_that_says_what_to_do(
    sim_controller: Callable[..., SimulatedController],
) -> None:
    ctl = sim_controller(instant=True)  # a simulator left running on that address
    done = run_module("--host", ctl.host)
    assert done.returncode == 3
    assert done.stdout == ""
    assert done.stderr.splitlines() == [
        f"error: cannot listen on {ctl.host}:30004 (rtde): Address already in use: is another "
        f"simulated controller (or URSim) still serving {ctl.host}? stop it, or give this one "
        "another --host 127.0.0.N"
    ]


@pytest.mark.parametrize(("arguments", "message"), [
    (["--speed-factor", "abc"], "error: argument --speed-factor: invalid float value: 'abc'"),
    (["--log-level", "loud"], "error: argument --log-level: invalid choice: 'LOUD'"),
    (["--feedback-input", "16"], "error: argument --feedback-input: expected 2 arguments"),
    (["inject", "--host"], "error: argument --host: expected one argument"),
])
def test_a_bad_option_value_is_one_line_with_status_2(arguments: list[str], message: str) -> None:
    done = run_module(*arguments) if arguments[0] == "inject" else run_module(
        "--host", next_loopback_host(), *arguments)
    assert done.returncode == 2
    assert len(done.stderr.splitlines()) == 1, done.stderr
    assert done.stderr.startswith(message)


@pytest.mark.parametrize("where", ["a folder", "below a file"])
def test_a_record_file_that_cannot_be_written_is_one_line_with_status_2(
    tmp_path: Path, where: str,
) -> None:
    (tmp_path / "plain").write_text("")
    record = tmp_path if where == "a folder" else tmp_path / "plain" / "commands.jsonl"
    done = run_module("--host", next_loopback_host(), "--record-motions", str(record))
    assert done.returncode == 2
    assert (done.stdout, len(done.stderr.splitlines())) == ("", 1), done.stderr
    assert done.stderr.startswith(f"error: --record-motions {record}: cannot ")
    assert done.stderr.rstrip().endswith("give a file in a folder you can write to")


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full (a full disk)")
def test_a_record_file_that_fills_up_ends_in_one_line_and_the_controller_goes_on() -> None:
    host, process = _start_ready_cli("--instant", "--record", "/dev/full")
    client = run_client(f"""
        import rtde_control, rtde_receive
        c = rtde_control.RTDEControlInterface({host!r})
        pose = rtde_receive.RTDEReceiveInterface({host!r}).getActualTCPPose()
        print(c.moveL([pose[0], pose[1], pose[2] - 0.02, *pose[3:]], 0.1, 0.5),
              c.moveL(pose, 0.1, 0.5))
        c.stopScript()
        c.disconnect()
    """)
    status, err = _stop(process, signal.SIGTERM)
    assert client.stdout.split() == ["True", "True"], client.stderr
    assert status == 0
    assert "Traceback" not in err, err
    assert [line.split(" ur-sim ")[1] for line in err.splitlines() if "/dev/full" in line] == [
        "ERROR record file /dev/full: cannot write (No space left on device): it ends here; the "
        "controller goes on"
    ]


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full (a full disk)")
def test_a_record_that_cannot_be_written_keeps_its_entries() -> None:
    record = CommandRecord("/dev/full")
    record.add({"kind": "moveL"})
    record.add({"kind": "stopL"})
    record.close()
    assert record.entries() == [{"kind": "moveL"}, {"kind": "stopL"}]


def test_a_reader_that_goes_away_stops_it_in_one_line() -> None:
    for _ in range(20):  # another test session may hold an address: move on
        host = next_loopback_host()
        process = _start_cli("--host", host, "--instant")
        assert process.stdout is not None
        process.stdout.close()  # before it says ready
        status, err = _stop(process)
        if status != 3:
            break
    assert status == 0, err
    assert _last_line_alone(err) == (f"stopped: its standard output closed: the simulated "
                                     f"controller on {host} has closed its ports")
