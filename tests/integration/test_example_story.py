"""examples/vision_loop.py reads as the loop's story: the simulated controller's log goes to the
file named at the start, never to the terminal; `grasp unconfirmed` is explained before it
first appears; the audit file is named. Its endings are one line: a controller already on the
address, and a Ctrl-C, which `run` answers by stopping the arm while the simulated robot (in a
session of its own, as a real one) goes on until the example stops it."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import yaml

from mocks.ur_controller import SimulatedController
from tests.integration.test_vision_loop_example import example_config

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "vision_loop.py"
# The example as a terminal starts it: Ctrl-C raises KeyboardInterrupt even when the test runner
# started this process with SIGINT ignored.
AS_FROM_A_TERMINAL = (
    "import runpy, signal, sys; signal.signal(signal.SIGINT, signal.default_int_handler); "
    "sys.argv = sys.argv[1:]; runpy.run_path(sys.argv[0], run_name='__main__')"
)


def _example(config: Path, cwd: Path) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-c", AS_FROM_A_TERMINAL, str(EXAMPLE), "--config", str(config)],
        cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        start_new_session=True,  # its own process group, as a terminal's foreground job
    )


def _finish(process: subprocess.Popen[str]) -> tuple[str, str]:
    try:
        return process.communicate(timeout=180)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()


def test_the_terminal_shows_the_loops_story_and_the_simulators_log_goes_to_a_file(
    tmp_path: Path,
) -> None:
    out, err = _finish(_example(example_config(tmp_path, "loop.yaml"), tmp_path))
    lines = out.splitlines()
    assert lines[1].endswith(": its log goes to out/vision_loop-simulator.log"), out
    log = (tmp_path / "out" / "vision_loop-simulator.log").read_text()
    assert "ur-sim INFO rtde_control program started" in log
    assert "ur-sim" not in out + err
    assert lines[2] == (
        "the gripper (tool output 0) has no confirm_input in loop.yaml: nothing senses the "
        "part, so every grasp reads 'grasp unconfirmed' and is carried as held "
        "(docs/grippers.md)"
    )
    assert err.count("grasp unconfirmed") == 5
    assert f"audit records go to {tmp_path / 'picks.jsonl'}" in err.splitlines()
    assert lines[-1] == "audit records: picks.jsonl"


def test_a_controller_already_on_the_address_is_one_line(
    sim_controller: Callable[..., SimulatedController], tmp_path: Path,
) -> None:
    ctl = sim_controller(instant=True)  # a simulator left running where the config points
    config = example_config(tmp_path, "loop.yaml")
    doc = yaml.safe_load(config.read_text())
    doc["robot"]["host"] = ctl.host
    config.write_text(yaml.safe_dump(doc))
    process = _example(config, tmp_path)
    _, err = _finish(process)
    assert process.returncode == 1
    assert err.splitlines() == [
        f"error: the simulated controller cannot listen on {ctl.host}: is another simulator or "
        "example still running there? stop it, then run this again "
        "(out/vision_loop-simulator.log says why)"
    ]


def test_ctrl_c_stops_the_arm_through_run_then_the_simulator_in_one_line(
    tmp_path: Path,
) -> None:
    process = _example(example_config(tmp_path, "loop.yaml"), tmp_path)
    assert process.stdout is not None
    for line in process.stdout:  # the first cycle is done: the second one is under way
        if line.startswith("cycle 1:"):
            break
    os.killpg(process.pid, signal.SIGINT)  # as Ctrl-C at the terminal
    _, err = _finish(process)
    assert process.returncode == 130, err
    assert "Traceback" not in err, err
    assert err.splitlines()[-1] == (
        "interrupted (Ctrl-C): handeye-pick run stopped the arm and exited 130; the simulated "
        "controller is stopped"
    )
    log = (tmp_path / "out" / "vision_loop-simulator.log").read_text().splitlines()
    assert log[-1].startswith("stopped by SIGTERM: the simulated controller on")  # by the example
