"""A missed grasp says why, against the simulated controller through the real ur_rtde client:
which input was awaited at which level and for how long (digital-output gripper), or what the
fingers did (Robotiq 2F), and what to check."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from mocks.ur_controller import SimulatedController
from tests.integration.test_gripper_pick import ROBOTIQ
from tests.integration.test_pick_cli import DEMO, TCP_OFFSET, run_pick, write_config

SimFactory = Callable[..., SimulatedController]
# An input the simulator never sets: it answers only its --feedback-input bit (here: none).
UNANSWERED = (
    "  gripper:\n    type: digital-output\n    bank: tool\n    index: 0\n    close_value: true\n"
    "    settle_s: 0\n    confirm_input: {bank: standard, index: 5, value: true}\n"
    "    confirm_timeout_s: 0.2\n"
)


def _missed_line(config: Path) -> str:
    """The pick's progress line that reports the missed grasp (the pick exits 5)."""
    done = run_pick(config, "--detection", str(DEMO / "detection.yaml"))
    assert done.returncode == 5, done.stderr
    return next(line for line in done.stderr.splitlines() if line.startswith("grasp missed"))


def test_a_missed_grasp_names_the_input_its_level_and_the_wait(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    assert _missed_line(write_config(tmp_path, ctl.host, robot_extra=UNANSWERED)) == (
        "grasp missed: standard digital input 5 did not read true within 0.2 s of closing "
        "(robot.gripper.confirm_input, confirm_timeout_s): check that a part was under the "
        "gripper and that its sensor switches that input"
    )


def test_a_missed_robotiq_grasp_says_what_the_fingers_did(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)  # no part between the fingers
    assert _missed_line(write_config(tmp_path, ctl.host, robot_extra=ROBOTIQ)) == (
        f"grasp missed: the fingers of the Robotiq gripper on {ctl.host}:63352 closed to 0.0 mm "
        "without touching anything (OBJ 3): check that a part was between them"
    )
