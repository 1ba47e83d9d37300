"""The hand-eye solver against synthetic data with a known truth: both modes, noise, OpenCV's
conventions, suspects, exclusion, and every refusal."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, reject, settings
from hypothesis import strategies as st
from numpy.typing import NDArray

from handeye_pick.calibration.rotation_spread import check_motion, motion_spread
from handeye_pick.calibration.solver import (
    OPENCV_METHODS,
    MeasurementNoise,
    opencv_hand_eye,
    robot_side,
    solve_hand_eye,
)
from handeye_pick.errors import CalibrationError
from handeye_pick.geometry import invert, ur_pose_to_matrix
from handeye_pick.hand_eye.files import HandEyeMode
from mocks.handeye_scene import NO_NOISE, Noise, make_scene, measure, wrong_pair
from tests.unit.handeye_helpers import MODES, NUMBERS, Captures, as_pairs, errors

T_FLANGE_CAM = ur_pose_to_matrix([0.04, -0.07, 0.09, 0.1, -0.15, 1.6])
T_BASE_OBJ = ur_pose_to_matrix([0.55, 0.05, 0.02, math.pi, 0.0, 0.3])


def stacks(captures: Captures, mode: HandEyeMode) -> tuple[NDArray[np.float64], ...]:
    A = robot_side(np.stack([a for a, _ in captures]), mode)
    return A, np.stack([b for _, b in captures])


def eye_in_hand_captures(robot_poses: list[NDArray[np.float64]]) -> Captures:
    """Exact T_cam_obj for each flange pose of an eye-in-hand cell (T_FLANGE_CAM, T_BASE_OBJ)."""
    return [(T, invert(T_FLANGE_CAM) @ invert(T) @ T_BASE_OBJ) for T in robot_poses]


# --- exact data: the truth comes back -------------------------------------------------------------


@settings(max_examples=6, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), mode=st.sampled_from(MODES), count=st.integers(4, 15))
def test_exact_data_gives_the_truth_and_zero_residuals(
    seed: int, mode: HandEyeMode, count: int
) -> None:
    rng = np.random.default_rng(seed)
    scene = make_scene(rng, mode.value, count)
    captures = measure(scene, rng, NO_NOISE)
    try:  # a few random views can all turn about one axis: refused by design, tested below
        check_motion(motion_spread(stacks(captures, mode)[0][:, :3, :3], list(range(count))))
    except CalibrationError:
        reject()
    result = solve_hand_eye(as_pairs(captures), mode)
    distance_mm, angle_deg = errors(result.fit.T_cal, scene.T_cal)
    assert distance_mm < 1e-6
    assert angle_deg < 1e-7
    assert result.fit.translation_max_mm < 1e-6
    assert result.fit.rotation_max_deg < 1e-7
    assert result.suspects == ()
    assert result.start_method in OPENCV_METHODS


@pytest.mark.parametrize("mode", MODES)
def test_every_opencv_method_follows_our_conventions(mode: HandEyeMode) -> None:
    # Eye-to-hand goes in as base2gripper (inverted robot poses) and comes out as T_base_cam.
    rng = np.random.default_rng(4)
    scene = make_scene(rng, mode.value, 8)
    A, B = stacks(measure(scene, rng, NO_NOISE), mode)
    for method in OPENCV_METHODS:
        distance_mm, angle_deg = errors(opencv_hand_eye(A, B, method), scene.T_cal)
        assert distance_mm < 1e-4, method
        assert angle_deg < 1e-5, method


def test_the_method_reaches_opencv() -> None:
    # Passed positionally, the method would be an output array and every result TSAI's.
    rng = np.random.default_rng(5)
    scene = make_scene(rng, "eye-in-hand", 10)
    A, B = stacks(measure(scene, rng, Noise()), HandEyeMode.EYE_IN_HAND)
    results = [opencv_hand_eye(A, B, method) for method in OPENCV_METHODS]
    tsai = results[0]
    assert all(np.max(np.abs(other - tsai)) > 1e-9 for other in results[1:])


# --- noise ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("mode", MODES)
def test_noisy_data_gives_the_truth_within_the_noise(mode: HandEyeMode) -> None:
    rng = np.random.default_rng(11)
    scene = make_scene(rng, mode.value, 15)
    result = solve_hand_eye(as_pairs(measure(scene, rng, Noise())), mode)
    distance_mm, angle_deg = errors(result.fit.T_cal, scene.T_cal)
    assert distance_mm < 0.5
    assert angle_deg < 0.05
    # Residuals show the noise: a few tenths of a mm, a few hundredths of a degree.
    assert 0.05 < result.fit.translation_mean_mm < 1.0
    assert 0.005 < result.fit.rotation_mean_deg < 0.1
    assert result.suspects == ()
    assert result.without_suspects is None
    assert result.warnings == ()
    assert [r.number for r in result.fit.residuals] == list(NUMBERS[:15])


def test_the_result_does_not_depend_on_the_order_of_the_pairs() -> None:
    rng = np.random.default_rng(12)
    scene = make_scene(rng, "eye-in-hand", 12)
    pairs = as_pairs(measure(scene, rng, Noise()))
    forward = solve_hand_eye(pairs, HandEyeMode.EYE_IN_HAND)
    backward = solve_hand_eye(pairs[::-1], HandEyeMode.EYE_IN_HAND)
    distance_mm, angle_deg = errors(forward.fit.T_cal, backward.fit.T_cal)
    assert distance_mm < 1e-4
    assert angle_deg < 1e-5


def test_the_stated_noise_must_be_positive() -> None:
    with pytest.raises(CalibrationError, match="camera_depth_mm must be > 0"):
        MeasurementNoise(camera_depth_mm=0.0)


# --- a wrongly paired sample ----------------------------------------------------------------------


@pytest.mark.parametrize("mode", MODES)
def test_a_wrongly_paired_sample_is_named_and_nothing_is_excluded_silently(
    mode: HandEyeMode,
) -> None:
    rng = np.random.default_rng(21)
    scene = make_scene(rng, mode.value, 12)
    pairs = as_pairs(wrong_pair(scene, rng, Noise(), 5))
    bad = NUMBERS[5]
    result = solve_hand_eye(pairs, mode)
    assert result.suspects == (bad,)
    # The result still uses every pair, and the wrong one drags it away from the truth.
    assert [r.number for r in result.fit.residuals] == list(NUMBERS[:12])
    assert errors(result.fit.T_cal, scene.T_cal)[0] > 5.0
    # What excluding it would give: the truth again.
    assert result.without_suspects is not None
    distance_mm, angle_deg = errors(result.without_suspects.T_cal, scene.T_cal)
    assert distance_mm < 0.5
    assert angle_deg < 0.05
    assert bad not in [r.number for r in result.without_suspects.residuals]


@pytest.mark.parametrize("mode", MODES)
def test_a_pair_half_a_turn_off_is_named(mode: HandEyeMode) -> None:
    # An object pose turned 179.9 deg about its normal (a symmetric board read the wrong way
    # round): its rotation residual sits at the rotation vector's wrap-around.
    rng = np.random.default_rng(25)
    scene = make_scene(rng, mode.value, 10)
    captures = measure(scene, rng, Noise())
    T_base_flange, T_cam_obj = captures[7]
    captures[7] = (T_base_flange, T_cam_obj @ ur_pose_to_matrix([0, 0, 0, 0, 0, 3.14]))
    result = solve_hand_eye(as_pairs(captures), mode)
    assert result.suspects == (NUMBERS[7],)
    assert result.without_suspects is not None
    assert errors(result.without_suspects.T_cal, scene.T_cal)[0] < 0.5


def test_excluding_the_wrong_pair_by_number() -> None:
    rng = np.random.default_rng(22)
    scene = make_scene(rng, "eye-to-hand", 12)
    pairs = as_pairs(wrong_pair(scene, rng, Noise(), 2))
    result = solve_hand_eye(pairs, HandEyeMode.EYE_TO_HAND, exclude={NUMBERS[2]})
    assert result.excluded == (NUMBERS[2],)
    assert NUMBERS[2] not in [r.number for r in result.fit.residuals]
    assert result.suspects == ()
    assert errors(result.fit.T_cal, scene.T_cal)[0] < 0.5


def test_excluding_a_pair_that_is_not_there_is_refused() -> None:
    rng = np.random.default_rng(23)
    pairs = as_pairs(measure(make_scene(rng, "eye-in-hand", 6), rng, Noise()))
    with pytest.raises(CalibrationError, match=r"cannot exclude pair\(s\) 4: the dataset has 3, 7"):
        solve_hand_eye(pairs, HandEyeMode.EYE_IN_HAND, exclude={4})


def test_suspects_that_cannot_be_excluded_say_why() -> None:
    rng = np.random.default_rng(1)
    scene = make_scene(rng, "eye-in-hand", 3)
    captures = measure(scene, rng, Noise())
    captures.append(wrong_pair(scene, rng, Noise(), 0)[0])  # the 4th pair is wrong
    result = solve_hand_eye(as_pairs(captures), HandEyeMode.EYE_IN_HAND)
    assert result.suspects == (NUMBERS[3],)
    assert result.without_suspects is None
    assert result.without_suspects_refusal == (
        "a hand-eye calibration needs at least 4 pairs, 3 left after excluding 1"
    )


# --- refusals and warnings ------------------------------------------------------------------------


def test_fewer_than_four_pairs_are_refused() -> None:
    rng = np.random.default_rng(31)
    pairs = as_pairs(measure(make_scene(rng, "eye-in-hand", 3), rng, NO_NOISE))
    with pytest.raises(CalibrationError, match="at least 4 pairs, 3 left"):
        solve_hand_eye(pairs, HandEyeMode.EYE_IN_HAND)


def test_exclusions_that_leave_fewer_than_four_pairs_are_refused() -> None:
    rng = np.random.default_rng(32)
    pairs = as_pairs(measure(make_scene(rng, "eye-to-hand", 5), rng, NO_NOISE))
    with pytest.raises(CalibrationError, match="at least 4 pairs, 3 left after excluding 2"):
        solve_hand_eye(pairs, HandEyeMode.EYE_TO_HAND, exclude={NUMBERS[0], NUMBERS[4]})


def test_rotations_too_small_are_refused() -> None:
    rng = np.random.default_rng(33)
    base = ur_pose_to_matrix([0.4, 0.1, 0.5, math.pi, 0.0, 0.0])
    robot = [
        base @ ur_pose_to_matrix([*rng.uniform(-0.1, 0.1, 3), *rng.uniform(-0.05, 0.05, 3)])
        for _ in range(10)
    ]  # at most about 10 deg between any two, usually less
    spread = motion_spread(np.stack([T[:3, :3] for T in robot]), list(range(10)))
    assert spread.largest_rotation_deg < 10.0
    with pytest.raises(CalibrationError, match="rotations too small"):
        solve_hand_eye(as_pairs(eye_in_hand_captures(robot)), HandEyeMode.EYE_IN_HAND)


def test_rotations_about_one_axis_are_refused() -> None:
    # Spinning only the last wrist joint: every relative rotation is about the flange's z.
    base = ur_pose_to_matrix([0.4, 0.1, 0.5, math.pi, 0.0, 0.0])
    robot = [
        base @ ur_pose_to_matrix([0.02 * i, -0.01 * i, 0.0, 0.0, 0.0, 0.4 * i]) for i in range(8)
    ]
    with pytest.raises(CalibrationError, match=r"nearly parallel axes.*within 0\.0 deg"):
        solve_hand_eye(as_pairs(eye_in_hand_captures(robot)), HandEyeMode.EYE_IN_HAND)


def test_weak_but_usable_motion_and_few_pairs_are_warned_about() -> None:
    base = ur_pose_to_matrix([0.4, 0.1, 0.5, math.pi, 0.0, 0.0])
    # Rotations of 12 deg about x, y and z: usable, but under the 30 deg guidance.
    tilts = [[0, 0, 0], [0.21, 0, 0], [0, 0.21, 0], [0, 0, 0.21], [0.1, 0.1, 0.0]]
    robot = [base @ ur_pose_to_matrix([0.03 * k, 0.02 * k, 0.0, *t]) for k, t in enumerate(tilts)]
    result = solve_hand_eye(as_pairs(eye_in_hand_captures(robot)), HandEyeMode.EYE_IN_HAND)
    assert errors(result.fit.T_cal, T_FLANGE_CAM)[0] < 1e-6
    text = " | ".join(result.warnings)
    assert "only 5 pairs" in text
    assert "largest rotation between two poses is" in text


def test_motion_checks_pass_for_a_varied_dataset() -> None:
    rng = np.random.default_rng(34)
    scene = make_scene(rng, "eye-in-hand", 12)
    A, _ = stacks(measure(scene, rng, NO_NOISE), HandEyeMode.EYE_IN_HAND)
    spread = motion_spread(A[:, :3, :3], list(NUMBERS[:12]))
    assert spread.largest_rotation_deg > 30.0
    assert spread.axis_spread_deg > 30.0
    assert set(spread.largest_rotation_between) <= set(NUMBERS[:12])
    assert check_motion(spread) == []
