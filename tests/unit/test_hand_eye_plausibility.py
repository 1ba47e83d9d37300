"""Plausibility of the camera chain: the shipped cells pass, an inverted file and a swapped mode
are refused naming the likely mistake, acknowledgement is per check."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from handeye_pick.config.load import load_config
from handeye_pick.config.schema import WorkspaceConfig
from handeye_pick.detection import detection_from_point_mm, load_detection
from handeye_pick.errors import InputError, SafetyRefusal
from handeye_pick.geometry import (
    Transform,
    compose,
    invert,
    make_transform,
    rotation_angle_between,
    rotation_from_rotvec,
    ur_pose_to_matrix,
)
from handeye_pick.hand_eye.files import (
    CELL_CONFIG,
    COMMAND_LINE,
    HandEyeCalibration,
    HandEyeMode,
    SettingNames,
    load_hand_eye,
)
from handeye_pick.hand_eye.plausibility import (
    CAMERA_POSITION_TOLERANCE_MM,
    CHECKS,
    MeasuredCamera,
    chain_problems,
    measured_position_problem,
    refuse_implausible,
)

ROOT = Path(__file__).resolve().parents[2]
DEMO = load_config(ROOT / "config" / "demo.yaml")
DEMO_DETECTION = load_detection(ROOT / "config" / "demo" / "detection.yaml")
# The simulated UR5e's home flange pose, where the demo detection was seen (m, rad).
DEMO_FLANGE = ur_pose_to_matrix([-0.4919, -0.1333, 0.4879, 2.221441, 2.221441, 0.0])
EXAMPLE = load_config(ROOT / "docs" / "plan-example.yaml")
# examples/table_box_camera_mm.npy at pixel (13, 8), as docs/make-plan-example.sh picks it.
EXAMPLE_POINT = detection_from_point_mm([168.16309, 24.023296, 1153.1183], "pixel 13 8")
EXAMPLE_FLANGE = ur_pose_to_matrix([0.35, -0.25, 0.45, 3.1416, 0.0, 0.0])


def _demo_calibration(mode: HandEyeMode, invert: bool) -> HandEyeCalibration:
    return load_hand_eye(DEMO.hand_eye.file, mode, "mm", invert, settings=CELL_CONFIG)


def _example_calibration(mode: HandEyeMode, invert: bool) -> HandEyeCalibration:
    return load_hand_eye(EXAMPLE.hand_eye.file, mode, "mm", invert, settings=CELL_CONFIG)


def _checks(*args: object) -> list[str]:
    return [problem.check for problem in chain_problems(*args)]  # type: ignore[arg-type]


def test_the_shipped_cells_pass() -> None:
    demo = _demo_calibration(HandEyeMode.EYE_IN_HAND, invert=False)
    assert chain_problems(demo, DEMO_FLANGE, DEMO_DETECTION.T_cam_obj, DEMO.workspace) == []
    example = _example_calibration(HandEyeMode.EYE_TO_HAND, invert=False)
    measured = EXAMPLE.hand_eye.camera_position
    assert measured is not None
    assert (
        chain_problems(example, None, EXAMPLE_POINT.T_cam_obj, EXAMPLE.workspace, measured=measured)
        == []
    )
    for name in ("EyeInHandTransform.yaml", "EyeInHandTransform_opencv_legacy.yaml"):
        eye_in_hand = load_hand_eye(ROOT / "config" / "calibration" / name, "eye-in-hand")  # type: ignore[arg-type]
        assert chain_problems(eye_in_hand, EXAMPLE_FLANGE, None, None) == []


def test_inverted_demo_file_is_refused_as_inverted() -> None:
    # The case: the inverted demo file ran the pick to an object 123 mm from the true one.
    right = _demo_calibration(HandEyeMode.EYE_IN_HAND, invert=False)
    wrong = _demo_calibration(HandEyeMode.EYE_IN_HAND, invert=True)
    T_cam_obj = DEMO_DETECTION.T_cam_obj
    miss = compose(DEMO_FLANGE, wrong.T_cal, T_cam_obj) - compose(
        DEMO_FLANGE, right.T_cal, T_cam_obj
    )
    assert np.linalg.norm(miss[:3, 3]) * 1000.0 == pytest.approx(123.2, abs=0.1)
    (problem,) = chain_problems(wrong, DEMO_FLANGE, T_cam_obj, DEMO.workspace)
    assert problem.check == "camera-in-front-of-flange"
    assert "59 mm behind the flange face" in problem.message
    assert "looks inverted (hand_eye.invert: false)" in problem.message


def test_swapped_modes_are_refused_naming_the_other_mode() -> None:
    demo_as_fixed = _demo_calibration(HandEyeMode.EYE_TO_HAND, invert=False)
    problems = chain_problems(demo_as_fixed, None, DEMO_DETECTION.T_cam_obj, DEMO.workspace)
    assert [p.check for p in problems] == ["camera-away-from-base"]
    assert "looks like an eye-in-hand file" in problems[0].message
    assert "hand_eye.mode: eye-in-hand" in problems[0].message
    fixed_on_arm = _example_calibration(HandEyeMode.EYE_IN_HAND, invert=False)
    problems = chain_problems(fixed_on_arm, EXAMPLE_FLANGE, EXAMPLE_POINT.T_cam_obj, None)
    assert [p.check for p in problems][:2] == ["camera-near-flange", "camera-looks-along-tool"]
    assert "1347 mm from the flange" in problems[0].message
    assert "looks like an eye-to-hand file" in problems[0].message
    assert "hand_eye.mode: eye-to-hand" in problems[0].message


@pytest.mark.parametrize("invert_file", [False, True])
def test_swapped_mode_is_refused_whichever_way_the_file_is_written(invert_file: bool) -> None:
    demo = _demo_calibration(HandEyeMode.EYE_TO_HAND, invert=invert_file)
    assert "camera-away-from-base" in _checks(demo, None, None, DEMO.workspace)
    example = _example_calibration(HandEyeMode.EYE_IN_HAND, invert=invert_file)
    assert "camera-near-flange" in _checks(example, EXAMPLE_FLANGE, None, None)


def _look_at(eye_mm: np.ndarray, target_mm: np.ndarray, roll_rad: float) -> Transform:
    """T_base_cam of a camera at ``eye_mm`` whose optical axis (z) points at ``target_mm``."""
    z = (target_mm - eye_mm) / np.linalg.norm(target_mm - eye_mm)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[2]) > 0.9 else np.array([0.0, 0.0, 1.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    R = np.column_stack([x, np.cross(z, x), z]) @ rotation_from_rotvec([0.0, 0.0, roll_rad])
    return make_transform(R, eye_mm / 1000.0)


def _calibration(
    mode: HandEyeMode,
    T_cal: Transform,
    inverted: bool = False,
    settings: SettingNames = COMMAND_LINE,
) -> HandEyeCalibration:
    return HandEyeCalibration(mode, T_cal, Path("cal.yaml"), "", "mm", inverted, settings)


def _measured(position_mm: np.ndarray, tolerance_mm: float = 100.0) -> MeasuredCamera:
    x, y, z = (float(v) for v in position_mm)
    return MeasuredCamera((x, y, z), tolerance_mm)


@settings(deadline=None)  # no timing assertion on a shared machine
@given(
    height_mm=st.floats(50.0, 180.0),
    side_mm=st.floats(0.0, 50.0),
    side_angle=st.floats(0.0, 2 * math.pi),
    tilt_deg=st.floats(0.0, 30.0),
    tilt_angle=st.floats(0.0, 2 * math.pi),
    roll=st.floats(-math.pi, math.pi),
)
def test_any_usual_wrist_camera_passes_and_its_inverse_or_other_mode_is_refused(
    height_mm: float,
    side_mm: float,
    side_angle: float,
    tilt_deg: float,
    tilt_angle: float,
    roll: float,
) -> None:
    # A wrist camera 50-180 mm in front of the flange, at most 50 mm off the tool axis, its
    # optical axis within 30 degrees of the tool axis, any roll about it.
    t = np.array([side_mm * math.cos(side_angle), side_mm * math.sin(side_angle), height_mm])
    tilt_axis = np.array([math.cos(tilt_angle), math.sin(tilt_angle), 0.0])
    R = rotation_from_rotvec(tilt_axis * math.radians(tilt_deg)) @ rotation_from_rotvec(
        [0.0, 0.0, roll]
    )
    T_flange_cam = make_transform(R, t / 1000.0)
    assert _checks(_calibration(HandEyeMode.EYE_IN_HAND, T_flange_cam), None, None, None) == []
    inverted = _calibration(HandEyeMode.EYE_IN_HAND, invert(T_flange_cam), inverted=True)
    assert _checks(inverted, None, None, None) == ["camera-in-front-of-flange"]
    as_fixed = _calibration(HandEyeMode.EYE_TO_HAND, T_flange_cam)
    assert "camera-away-from-base" in _checks(as_fixed, None, None, DEMO.workspace)


WORKSPACE = WorkspaceConfig(min_mm=(-800, -800, 0), max_mm=(800, 800, 700), max_tilt_deg=30)


@settings(deadline=None)
@given(
    height_mm=st.floats(800.0, 2000.0),
    reach_mm=st.floats(0.0, 1500.0),
    azimuth=st.floats(0.0, 2 * math.pi),
    target_mm=st.tuples(st.floats(-700, 700), st.floats(-700, 700), st.floats(0, 100)),
    roll=st.floats(-math.pi, math.pi),
)
def test_any_fixed_camera_looking_at_the_workspace_passes_and_used_on_the_arm_is_refused(
    height_mm: float,
    reach_mm: float,
    azimuth: float,
    target_mm: tuple[float, float, float],
    roll: float,
) -> None:
    eye = np.array([reach_mm * math.cos(azimuth), reach_mm * math.sin(azimuth), height_mm])
    T_base_cam = _look_at(eye, np.array(target_mm), roll)
    fixed = _calibration(HandEyeMode.EYE_TO_HAND, T_base_cam)
    assert chain_problems(fixed, None, None, WORKSPACE, measured=_measured(eye)) == []
    on_arm = _calibration(HandEyeMode.EYE_IN_HAND, T_base_cam)
    assert _checks(on_arm, None, None, None)[:2] == [
        "camera-near-flange",
        "camera-looks-along-tool",
    ]


def test_an_inverted_tilted_fixed_camera_looks_away_from_the_workspace() -> None:
    T_base_cam = _look_at(np.array([1300.0, 100.0, 900.0]), np.array([500.0, 100.0, 200.0]), 0.0)
    assert _checks(_calibration(HandEyeMode.EYE_TO_HAND, T_base_cam), None, None, WORKSPACE) == []
    inverted = _calibration(HandEyeMode.EYE_TO_HAND, invert(T_base_cam), inverted=True)
    (problem,) = chain_problems(inverted, None, None, WORKSPACE)
    assert problem.check == "camera-looks-at-workspace"
    assert "looks inverted (drop --invert)" in problem.message


def test_a_fixed_camera_below_the_floor_is_refused() -> None:
    T_base_cam = _look_at(np.array([600.0, 0.0, -300.0]), np.array([600.0, 0.0, 500.0]), 0.0)
    problems = chain_problems(_calibration(HandEyeMode.EYE_TO_HAND, T_base_cam), None, None, None)
    assert [p.check for p in problems] == ["camera-above-floor"]
    assert "300 mm below the robot base plane" in problems[0].message
    assert "looks inverted (add --invert)" in problems[0].message
    # With a workspace the floor is the box's: a camera on a low table is still above it.
    table = WorkspaceConfig(min_mm=(-800, -800, -400), max_mm=(800, 800, 700), max_tilt_deg=30)
    low = _calibration(HandEyeMode.EYE_TO_HAND, T_base_cam)
    measured = _measured(np.array([600.0, 0.0, -300.0]))
    assert chain_problems(low, None, None, table, measured=measured) == []


# The cell: a camera 1.2 m above the base plane looking straight down (T_base_cam). Its
# inverse is a camera at (100, 450, 1200) mm looking straight down, mirrored about the vertical
# plane through the base origin at 45 degrees: both look at the workspace, and every pick with
# the wrong one lands 778 mm off.
STRAIGHT_DOWN = make_transform([[0, 1, 0], [1, 0, 0], [0, 0, -1]], [-0.45, -0.1, 1.2])
STRAIGHT_DOWN_TAPED = np.array([-430.0, -120.0, 1180.0])  # 35 mm off: the body, not the optics


def _straight_down(invert_file: bool) -> HandEyeCalibration:
    """The straight-down camera's calibration from a cell config: ``invert_file`` (the file holds
    the inverse) and the inverse set wrongly, or both right."""
    T_file = invert(STRAIGHT_DOWN) if invert_file else STRAIGHT_DOWN
    return _calibration(HandEyeMode.EYE_TO_HAND, T_file, inverted=False, settings=CELL_CONFIG)


@pytest.mark.parametrize("invert_file", [False, True])
def test_a_straight_down_camera_without_a_measured_position_is_refused(invert_file: bool) -> None:
    (problem,) = chain_problems(_straight_down(invert_file), None, None, WORKSPACE)
    assert problem.check == "camera-position-measured"
    assert "cannot be told from its inverse" in problem.message
    mirrored = "[100, 450, 1200]" if not invert_file else "[-450, -100, 1200]"
    assert f"its inverse (hand_eye.invert: true) at {mirrored} mm" in problem.message
    assert "778 mm apart" in problem.message
    assert problem.message.endswith("set hand_eye.camera_position_mm (robot base frame, mm)")


def test_a_measured_position_tells_the_straight_down_file_from_its_inverse() -> None:
    taped = _measured(STRAIGHT_DOWN_TAPED)
    assert chain_problems(_straight_down(False), None, None, WORKSPACE, measured=taped) == []
    (problem,) = chain_problems(_straight_down(True), None, None, WORKSPACE, measured=taped)
    assert problem.check == "camera-at-measured-position"
    assert problem.message.startswith(
        "the calibration puts the camera at [100, 450, 1200] mm in the robot base frame, 779 mm "
        "from its measured position [-430, -120, 1180] mm (hand_eye.camera_position_mm, "
        "tolerance 100 mm); the inverse file puts it 35 mm from there"
    )
    assert problem.message.endswith("looks inverted (hand_eye.invert: true)")
    # Without a workspace (point, cloud) only the measured position catches it.
    assert _checks(_straight_down(True), None, None, None) == []
    problems = chain_problems(_straight_down(True), None, None, None, measured=taped)
    assert [p.check for p in problems] == ["camera-at-measured-position"]


def test_a_measured_position_that_fits_neither_way_blames_file_mode_or_measurement() -> None:
    elsewhere = _measured(np.array([450.0, -100.0, 1200.0]), tolerance_mm=50.0)
    (problem,) = chain_problems(_straight_down(False), None, None, WORKSPACE, measured=elsewhere)
    assert problem.check == "camera-at-measured-position"
    assert "900 mm from its measured position [450, -100, 1200] mm" in problem.message
    assert "tolerance 50 mm" in problem.message
    assert "the file, its mode (hand_eye.mode) or the measured position is wrong" in problem.message
    # A wrist camera's file used as a fixed one fails here as well as on its distance.
    demo_as_fixed = _demo_calibration(HandEyeMode.EYE_TO_HAND, invert=False)
    problems = chain_problems(
        demo_as_fixed, None, None, WORKSPACE, measured=_measured(STRAIGHT_DOWN_TAPED)
    )
    assert [p.check for p in problems] == ["camera-away-from-base", "camera-at-measured-position"]


def test_a_wrist_camera_is_checked_against_its_measured_position_in_the_flange_frame() -> None:
    taped = _measured(np.array([0.0, -70.0, 60.0]), tolerance_mm=20.0)
    right = _demo_calibration(HandEyeMode.EYE_IN_HAND, invert=False)
    assert chain_problems(right, DEMO_FLANGE, None, None, measured=taped) == []
    wrong = _demo_calibration(HandEyeMode.EYE_IN_HAND, invert=True)
    problems = chain_problems(wrong, DEMO_FLANGE, None, None, measured=taped)
    assert [p.check for p in problems] == [
        "camera-in-front-of-flange",
        "camera-at-measured-position",
    ]
    assert "in the flange frame" in problems[1].message
    assert problems[1].message.endswith("looks inverted (hand_eye.invert: false)")


def test_a_straight_down_camera_that_is_its_own_inverse_is_not_refused() -> None:
    # Half a turn about x, camera over the x = 0 plane: inv(T) == T, nothing to tell apart.
    T_base_cam = make_transform([[1, 0, 0], [0, -1, 0], [0, 0, -1]], [0.0, 0.6, 1.2])
    np.testing.assert_allclose(invert(T_base_cam), T_base_cam, atol=1e-15)
    assert _checks(_calibration(HandEyeMode.EYE_TO_HAND, T_base_cam), None, None, WORKSPACE) == []


@pytest.mark.parametrize(
    ("mode", "position_mm", "problem"),
    [
        (HandEyeMode.EYE_TO_HAND, (500.0, -40.0, 1250.0), None),
        (HandEyeMode.EYE_IN_HAND, (0.0, -75.0, 55.0), None),
        (HandEyeMode.EYE_TO_HAND, (0.5, -0.04, 1.25), "base is 1.34689 mm, expected 50 to"),
        (HandEyeMode.EYE_IN_HAND, (0.0, 0.0, 2500.0), "from the flange is 2500 mm"),
        (HandEyeMode.EYE_IN_HAND, (0.0, math.inf, 55.0), "expected 3 finite numbers"),
        (HandEyeMode.EYE_IN_HAND, (0.0, 55.0), "expected 3 finite numbers"),
    ],
)
def test_measured_positions_are_checked_for_range_and_unit(
    mode: HandEyeMode, position_mm: tuple[float, ...], problem: str | None
) -> None:
    found = measured_position_problem(mode, position_mm)
    if problem is None:
        assert found is None
    else:
        assert found is not None
        assert problem in found


@settings(deadline=None)
@given(
    eye_xy_mm=st.tuples(st.floats(-700, 700), st.floats(-700, 700)),
    height_mm=st.floats(800.0, 2000.0),
    look_xy_mm=st.tuples(st.floats(-100, 100), st.floats(-100, 100)),
    roll=st.floats(-math.pi, math.pi),
    tape_direction=st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1)),
    tape_error=st.floats(0.0, 0.99),  # within the tolerance, clear of rounding at its edge
)
def test_an_inverted_straight_down_camera_is_refused_or_indistinguishable(
    eye_xy_mm: tuple[float, float],
    height_mm: float,
    look_xy_mm: tuple[float, float],
    roll: float,
    tape_direction: tuple[float, float, float],
    tape_error: float,
) -> None:
    # A fixed camera 0.8 to 2 m up, looking at the table at most 100 mm beside the point below
    # it (7 degrees or less from straight down), any roll.
    eye = np.array([*eye_xy_mm, height_mm])
    T_base_cam = _look_at(eye, np.array([*np.add(eye_xy_mm, look_xy_mm), 0.0]), roll)
    T_inverse = invert(T_base_cam)
    right = _calibration(HandEyeMode.EYE_TO_HAND, T_base_cam)
    wrong = _calibration(HandEyeMode.EYE_TO_HAND, T_inverse, inverted=True)
    right_checks = _checks(right, None, None, WORKSPACE)
    wrong_checks = _checks(wrong, None, None, WORKSPACE)
    assert right_checks in ([], ["camera-position-measured"])
    # Both or neither: each is the other's inverse.
    assert ("camera-position-measured" in wrong_checks) == bool(right_checks)
    apart_mm = float(np.linalg.norm(T_inverse[:3, 3] - T_base_cam[:3, 3])) * 1000.0
    if apart_mm > CAMERA_POSITION_TOLERANCE_MM:
        assert wrong_checks != []
    else:  # the documented limit: never told apart, and the rotations differ this little
        bound = 4.0 * math.asin(apart_mm / (2.0 * float(np.linalg.norm(eye))))
        assert rotation_angle_between(T_base_cam[:3, :3], T_inverse[:3, :3]) <= bound + 1e-9
    # A tape measure within the tolerance: the right file passes, the inverse is refused as
    # inverted unless its camera lies within the tolerance of the tape as well.
    direction = np.array(tape_direction)
    length = float(np.linalg.norm(direction))
    offset = direction / length * tape_error * CAMERA_POSITION_TOLERANCE_MM if length > 0 else 0
    taped = _measured(eye + offset)
    assert chain_problems(right, None, None, WORKSPACE, measured=taped) == []
    problems = chain_problems(wrong, None, None, WORKSPACE, measured=taped)
    at_tape = [p for p in problems if p.check == "camera-at-measured-position"]
    if at_tape:
        assert at_tape[0].message.endswith("looks inverted (drop --invert)")
    else:
        wrong_mm = T_inverse[:3, 3] * 1000.0
        assert np.linalg.norm(wrong_mm - eye - offset) <= CAMERA_POSITION_TOLERANCE_MM
    assert "camera-position-measured" not in [p.check for p in problems]


def test_each_new_check_can_be_acknowledged_and_is_still_reported() -> None:
    for measured, check in [
        (None, "camera-position-measured"),
        (_measured(STRAIGHT_DOWN_TAPED), "camera-at-measured-position"),
    ]:
        wrong = _straight_down(True)
        refused = chain_problems(wrong, None, None, WORKSPACE, measured=measured)
        with pytest.raises(SafetyRefusal, match=f"{check}: .* acknowledge the check: "
                           f"hand_eye.acknowledge: \\[{check}\\]"):  # fmt: skip
            refuse_implausible(refused, CELL_CONFIG, SafetyRefusal)
        problems = chain_problems(wrong, None, None, WORKSPACE, [check], measured=measured)
        assert [(p.check, p.acknowledged) for p in problems] == [(check, True)]
        refuse_implausible(problems, CELL_CONFIG, SafetyRefusal)  # reported, not refused


@pytest.mark.parametrize(
    ("p_cam_mm", "check"),
    [
        ([3.0, 2.0, 30.0], "object-in-camera-range"),  # cm typed as mm
        ([0.0, 0.0, 6000.0], "object-in-camera-range"),
        ([0.0, 1500.0, 3000.0], "object-within-reach"),
    ],
)
def test_objects_no_camera_or_arm_could_use_are_refused(p_cam_mm: list[float], check: str) -> None:
    example = _example_calibration(HandEyeMode.EYE_TO_HAND, invert=False)
    T_cam_obj = detection_from_point_mm(p_cam_mm, "--xyz").T_cam_obj
    assert check in _checks(example, None, T_cam_obj, None)


def test_the_object_reach_check_needs_the_flange_pose_for_a_wrist_camera() -> None:
    demo = _demo_calibration(HandEyeMode.EYE_IN_HAND, invert=False)
    T_far = ur_pose_to_matrix([0.0, 2.5, 0.5, math.pi, 0.0, 0.0])  # not a UR flange pose
    assert _checks(demo, T_far, DEMO_DETECTION.T_cam_obj, None) == ["object-within-reach"]
    assert _checks(demo, None, DEMO_DETECTION.T_cam_obj, None) == []


@pytest.mark.parametrize(
    ("names", "how"),
    [
        (CELL_CONFIG, "hand_eye.acknowledge: [camera-in-front-of-flange]"),
        (COMMAND_LINE, "--acknowledge camera-in-front-of-flange)"),
    ],
)
def test_refusal_is_one_line_naming_the_check_and_how_to_acknowledge_it(
    names: SettingNames, how: str
) -> None:
    wrong = load_hand_eye(DEMO.hand_eye.file, HandEyeMode.EYE_IN_HAND, invert=True, settings=names)
    problems = chain_problems(wrong, DEMO_FLANGE, None, None)
    with pytest.raises(SafetyRefusal) as info:
        refuse_implausible(problems, names, SafetyRefusal)
    message = str(info.value)
    assert message.startswith("implausible camera chain: camera-in-front-of-flange: the camera")
    assert how in message
    assert "\n" not in message


def test_acknowledging_one_check_lets_only_that_one_through() -> None:
    wrong = _demo_calibration(HandEyeMode.EYE_IN_HAND, invert=True)
    acknowledged = chain_problems(wrong, DEMO_FLANGE, None, None, ["camera-in-front-of-flange"])
    assert [(p.check, p.acknowledged) for p in acknowledged] == [
        ("camera-in-front-of-flange", True)
    ]
    refuse_implausible(acknowledged, CELL_CONFIG, InputError)  # reported, not refused
    other = chain_problems(wrong, DEMO_FLANGE, None, None, ["camera-looks-along-tool"])
    with pytest.raises(InputError, match="camera-in-front-of-flange"):
        refuse_implausible(other, CELL_CONFIG, InputError)
    with pytest.raises(ValueError, match="unknown plausibility checks"):
        chain_problems(wrong, DEMO_FLANGE, None, None, ["everything"])


def test_check_names_are_the_documented_ones() -> None:
    import handeye_pick.hand_eye.plausibility as module

    assert module.__doc__ is not None
    for check in CHECKS:
        assert f"``{check}``" in module.__doc__
