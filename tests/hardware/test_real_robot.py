"""Opt-in tests against a real UR controller: ``pytest tests/hardware --robot-host 192.168.1.10``.

They read and ask, and never move the arm: motion on a real cell belongs to a person running
``handeye-pick touch-test`` or ``pick`` next to it. What they prove is the part the simulated
controller cannot: that the real controller's answers agree with our frames.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest

from handeye_pick.geometry import compose, invert, rotation_angle_between
from handeye_pick.robot.ur.arm import URRtdeArm

pytestmark = pytest.mark.hardware


@pytest.fixture(scope="module")
def arm(request: pytest.FixtureRequest) -> Iterator[URRtdeArm]:
    with URRtdeArm(request.config.getoption("--robot-host")) as robot:
        yield robot


def test_status_reads_a_live_controller(arm: URRtdeArm) -> None:
    status = arm.status()
    assert status.controller_version
    assert status.safety_mode > 0


def test_flange_and_tcp_agree_through_the_active_tcp_offset(arm: URRtdeArm) -> None:
    T_flange_tcp = arm.tcp_offset()
    T_base_flange = arm.flange_pose()
    T_base_tcp = arm.tcp_pose()
    # The arm stands still during the test, so both samples describe one pose.
    T_predicted = compose(T_base_flange, T_flange_tcp)
    assert np.linalg.norm(T_predicted[:3, 3] - T_base_tcp[:3, 3]) < 1e-4
    assert rotation_angle_between(T_predicted[:3, :3], T_base_tcp[:3, :3]) < 1e-4
    assert np.allclose(compose(T_base_tcp, invert(T_flange_tcp)), T_base_flange, atol=1e-4)


def test_the_controller_accepts_the_pose_it_is_in(arm: URRtdeArm) -> None:
    T_base_tcp = arm.tcp_pose()
    assert arm.has_ik_solution(T_base_tcp)
    assert arm.is_pose_within_safety_limits(T_base_tcp)
