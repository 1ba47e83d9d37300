"""The joint path along a move (arm/path.py): every look verified with the simulated
controller's own forward kinematics and path interpolation, the steps as fine as documented, the
branch kept, and a move the arm cannot follow refused by name and where along it."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from handeye_pick.arm.kinematics import tcp_poses
from handeye_pick.arm.models import arm_model
from handeye_pick.arm.path import (
    JOINT_STEP_RAD,
    LINEAR_STEP_M,
    TURN_STEP_RAD,
    JointPath,
    JointPathRefused,
    follow,
    follow_all,
    joint_move,
)
from handeye_pick.geometry import make_transform, rotation_angle_between, rotation_from_rotvec
from handeye_pick.scene.path import pieces
from handeye_pick.steps import Move
from mocks.ur_controller.kinematics import MODELS, forward, interpolate_pose, inverse, inverse_all

MODEL = arm_model("ur5e")
SIM = MODELS["ur5e"]
T_FLANGE_TCP = make_transform(np.eye(3), [0.0, 0.0, 0.15])
Q_CAPTURE = np.array([0.0, -1.63039, 1.338517, -1.278923, -1.570796, 0.0])  # config/bin.yaml
T_CAPTURE = tcp_poses(MODEL, Q_CAPTURE, T_FLANGE_TCP)[0]


def _moved(T: np.ndarray, by_m: list[float], turn_rotvec: list[float] | None = None) -> np.ndarray:
    out = T.copy()
    out[:3, 3] += by_m
    if turn_rotvec is not None:
        out[:3, :3] = rotation_from_rotvec(turn_rotvec) @ T[:3, :3]
    return out


def _sim_tcp(q: np.ndarray) -> np.ndarray:
    """The TCP by the simulator's forward kinematics (its own code and DH table)."""
    return forward(SIM, q) @ T_FLANGE_TCP


def _assert_on_the_line(path: JointPath, T_from: np.ndarray, T_to: np.ndarray) -> None:
    """Every look's TCP within 0.01 mm (and 1e-5 rad) of the controller's straight line, and
    no step longer than the documented step."""
    tcps = [_sim_tcp(q) for q in path.q]
    for s, T in zip(path.fraction, tcps, strict=True):
        expected = interpolate_pose(T_from, T_to, float(s))
        assert np.linalg.norm(T[:3, 3] - expected[:3, 3]) < 1e-5
        assert rotation_angle_between(T[:3, :3], expected[:3, :3]) < 1e-5
    for a, b in itertools.pairwise(tcps):
        assert np.linalg.norm(b[:3, 3] - a[:3, 3]) <= LINEAR_STEP_M + 1e-9
        assert rotation_angle_between(a[:3, :3], b[:3, :3]) <= TURN_STEP_RAD + 1e-9


def test_a_move_l_is_followed_in_fine_steps_each_on_the_line() -> None:
    T_to = _moved(T_CAPTURE, [0.1, 0.05, -0.3], [0.0, 0.0, math.radians(20)])
    (piece,) = pieces([Move("grasp", T_to)], T_CAPTURE)
    q_end = inverse(SIM, T_to @ np.linalg.inv(T_FLANGE_TCP), Q_CAPTURE)
    path = follow(MODEL, T_FLANGE_TCP, piece, Q_CAPTURE, q_end)
    assert path.what == "the grasp descent"
    assert path.q.shape == (len(path.fraction), 6)
    assert len(path.fraction) - 1 == math.ceil(0.3202 / LINEAR_STEP_M)  # 320 mm in 5 mm steps
    np.testing.assert_allclose(path.q[0], Q_CAPTURE, atol=1e-9)
    np.testing.assert_allclose(path.dq, np.diff(path.q, axis=0))
    _assert_on_the_line(path, T_CAPTURE, T_to)


def test_a_blended_path_is_followed_piece_after_piece_without_a_seam() -> None:
    T_approach = _moved(T_CAPTURE, [0.15, 0.0, -0.1])
    T_grasp = _moved(T_approach, [0.0, 0.0, -0.2])
    steps = [Move("approach", T_approach, blend_m=0.05), Move("grasp", T_grasp, slow=True)]
    curves = pieces(steps, T_CAPTURE)
    assert [c.what for c in curves] == [
        "the move to the approach", "the blend at the approach", "the grasp descent"
    ]
    q_grasp = inverse(SIM, T_grasp @ np.linalg.inv(T_FLANGE_TCP), Q_CAPTURE)
    paths = follow_all(MODEL, T_FLANGE_TCP, curves, Q_CAPTURE, [None, None, q_grasp])
    for before, after in itertools.pairwise(paths):
        np.testing.assert_allclose(after.q[0], before.q[-1], atol=1e-9)
    for curve, path in zip(curves, paths, strict=True):
        s = (path.fraction - curve.fraction(0.0)) / (curve.fraction(1.0) - curve.fraction(0.0))
        for q, s_one in zip(path.q, s, strict=True):
            expected = curve.pose(float(s_one))
            assert np.linalg.norm(_sim_tcp(q)[:3, 3] - expected[:3, 3]) < 1e-5
    np.testing.assert_allclose(_sim_tcp(paths[-1].q[-1]), T_grasp, atol=1e-9)


