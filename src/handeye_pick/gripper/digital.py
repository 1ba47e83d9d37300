"""``type: digital-output``: a gripper switched by one digital output of the controller, with an
optional feedback input (vacuum switch, finger sensor) that confirms the grasp.

Without a feedback input nothing is sensed: every grasp is ``UNCONFIRMED``, never ``CONFIRMED``.
"""

from __future__ import annotations

import time

from handeye_pick.config.gripper import GripperConfig
from handeye_pick.errors import GripperFault
from handeye_pick.gripper.port import GraspState
from handeye_pick.robot.port import RobotArm

INPUT_POLL_S = 0.01
"""How often the feedback input is read while waiting for it (five RTDE cycles at 500 Hz)."""


class DigitalOutputGripper:
    """A ``Gripper`` on one output of ``arm``; ``config.settle_s`` is waited after switching."""

    kind = GripperConfig.kind

    def __init__(self, config: GripperConfig, arm: RobotArm) -> None:
        self._config = config
        self._arm = arm

    def close(self) -> GraspState:
        """Switch the output to ``close_value``; with a feedback input, ``CONFIRMED`` once it
        reads "held" within ``confirm_timeout_s``, else ``MISSED``."""
        self._switch(self._config.close_value)
        if self._config.confirm_input is None:
            return GraspState.UNCONFIRMED
        held = self._wait_for_input(held=True)
        return GraspState.CONFIRMED if held else GraspState.MISSED

    def why_missed(self) -> str:
        """The feedback input, the level that means "held" and the wait (s), and what to check."""
        feedback = self._config.confirm_input
        if feedback is None:  # close() never misses without one
            return "no confirm_input is configured"
        return (
            f"{feedback.bank.value} digital input {feedback.index} did not read "
            f"{str(feedback.value).lower()} within {self._config.confirm_timeout_s:g} s of "
            "closing (robot.gripper.confirm_input, confirm_timeout_s): check that a part was "
            "under the gripper and that its sensor switches that input"
        )

    def open(self) -> bool:
        """Switch the output off; with a feedback input, the release is confirmed when it clears
        within ``confirm_timeout_s`` (GripperFault when it does not)."""
        self._switch(not self._config.close_value)
        feedback = self._config.confirm_input
        if feedback is None:
            return False
        if not self._wait_for_input(held=False):
            raise GripperFault(
                f"gripper released, but {feedback.bank.value} input {feedback.index} still reads "
                f"the part held after {self._config.confirm_timeout_s:g} s: check the part and "
                "the sensor"
            )
        return True

    def ready_to_grasp(self) -> str | None:
        """Always ready: an output cannot be read back here, and a feedback input senses the
        part, not whether the gripper is open."""
        return None

    def state(self) -> GraspState:
        feedback = self._config.confirm_input
        if feedback is None:
            return GraspState.UNCONFIRMED
        held = self._arm.digital_input(feedback.bank, feedback.index) == feedback.value
        return GraspState.CONFIRMED if held else GraspState.MISSED

    def close_connection(self) -> None:
        """Nothing to close: the output belongs to the robot session."""

    def _switch(self, value: bool) -> None:
        config = self._config
        self._arm.set_digital_output(config.bank, config.index, value)
        time.sleep(config.settle_s)

    def _wait_for_input(self, *, held: bool) -> bool:
        """Whether the feedback input reads ``held`` within ``confirm_timeout_s``."""
        wanted = GraspState.CONFIRMED if held else GraspState.MISSED
        deadline = time.monotonic() + self._config.confirm_timeout_s
        while self.state() is not wanted:
            if time.monotonic() > deadline:
                return False
            time.sleep(INPUT_POLL_S)
        return True
