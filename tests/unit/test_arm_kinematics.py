"""The arm's model (src/handeye_pick/arm/): its forward kinematics against the simulated
controller's independent model for every ``robot.model``, its closed-form IK branches, and where
its link solids lie, property-based over random joint angles."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from handeye_pick.arm.ik import BRANCHES, branches, wrap
from handeye_pick.arm.kinematics import flange_poses, frames, link_poses, tcp_poses
from handeye_pick.arm.models import ALPHA_RAD, LINK_NAMES, MODEL_NAMES, arm_model
from handeye_pick.geometry import make_transform, rotation_from_rotvec
from mocks.ur_controller.kinematics import ALL_MODELS, URModel, elbow_position, forward

# UR20 and UR30 as Universal Robots' DH article gives them: d1, a2, a3, d4, d5, d6 (m). The
# simulator has no such arms, so the test builds them for its forward kinematics.
_LARGE = {
    "ur20": (0.2363, -0.8620, -0.7287, 0.2010, 0.1593, 0.1543),
    "ur30": (0.2363, -0.6370, -0.5037, 0.2010, 0.1593, 0.1543),
}
_LIMITS = (-2 * math.pi,) * 6, (2 * math.pi,) * 6


def _reference(name: str) -> URModel:
    """The simulator's model of ``name`` (its own tables and code)."""
    if name in ALL_MODELS:
        return ALL_MODELS[name]
    d1, a2, a3, d4, d5, d6 = _LARGE[name]
    return URModel(name, (d1, 0, 0, d4, d5, d6), (0, a2, a3, 0, 0, 0), ALPHA_RAD, 1.75, *_LIMITS)


EDGES = [0.0, 1e-9, -1e-9, math.pi - 1e-7, math.pi, -math.pi, 2 * math.pi]
angle = st.one_of(st.sampled_from(EDGES), st.floats(-2 * math.pi, 2 * math.pi))
joint_batches = arrays(np.float64, st.tuples(st.integers(1, 12), st.just(6)), elements=angle)


def test_every_model_the_config_names_has_its_published_kinematics() -> None:
    assert set(MODEL_NAMES) == {"ur3e", "ur5e", "ur10e", "ur16e", "ur20", "ur30", "ur3", "ur5",
                                "ur10"}
    for name, reference in ALL_MODELS.items():
        model = arm_model(name)
        assert model.d == reference.d, name
        assert model.a == reference.a, name
    assert [link.name for link in arm_model("ur5e").links] == list(LINK_NAMES)


@pytest.mark.parametrize("name", MODEL_NAMES)
@settings(max_examples=50)
@given(Q=joint_batches)
def test_forward_kinematics_equals_the_simulators_for_every_model(
    name: str, Q: np.ndarray
) -> None:
    model, reference = arm_model(name), _reference(name)
    ours = flange_poses(model, Q)
    for q, T in zip(Q, ours, strict=True):
        np.testing.assert_allclose(T, forward(reference, q), rtol=0, atol=1e-9)
    np.testing.assert_allclose(frames(model, Q)[:, 6], ours, rtol=0, atol=1e-12)


@given(Q=joint_batches, turns=arrays(np.int64, 6, elements=st.integers(-1, 1)),
       offset=arrays(np.float64, 6, elements=st.floats(-0.3, 0.3)))
def test_the_tcp_is_the_flange_with_its_offset_and_whole_turns_change_nothing(
    Q: np.ndarray, turns: np.ndarray, offset: np.ndarray
) -> None:
    model = arm_model("ur10e")
    T_flange_tcp = make_transform(rotation_from_rotvec(offset[3:]), offset[:3])
    tcp = tcp_poses(model, Q, T_flange_tcp)
    np.testing.assert_allclose(tcp, flange_poses(model, Q) @ T_flange_tcp, atol=1e-12)
    np.testing.assert_allclose(
        tcp_poses(model, Q + 2 * math.pi * turns, T_flange_tcp), tcp, atol=1e-9
    )
    solids = link_poses(model, Q)
    R = solids[..., :3, :3]
    np.testing.assert_allclose(R @ np.swapaxes(R, -1, -2), np.broadcast_to(np.eye(3), R.shape),
                               atol=1e-12)


@pytest.mark.parametrize("name", MODEL_NAMES)
@settings(max_examples=50)
@given(Q=joint_batches)
def test_one_ik_branch_is_the_arm_and_every_branch_reaches_the_pose(
    name: str, Q: np.ndarray
) -> None:
    model = arm_model(name)
    T = flange_poses(model, Q)
    solved = branches(model, T)
    assert solved.q.shape == (len(Q), BRANCHES, 6)
    for q, T_one, options, shoulder, wrist, elbow in zip(
        Q, T, solved.q, solved.shoulder_m, solved.wrist, solved.elbow, strict=True
    ):
        if min(shoulder, wrist.min(), np.nanmin(elbow, initial=np.inf)) < 1e-3:
            # At a singularity branches meet and q6 (or q4) is free; near one the angles are
            # ill-conditioned. Paths refuse far sooner (sin 2 deg, arm/path.py).
            continue
        reaching = options[~np.isnan(options).any(axis=1)]
        assert np.abs(wrap(reaching - q)).max(axis=1).min() < 1e-7
        for other in reaching:
            np.testing.assert_allclose(forward(_reference(name), other), T_one, atol=1e-9)


@pytest.mark.parametrize("name", MODEL_NAMES)
@settings(max_examples=30)
@given(q=arrays(np.float64, 6, elements=st.floats(-math.pi, math.pi)))
def test_the_tubes_run_between_the_joint_axes_at_their_sideways_offsets(
    name: str, q: np.ndarray
) -> None:
    """The upper arm from joint 2's axis to the elbow (joint 3's axis, the simulator's DH frame
    2 origin), the forearm from there to wrist 1 (joint 4's axis), each along its joint axes by
    its offset; the wrist 3 housing ends at the flange face."""
    model = arm_model(name)
    F = frames(model, q)[0]
    solids = dict(zip(LINK_NAMES, link_poses(model, q)[0], strict=True))

    def ends(link: str) -> tuple[np.ndarray, np.ndarray]:
        T, half = solids[link], model.link(link).length_m / 2.0
        return T[:3, 3] - half * T[:3, 2], T[:3, 3] + half * T[:3, 2]

    def on_axis(point: np.ndarray, frame: int) -> float:
        """The point's offset along frame ``frame``'s z from its origin, checked on the axis."""
        rel = point - F[frame][:3, 3]
        along = float(rel @ F[frame][:3, 2])
        np.testing.assert_allclose(rel, along * F[frame][:3, 2], atol=1e-9)
        return along

    elbow = elbow_position(_reference(name), q)
    np.testing.assert_allclose(F[2][:3, 3], elbow, atol=1e-9)
    elbow_end, shoulder_end = ends("upper arm")  # a tube's solid z points back up the arm
    shoulder_offset = on_axis(shoulder_end, 1)
    assert on_axis(elbow_end, 2) == pytest.approx(shoulder_offset, abs=1e-9)
    wrist_end, elbow_end = ends("forearm")
    elbow_offset = on_axis(wrist_end, 3)
    assert on_axis(elbow_end, 2) == pytest.approx(elbow_offset, abs=1e-9)
    assert 0.0 < elbow_offset < shoulder_offset
    np.testing.assert_allclose(ends("wrist 3")[1], F[6][:3, 3], atol=1e-9)
