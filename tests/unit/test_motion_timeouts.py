"""The time a move may take before it counts as hung (cell/sequence.py): ``trapezoid_s``,
``move_timeout_s``, ``joint_move_timeout_s`` and a blended path's sum of them, against motion
times worked out by hand from the trapezoid (accelerate at ``a`` to ``v``, cruise, brake at
``a``) or the triangle (never reaches ``v``). A wrong sign, a dropped factor or margin, the
smaller instead of the larger of translation and rotation, a joint travel without its
absolute value: each moves one of these numbers (issue 32, item 6)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from handeye_pick.cell.sequence import (
    TIMEOUT_FACTOR,
    execute,
    joint_move_timeout_s,
    move_timeout_s,
    trapezoid_s,
)
from handeye_pick.geometry import make_transform
from handeye_pick.progress import Progress
from handeye_pick.steps import Move
from tests.unit.test_cell_session import ScriptedArm, _config

DOWN = np.diag([1.0, -1.0, -1.0])  # tool z straight down


def _rot_z(angle_rad: float) -> np.ndarray:
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


# --- the profile --------------------------------------------------------------------------------


def test_a_long_move_cruises_between_its_ramps() -> None:
    # 1 m at 0.25 m/s, 1.2 m/s^2: each ramp takes 0.25 / 1.2 = 0.208333 s over
    # 0.25^2 / 2.4 = 0.0260417 m; the 0.947917 m between them at 0.25 m/s take 3.791667 s.
    ramp_s = 0.25 / 1.2
    cruise_s = (1.0 - 2 * 0.25**2 / (2 * 1.2)) / 0.25
    assert trapezoid_s(1.0, 0.25, 1.2) == pytest.approx(2 * ramp_s + cruise_s, rel=1e-12)
    assert trapezoid_s(1.0, 0.25, 1.2) == pytest.approx(4.2083333, abs=1e-6)


def test_a_short_move_never_reaches_its_speed() -> None:
    # 10 mm at 1.2 m/s^2: accelerate over 5 mm (t = sqrt(2 * 0.005 / 1.2) = 0.091287 s), brake
    # over the other 5 mm in as long; the peak speed 0.1095 m/s stays below 0.25 m/s.
    half_s = math.sqrt(2 * 0.005 / 1.2)
    assert 1.2 * half_s < 0.25
    assert trapezoid_s(0.01, 0.25, 1.2) == pytest.approx(2 * half_s, rel=1e-12)
    assert trapezoid_s(0.01, 0.25, 1.2) == pytest.approx(0.1825742, abs=1e-6)


def test_the_trapezoid_and_the_triangle_meet_where_the_cruise_vanishes() -> None:
    # At d = v^2 / a the arm reaches v exactly half way and brakes at once: 2 v / a either way.
    v, a = 0.25, 1.2
    at = v**2 / a
    assert trapezoid_s(at, v, a) == pytest.approx(2 * v / a, rel=1e-12)
    assert trapezoid_s(at * (1 - 1e-9), v, a) == pytest.approx(2 * v / a, rel=1e-6)
    assert trapezoid_s(at * (1 + 1e-9), v, a) == pytest.approx(2 * v / a, rel=1e-6)
    assert trapezoid_s(0.0, v, a) == 0.0


def test_the_profile_time_grows_with_distance_and_shrinks_with_speed_and_acceleration() -> None:
    distances = [0.0, 0.001, 0.01, 0.05, 0.0520833, 0.06, 0.3, 1.0]
    times = [trapezoid_s(d, 0.25, 1.2) for d in distances]
    assert times == sorted(times)
    assert trapezoid_s(0.3, 0.5, 1.2) < trapezoid_s(0.3, 0.25, 1.2)
    assert trapezoid_s(0.3, 0.25, 2.4) < trapezoid_s(0.3, 0.25, 1.2)


# --- moveL ------------------------------------------------------------------------------------


def test_a_movel_gets_its_profile_time_times_the_factor_plus_the_margin() -> None:
    # 0.3 m straight, no turn: 0.3 / 0.25 + 0.25 / 1.2 = 1.408333 s; x 1.5 = 2.1125 s; + 5 s.
    T_from = make_transform(DOWN, [-0.4, 0.0, 0.3])
    T_to = make_transform(DOWN, [-0.4, 0.3, 0.3])
    assert TIMEOUT_FACTOR == 1.5
    assert move_timeout_s(T_from, T_to, 0.25, 1.2, 5.0) == pytest.approx(7.1125, abs=1e-9)
    assert move_timeout_s(T_from, T_to, 0.25, 1.2, 0.0) == pytest.approx(2.1125, abs=1e-9)
    # The way back takes as long.
    assert move_timeout_s(T_to, T_from, 0.25, 1.2, 5.0) == pytest.approx(7.1125, abs=1e-9)


def test_a_movel_that_mostly_turns_is_timed_by_its_angle() -> None:
    # 90 degrees about z, 10 mm across: pi/2 rad "at 0.25 m/s" is 6.283185 s + 0.208333 s of
    # ramps = 6.491519 s; x 1.5 = 9.737278 s; + 5 s. The 10 mm alone would give 0.27 s.
    T_from = make_transform(DOWN, [-0.4, 0.0, 0.3])
    T_to = make_transform(_rot_z(math.pi / 2) @ DOWN, [-0.4, 0.01, 0.3])
    expected = (math.pi / 2 / 0.25 + 0.25 / 1.2) * 1.5 + 5.0
    assert expected == pytest.approx(14.737278, abs=1e-6)
    assert move_timeout_s(T_from, T_to, 0.25, 1.2, 5.0) == pytest.approx(expected, abs=1e-9)


def test_a_movel_that_mostly_travels_is_timed_by_its_length() -> None:
    # 0.2 m with a 0.05 rad turn: the translation is the larger, 0.2 / 0.25 + 0.208333 s.
    T_from = make_transform(DOWN, [-0.4, 0.0, 0.3])
    T_to = make_transform(_rot_z(0.05) @ DOWN, [-0.4, 0.0, 0.5])
    expected = (0.2 / 0.25 + 0.25 / 1.2) * 1.5 + 2.0
    assert move_timeout_s(T_from, T_to, 0.25, 1.2, 2.0) == pytest.approx(expected, abs=1e-9)


# --- moveJ ------------------------------------------------------------------------------------


def test_a_movej_is_timed_by_the_joint_that_travels_farthest_either_way() -> None:
    # Joint 3 turns -1.0 rad (the farthest, backwards), joint 2 +0.5 rad: 1.0 rad at 0.5 rad/s,
    # 1.0 rad/s^2: ramps 0.5 s each over 0.125 rad, 0.75 rad cruising in 1.5 s: 2.5 s in all;
    # x 1.5 = 3.75 s; + 5 s.
    q_from = (0.0, -1.57, 1.57, -1.57, -1.57, 0.0)
    q_to = (0.0, -1.07, 0.57, -1.57, -1.57, 0.2)
    assert joint_move_timeout_s(q_from, q_to, 0.5, 1.0, 5.0) == pytest.approx(8.75, abs=1e-9)
    assert joint_move_timeout_s(q_to, q_from, 0.5, 1.0, 5.0) == pytest.approx(8.75, abs=1e-9)


def test_a_short_movej_is_timed_by_its_triangle() -> None:
    # 0.1 rad at 1.0 rad/s^2 never reaches 0.5 rad/s: 2 sqrt(0.1) = 0.632456 s; x 1.5; + 1 s.
    q_from = (0.0,) * 6
    q_to = (0.0, 0.0, 0.0, 0.0, 0.0, -0.1)
    expected = 2 * math.sqrt(0.1) * 1.5 + 1.0
    assert expected == pytest.approx(1.948683, abs=1e-6)
    assert joint_move_timeout_s(q_from, q_to, 0.5, 1.0, 1.0) == pytest.approx(expected, abs=1e-9)


# --- a blended path ---------------------------------------------------------------------------


def test_a_blended_path_gets_the_sum_of_its_segments_and_one_margin(tmp_path: Path) -> None:
    """The path's timeout (cell/sequence.py ``_Run.path``): each segment's profile time times
    the factor, from where the arm stands, plus the config's margin once (not per segment)."""
    config = _config(tmp_path)
    arm = ScriptedArm(tmp_path / "audit.jsonl")
    R_start, start = arm.tcp_pose()[:3, :3], arm.tcp_pose()[:3, 3]  # no turn: lengths only
    first = make_transform(R_start, start + np.array([0.0, 0.2, 0.0]))
    second = make_transform(R_start, start + np.array([0.0, 0.2, -0.1]))
    steps = [Move("over", first, blend_m=0.01), Move("down", second, slow=True)]
    execute(config, steps, arm, Progress.quiet(), {})
    ((waypoints, timeout_s),) = [c[1] for c in arm.calls if c[0] == "path"]  # type: ignore[misc]
    motion = config.motion
    # 0.2 m at the travel speed, then 0.1 m at the grasp speed, both at the same acceleration.
    over_s = 0.2 / motion.speed_mps + motion.speed_mps / motion.accel_mps2
    down_s = trapezoid_s(0.1, motion.grasp_speed_mps, motion.accel_mps2)
    expected = (over_s + down_s) * TIMEOUT_FACTOR + motion.timeout_margin_s
    assert [w.speed_mps for w in waypoints] == [motion.speed_mps, motion.grasp_speed_mps]
    assert timeout_s == pytest.approx(expected, abs=1e-9)
