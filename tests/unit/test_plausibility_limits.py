"""The plausibility checks at their limits: each limit itself passes and the first step beyond
it is refused, and each refusal names its likely mistake in the user's own setting. Positions
here are exact in binary (0.5 m, 2 m, ...), so a limit is met exactly, not to rounding."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from handeye_pick.config.schema import WorkspaceConfig
from handeye_pick.errors import InputError
from handeye_pick.geometry import Transform, make_transform
from handeye_pick.hand_eye.files import (
    CELL_CONFIG,
    COMMAND_LINE,
    HandEyeCalibration,
    HandEyeMode,
    SettingNames,
)
from handeye_pick.hand_eye.plausibility import (
    MeasuredCamera,
    Problem,
    chain_problems,
    measured_position_problem,
    refuse_implausible,
)

IN_HAND, TO_HAND = HandEyeMode.EYE_IN_HAND, HandEyeMode.EYE_TO_HAND
DOWN = np.diag([1.0, -1.0, -1.0])  # optical axis along base -z
# Grown by the 100 mm view margin: x, y -500 to 500, z -100 to 700 (mm)
BOX = WorkspaceConfig(
    min_mm=(-400.0, -400.0, 0.0), max_mm=(400.0, 400.0, 600.0), max_tilt_deg=90.0
)


def _calibration(
    mode: HandEyeMode, R: np.ndarray, t_m: list[float], settings: SettingNames = CELL_CONFIG
) -> HandEyeCalibration:
    T_cal = make_transform(R, t_m)
    T_cal.flags.writeable = False
    return HandEyeCalibration(mode, T_cal, Path("he.yaml"), "0" * 64, "mm", False, settings)


def _found(
    calibration: HandEyeCalibration,
    workspace: WorkspaceConfig | None = None,
    T_cam_obj: Transform | None = None,
    measured: MeasuredCamera | None = None,
) -> dict[str, str]:
    flange = np.eye(4) if calibration.mode is IN_HAND else None
    problems = chain_problems(calibration, flange, T_cam_obj, workspace, measured=measured)
    return {problem.check: problem.message for problem in problems}


def _axis_at(z: float) -> np.ndarray:
    """A rotation whose optical axis (third column) has base z ``z`` (may leave [-1, 1] by a
    rounding's width, as a product of rotations can)."""
    R = np.eye(3)
    R[2, 2] = z
    return R


def test_eye_in_hand_limits_pass_at_the_limit_and_refuse_beyond() -> None:
    assert _found(_calibration(IN_HAND, np.eye(3), [0.0, 0.5, 0.0])) == {}  # 500 mm away
    far = _found(_calibration(IN_HAND, np.eye(3), [0.0, 0.5, 0.001]))
    assert list(far) == ["camera-near-flange"]
    assert "eye-to-hand file (T_base_cam); for a camera fixed in the cell set " in (
        far["camera-near-flange"]
    )
    assert far["camera-near-flange"].endswith("hand_eye.mode: eye-to-hand")
    assert _found(_calibration(IN_HAND, np.eye(3), [0.0, 0.0, -0.01])) == {}  # 10 mm behind
    behind = _found(_calibration(IN_HAND, np.eye(3), [0.0, 0.0, -0.015625]))  # 15.6 mm
    assert list(behind) == ["camera-in-front-of-flange"]
    assert "16 mm behind the flange face" in behind["camera-in-front-of-flange"]
    # Looking square to the tool axis is the limit; a hair back into the wrist is beyond it.
    assert _found(_calibration(IN_HAND, _axis_at(0.0), [0.0, 0.0, 0.0625])) == {}
    back = _found(_calibration(IN_HAND, _axis_at(-1e-6), [0.0, 0.0, 0.0625]))
    assert list(back) == ["camera-looks-along-tool"]
    message = back["camera-looks-along-tool"]
    assert "back into the wrist: this looks like an eye-to-hand file (T_base_cam) " in message
    assert "(hand_eye.mode: eye-to-hand) or a camera frame that is not the optical one " in message
    assert message.endswith("(z out of the lens)")


def test_an_optical_axis_a_rounding_beyond_the_unit_length_is_measured_not_a_crash() -> None:
    along = _found(_calibration(IN_HAND, _axis_at(1.0 + 1e-12), [0.0, 0.0, 0.0625]))
    assert along == {}
    back = _found(_calibration(IN_HAND, _axis_at(-1.0 - 1e-12), [0.0, 0.0, 0.0625]))
    assert "looks 180 deg away from the tool axis" in back["camera-looks-along-tool"]


def test_eye_to_hand_limits_pass_at_the_limit_and_refuse_beyond() -> None:
    assert _found(_calibration(TO_HAND, DOWN, [0.0, 0.0, 0.2])) == {}  # 200 mm from the base
    inside = _found(_calibration(TO_HAND, DOWN, [0.0, 0.0, 0.1875]))
    assert list(inside) == ["camera-away-from-base"]
    assert "eye-in-hand file (T_flange_cam); for a camera on the arm set hand_eye.mode: " in (
        inside["camera-away-from-base"]
    )
    # On the workspace floor (z 0) is the limit; a millimetre below it is refused.
    at_floor = _found(_calibration(TO_HAND, np.eye(3), [0.0, 0.5, 0.0]), BOX)
    assert "camera-above-floor" not in at_floor
    below = _found(_calibration(TO_HAND, np.eye(3), [0.0, 0.5, -0.0009765625]), BOX)
    assert list(below) == ["camera-above-floor"]
    assert "1 mm below the workspace floor (z = 0 mm)" in below["camera-above-floor"]
    assert "or is an eye-in-hand file" in below["camera-above-floor"]


@pytest.mark.parametrize(
    ("x_m", "sees"),
    [(-0.5, True), (0.5, True), (-0.5078125, False), (0.5078125, False)],
)
def test_a_camera_looking_straight_down_sees_the_box_grown_by_the_margin_to_its_edge(
    x_m: float, sees: bool
) -> None:
    """On the grown box's edge (x +-500 mm) it sees it; 7.8 mm outside it does not."""
    found = _found(_calibration(TO_HAND, DOWN, [x_m, 0.0, 1.0]), BOX)
    assert ("camera-looks-at-workspace" not in found) is sees
    if not sees:
        message = found["camera-looks-at-workspace"]
        assert "misses the workspace box (grown by 100 mm)" in message
        assert message.endswith("or the box or the file is wrong")


def test_a_camera_inside_the_grown_box_looking_out_sees_it_and_a_grazing_axis_meets_it() -> None:
    # Half a millimetre inside the grown box's top (700 mm), looking straight up
    up = _calibration(TO_HAND, np.eye(3), [0.0, 0.5, 0.6995])
    assert "camera-looks-at-workspace" not in _found(up, BOX)
    # Level at z 300 mm, looking along (1, 1, 0) past the grown box's corner (-500, 500): the
    # axis touches the box at that corner and nowhere else.
    a = np.sqrt(0.5)
    R = np.array([[0.0, a, a], [0.0, -a, a], [1.0, 0.0, 0.0]])
    grazing = _calibration(TO_HAND, R, [-0.6, 0.4, 0.3])
    assert "camera-looks-at-workspace" not in _found(grazing, BOX)
    past = _calibration(TO_HAND, R, [-0.6, 0.404296875, 0.3])  # 4.3 mm farther: it misses
    assert "camera-looks-at-workspace" in _found(past, BOX)


def test_the_measured_position_holds_to_its_tolerance_and_a_nearby_inverse_is_named() -> None:
    calibration = _calibration(TO_HAND, DOWN, [0.5, 0.0, 1.0])
    at_tolerance = MeasuredCamera((600.0, 0.0, 1000.0), tolerance_mm=100.0)
    assert "camera-at-measured-position" not in _found(calibration, BOX, measured=at_tolerance)
    beyond = MeasuredCamera((600.0, 0.0, 1000.0), tolerance_mm=99.5)
    assert "camera-at-measured-position" in _found(calibration, BOX, measured=beyond)
    # The inverse of this file puts the camera at (-500, 0, 1000): 100 mm from a measurement at
    # (-400, 0, 1000), exactly the tolerance, so the file looks inverted.
    near_inverse = MeasuredCamera((-400.0, 0.0, 1000.0), tolerance_mm=100.0)
    message = _found(calibration, BOX, measured=near_inverse)["camera-at-measured-position"]
    assert "the inverse file puts it 100 mm from there: the calibration looks inverted" in message


@pytest.mark.parametrize(
    ("mode", "distance_mm", "fits"),
    [(IN_HAND, 1.0, True), (IN_HAND, 2000.0, True), (IN_HAND, 2000.5, False),
     (IN_HAND, 0.5, False), (TO_HAND, 50.0, True), (TO_HAND, 10000.0, True),
     (TO_HAND, 10005.0, False)],
)
def test_a_measured_position_is_in_mm_within_the_file_checks_range(
    mode: HandEyeMode, distance_mm: float, fits: bool
) -> None:
    problem = measured_position_problem(mode, (0.0, distance_mm, 0.0))
    assert (problem is None) is fits
    if problem is not None:
        assert problem.endswith("(this is in mm: metres given?)")


@pytest.mark.parametrize(
    ("distance_m", "in_range"),
    [(0.05, True), (5.0, True), (0.0478515625, False), (5.0078125, False)],
)
def test_an_object_is_within_the_cameras_range_to_its_limits(
    distance_m: float, in_range: bool
) -> None:
    calibration = _calibration(TO_HAND, np.eye(3), [0.0, 0.0, 0.25])
    found = _found(calibration, T_cam_obj=make_transform(np.eye(3), [0.0, 0.0, distance_m]))
    assert ("object-in-camera-range" not in found) is in_range
    if not in_range:
        assert found["object-in-camera-range"].endswith("given as mm, or a wrong detection")


def test_an_object_at_2000_mm_from_the_base_is_within_reach_one_beyond_is_not() -> None:
    calibration = _calibration(TO_HAND, np.eye(3), [0.0, 0.0, 0.25])
    reach = make_transform(np.eye(3), [0.0, 0.0, 1.75])  # 2000 mm from the base
    assert "object-within-reach" not in _found(calibration, T_cam_obj=reach)
    beyond = make_transform(np.eye(3), [0.0, 0.0, 1.7578125])
    assert "object-within-reach" in _found(calibration, T_cam_obj=beyond)


@pytest.mark.parametrize(
    ("settings", "how"),
    [
        (COMMAND_LINE, "--acknowledge camera-near-flange --acknowledge camera-looks-along-tool"),
        (CELL_CONFIG, "hand_eye.acknowledge: [camera-near-flange, camera-looks-along-tool]"),
    ],
)
def test_a_refusal_lists_every_problem_and_how_to_acknowledge_each(
    settings: SettingNames, how: str
) -> None:
    problems = [
        Problem("camera-near-flange", "far", acknowledged=False),
        Problem("camera-in-front-of-flange", "behind", acknowledged=True),
        Problem("camera-looks-along-tool", "back", acknowledged=False),
    ]
    with pytest.raises(InputError) as refused:
        refuse_implausible(problems, settings, InputError)
    assert str(refused.value) == (
        "implausible camera chain: camera-near-flange: far; camera-looks-along-tool: back "
        f"(if the mount really is unusual, acknowledge the check: {how})"
    )


def test_an_unknown_acknowledged_check_is_refused_with_the_known_ones_listed() -> None:
    calibration = _calibration(IN_HAND, np.eye(3), [0.0, 0.0, 0.0625])
    with pytest.raises(ValueError, match="unknown plausibility checks") as refused:
        chain_problems(calibration, np.eye(4), None, None, ["camera-upside-down"])
    assert str(refused.value).endswith(
        "known: camera-near-flange, camera-in-front-of-flange, camera-looks-along-tool, "
        "camera-away-from-base, camera-above-floor, camera-looks-at-workspace, "
        "camera-at-measured-position, camera-position-measured, object-in-camera-range, "
        "object-within-reach"
    )


def test_a_straight_down_camera_is_told_from_its_inverse_only_beyond_the_tolerance() -> None:
    """Its inverse is the camera mirrored to -x: 100 mm apart (the tolerance) they count as the
    same camera; 125 mm apart the file cannot be told from its inverse without a measurement."""
    same = _calibration(TO_HAND, DOWN, [0.05, 0.25, 1.0])
    assert _found(same, BOX) == {}
    apart = _found(_calibration(TO_HAND, DOWN, [0.0625, 0.25, 1.0]), BOX)
    assert list(apart) == ["camera-position-measured"]
    assert "125 mm apart, and both look at the workspace" in apart["camera-position-measured"]
