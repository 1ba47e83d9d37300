"""The motion bound of the link solids (arm/bound.py): no sampled point of any link, inside or
on its surface, travels farther along a joint step than the bound says; joints that do not carry
a link do not count, and a lone joint's turn is bounded by its distances exactly."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from handeye_pick.arm.bound import axis_distances, motion_bound
from handeye_pick.arm.kinematics import link_poses
from handeye_pick.arm.models import MODEL_NAMES, arm_model

_RNG = np.random.default_rng(27)


def _points_in(length_m: float, radius_m: float, capsule: bool, n: int = 150) -> np.ndarray:
    """Points of a solid in its own frame (homogeneous, (4, n)): inside, on its mantle, at the
    rims of a cylinder and the poles of a capsule."""
    z = _RNG.uniform(-length_m / 2, length_m / 2, n)
    angle = _RNG.uniform(0.0, 2 * math.pi, n)
    r = radius_m * np.sqrt(_RNG.uniform(0.0, 1.0, n))
    r[: n // 3] = radius_m  # on the mantle
    z[: n // 6] = np.sign(z[: n // 6]) * length_m / 2  # at the rims
    points = np.stack([r * np.cos(angle), r * np.sin(angle), z, np.ones(n)])
    if capsule:
        tip = length_m / 2 + radius_m
        poles = np.array([[0.0, 0.0], [0.0, 0.0], [-tip, tip], [1.0, 1.0]])
        points = np.concatenate([points, poles], axis=1)
    return points


@pytest.mark.parametrize("name", ["ur3e", "ur5e", "ur10e", "ur30", "ur10"])
@settings(max_examples=40)
@given(
    q=arrays(np.float64, 6, elements=st.floats(-math.pi, math.pi)),
    dq=arrays(np.float64, 6, elements=st.floats(-0.08, 0.08)),
)
def test_no_point_of_a_link_moves_farther_than_its_bound(
    name: str, q: np.ndarray, dq: np.ndarray
) -> None:
    model = arm_model(name)
    bound = motion_bound(model, q, dq)[0]
    t = np.linspace(0.0, 1.0, 41)
    solids = link_poses(model, q + t[:, None] * dq)  # (T, L, 4, 4): moveJ-like, one way each
    for index, link in enumerate(model.links):
        points = _points_in(link.length_m, link.radius_m, link.kind == "capsule")
        moved = solids[:, index] @ points  # (T, 4, n)
        travel = np.linalg.norm(np.diff(moved[:, :3], axis=0), axis=1).sum(axis=0)
        assert travel.max() <= bound[index] * (1 + 1e-9) + 1e-12, link.name


def test_a_joint_beyond_a_link_does_not_move_it_and_a_lone_turn_is_bounded_exactly() -> None:
    model = arm_model("ur5e")
    q = np.array([0.0, -1.2, 1.0, -1.4, -1.57, 0.3])
    names = [link.name for link in model.links]
    # Joint 6 turns the wrist 3 housing on its own axis (and the tool, not a link here).
    assert motion_bound(model, q, np.array([0, 0, 0, 0, 0, 0.05]))[0].tolist() == [0.0] * 7
    wrist_2 = dict(zip(names, motion_bound(model, q, np.array([0, 0, 0, 0, 0.05, 0]))[0],
                       strict=True))
    assert [name for name, moved in wrist_2.items() if moved > 0] == ["wrist 3"]
    distances = axis_distances(model, q)[0]
    one_way = motion_bound(model, q, np.array([0.01, 0, 0, 0, 0, 0]))[0]
    np.testing.assert_allclose(one_way, 0.01 * distances[:, 0] / (1 - 0.01))


def test_a_step_of_a_radian_or_more_has_no_bound() -> None:
    model = arm_model(MODEL_NAMES[0])
    bound = motion_bound(model, np.zeros(6), np.array([0.5, 0.5, 0.0, 0.0, 0.0, 0.0]))[0]
    assert bound[0] < math.inf  # the shoulder turns with joint 1 alone
    assert np.isinf(bound[1:]).all()
