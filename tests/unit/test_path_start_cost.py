"""The session's running figure of a path's start (robot/ur/start_cost.py): none before it is
measured, the measurement at connect, then each path's call beyond a single move's weighed in."""

from __future__ import annotations

import math

from hypothesis import given
from hypothesis import strategies as st

from handeye_pick.robot.ur.start_cost import SMOOTHING, PathStartCost

seconds = st.floats(0.0, 5.0)


def test_no_figure_before_a_measurement_or_a_path() -> None:
    cost = PathStartCost()
    assert cost.seconds is None
    cost.single_sent(0.004)  # a single move alone says nothing of a path's start
    assert cost.seconds is None


@given(seconds)
def test_the_measurement_at_connect_is_the_first_figure(restart_s: float) -> None:
    cost = PathStartCost()
    cost.restarted(restart_s)
    assert cost.seconds == restart_s


@given(seconds, seconds, st.floats(0.0, 0.05))
def test_a_path_weighs_in_what_it_took_beyond_a_single_move(
    restart_s: float, path_s: float, single_s: float
) -> None:
    cost = PathStartCost()
    cost.restarted(restart_s)
    cost.single_sent(single_s)
    cost.path_sent(path_s)
    beyond = max(0.0, path_s - single_s)
    assert cost.seconds is not None
    assert math.isclose(cost.seconds, (1 - SMOOTHING) * restart_s + SMOOTHING * beyond)


@given(st.lists(seconds, min_size=1, max_size=30))
def test_the_figure_stays_within_what_was_measured(paths: list[float]) -> None:
    cost = PathStartCost()
    for path_s in paths:
        cost.path_sent(path_s)
    assert cost.seconds is not None
    assert min(paths) - 1e-12 <= cost.seconds <= max(paths) + 1e-12
