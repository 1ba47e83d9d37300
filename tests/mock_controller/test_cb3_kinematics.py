"""The CB3 arms of the cb3 profile (UR3, UR5, UR10): UR's published DH rows, and the analytic IK
the e-Series arms use also inverts their forward kinematics."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray

from mocks.ur_controller.kinematics import CB3_MODELS, IK_TOLERANCE, forward, inverse, inverse_all

TWO_PI = 2.0 * math.pi
joint_vectors = st.lists(st.floats(-TWO_PI, TWO_PI), min_size=6, max_size=6).map(np.array)


@pytest.mark.parametrize(("name", "base_height_m", "upper_arm_m"),
                         [("ur3", 0.1519, 0.24365), ("ur5", 0.089159, 0.425),
                          ("ur10", 0.1273, 0.612)])
def test_published_dh_rows(name: str, base_height_m: float, upper_arm_m: float) -> None:
    model = CB3_MODELS[name]
    assert (model.d[0], -model.a[1]) == (base_height_m, upper_arm_m)


@settings(max_examples=100, deadline=None)
@given(name=st.sampled_from(sorted(CB3_MODELS)), q=joint_vectors)
def test_ik_reproduces_the_forward_pose_and_finds_q(name: str, q: NDArray[np.float64]) -> None:
    model = CB3_MODELS[name]
    T = forward(model, q)
    for solution in inverse_all(model, T):
        assert np.max(np.abs(forward(model, solution) - T)) <= IK_TOLERANCE
    # Away from the wrist, elbow and shoulder singularities the solution is isolated.
    assume(abs(math.sin(q[4])) > 1e-3 and abs(math.sin(q[2])) > 1e-3)
    wrist_centre = T[:3, 3] - model.d[5] * T[:3, 2]
    assume(abs(math.hypot(wrist_centre[0], wrist_centre[1]) - model.d[3]) > 1e-4)
    nearest = inverse(model, T, q)
    assert nearest is not None
    np.testing.assert_allclose(nearest, q, atol=1e-9)