def test_a_move_ending_on_another_branch_than_the_controllers_ik_is_refused() -> None:
    T_to = _moved(T_CAPTURE, [0.05, 0.0, -0.1])
    (piece,) = pieces([Move("approach", T_to)], T_CAPTURE)
    followed = follow(MODEL, T_FLANGE_TCP, piece, Q_CAPTURE).q[-1]
    others = inverse_all(SIM, T_to @ np.linalg.inv(T_FLANGE_TCP))
    elbow_down = max(others, key=lambda q: float(np.abs(q - followed).max()))
    with pytest.raises(JointPathRefused) as refused:
        follow(MODEL, T_FLANGE_TCP, piece, Q_CAPTURE, elbow_down)
    message = str(refused.value)
    assert message.startswith("the arm cannot follow the move to the approach at 100 %: it ends")
    assert "another branch than the controller's IK at the target" in message
    assert refused.value.fraction == 1.0


def test_a_path_through_the_wrist_singularity_is_refused_by_name_and_where() -> None:
    """Wrist 2 from +0.1 to -0.1 rad: joints 4 and 6 line up at a third of the way, where the
    controller would stop the arm (a protective stop near a singularity)."""
    q_from = np.array([0.3, -1.2, 1.2, -1.5, 0.1, 0.2])
    q_to = q_from + np.array([0, 0, 0, 0, -0.2, 0])
    T_from, T_to = (tcp_poses(MODEL, q, T_FLANGE_TCP)[0] for q in (q_from, q_to))
    (piece,) = pieces([Move("place", T_to, slow=True)], T_from)
    with pytest.raises(JointPathRefused) as refused:
        follow(MODEL, T_FLANGE_TCP, piece, q_from)
    assert str(refused.value) == (
        "the arm cannot follow the place descent at 33 %: wrist 2 comes within 2 deg of lining "
        "up joints 4 and 6 (the wrist singularity)"
    )
    assert 0.3 < refused.value.fraction < 0.36


def test_a_wrist_that_would_jump_is_refused() -> None:
    q_from = np.array([0.3, -1.2, 1.2, -1.5, 0.3, 0.2])
    q_to = q_from + np.array([0, 0, 0, 0, -0.6, 0])
    T_from, T_to = (tcp_poses(MODEL, q, T_FLANGE_TCP)[0] for q in (q_from, q_to))
    (piece,) = pieces([Move("retreat", T_to)], T_from)
    with pytest.raises(JointPathRefused, match=r"the lift-off to the retreat at \d+ %: joint 4 "
                       r"would turn [\d.]+ deg in one step \(at most 5.7 deg\)"):
        follow(MODEL, T_FLANGE_TCP, piece, q_from)


def test_joints_on_no_branch_of_the_start_are_refused() -> None:
    (piece,) = pieces([Move("approach", _moved(T_CAPTURE, [0.0, 0.0, -0.1]))], T_CAPTURE)
    with pytest.raises(JointPathRefused, match="on no branch that reaches the move's start"):
        follow(MODEL, T_FLANGE_TCP, piece, Q_CAPTURE + np.array([0.3, 0, 0, 0, 0, 0]))


def test_a_move_j_is_linear_in_joint_angles_in_one_degree_steps() -> None:
    q_to = Q_CAPTURE + np.array([1.0, -0.2, 0.3, 0.0, 0.5, -3.0])
    path = joint_move("the move to capture", Q_CAPTURE, q_to)
    assert np.abs(path.dq).max() <= JOINT_STEP_RAD + 1e-12
    np.testing.assert_array_equal(path.q[[0, -1]], [Q_CAPTURE, q_to])
    np.testing.assert_allclose(path.dq, np.broadcast_to(path.dq[0], path.dq.shape), atol=1e-12)
    np.testing.assert_allclose(path.fraction, np.linspace(0, 1, len(path.q)))


@settings(max_examples=60)
@given(
    offset=arrays(np.float64, 3, elements=st.floats(-0.6, 0.6)),
    turn=arrays(np.float64, 3, elements=st.floats(-0.6, 0.6)),
)
def test_a_move_l_is_either_followed_on_the_line_or_refused(
    offset: np.ndarray, turn: np.ndarray
) -> None:
    """Never a path that silently leaves the line: wherever the target lies, each look is on it
    by the simulator's kinematics, or the move is refused."""
    T_to = _moved(T_CAPTURE, offset.tolist(), turn.tolist())
    (piece,) = pieces([Move("approach", T_to)], T_CAPTURE)
    try:
        path = follow(MODEL, T_FLANGE_TCP, piece, Q_CAPTURE)
    except JointPathRefused as refused:
        message = str(refused)
    else:
        _assert_on_the_line(path, T_CAPTURE, T_to)
        return
    assert message.startswith("the arm cannot follow the move to the approach at ")
