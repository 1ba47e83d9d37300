"""The controller's checks asked while an asynchronous move runs (issue 29, section 3).

ur_rtde's control script serves getInverseKinematics and isPoseWithinSafetyLimits while an
asynchronous moveL runs (docs/motion.md, "The next pick checked under motion"): the next pick
can be checked while the place still moves. This test asks them through the real ur_rtde, from
a second thread, while the session's own thread watches the move, as the cell does.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

import numpy as np

from handeye_pick.geometry import Transform
from handeye_pick.robot.ur.arm import URRtdeArm
from mocks.ur_controller import SimulatedController
from tests.conftest import TEST_WATCHDOG_S

SimFactory = Callable[..., SimulatedController]


def _lowered(T_base_tcp: Transform, metres: float) -> Transform:
    T = T_base_tcp.copy()
    T[2, 3] -= metres
    return T


def test_ik_and_safety_limits_are_answered_while_a_move_runs(
    sim_controller: SimFactory,
) -> None:
    ctl = sim_controller(speed_factor=1.0)
    answers: list[tuple[bool, bool, bool, bool]] = []
    with URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S) as arm:
        start = arm.tcp_pose()
        far = _lowered(start, 10.0)  # out of reach: the controller must say so, not just "yes"
        moving = threading.Event()

        def ask() -> None:
            moving.wait(10.0)
            before = ctl.snapshot().moving
            verdicts = (arm.has_ik_solution(start), arm.is_pose_within_safety_limits(start))
            refused_far = not arm.has_ik_solution(far)
            answers.append((before, *verdicts, ctl.snapshot().moving and refused_far))

        asker = threading.Thread(target=ask)
        asker.start()

        def watch(fraction: float) -> None:
            if 0.0 < fraction < 0.5:
                moving.set()

        arm.move_linear(_lowered(start, 0.15), 0.05, 0.5, 10.0, watch)
        asker.join(10.0)
        reached = arm.tcp_pose()
    assert answers == [(True, True, True, True)]
    np.testing.assert_allclose(reached[:3, 3], _lowered(start, 0.15)[:3, 3], atol=1e-4)
