"""Failure endings the field notes and the README promise, through the real ur_rtde against the
simulated controller: whatever ends a move, the arm is stopped where it still listens, and nothing
is ever unlocked or re-sent by itself.
"""

from __future__ import annotations

from collections.abc import Callable

import pytest

from handeye_pick.geometry import Transform
from handeye_pick.robot.port import RuntimeState
from handeye_pick.robot.ur_rtde_arm import URRtdeArm
from mocks.ur_controller import SimulatedController

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

    with URRtdeArm(ctl.host) as arm:
        with pytest.raises(RuntimeError, match="progress output is gone"):
            arm.move_linear(_lowered(arm.tcp_pose(), 0.10), 0.25, 1.2, 5.0, fail_halfway)
        assert arm.status().runtime_state == RuntimeState.PLAYING  # session still usable
    assert [c["kind"] for c in ctl.commands] == ["moveL", "stopL"]
    assert not ctl.snapshot().moving
