"""Hand-eye and robot pose files: every format, declared units, the magnitude check, direction."""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray

from handeye_pick.errors import CalibrationError, TransformError
from handeye_pick.geometry import (
    compose,
    invert,
    rotation_angle_between,
    scale_translation,
    transform_point,
    ur_pose_to_matrix,
)
from handeye_pick.hand_eye.files import (
    CELL_CONFIG,
    COMMAND_LINE,
    HandEyeMode,
    file_sha256,
    load_hand_eye,
    read_robot_pose_file,
    read_transform_file,
    write_zivid_transform,
)

EXAMPLES = Path(__file__).resolve().parents[2] / "config" / "calibration"
EYE_IN_HAND = EXAMPLES / "EyeInHandTransform.yaml"
EYE_TO_HAND = EXAMPLES / "EyeToHandTransform.yaml"
ROBOT_POSE = EXAMPLES / "RobotTransform.yaml"
OPENCV_LEGACY = EXAMPLES / "EyeInHandTransform_opencv_legacy.yaml"

# The rows of EyeInHandTransform.yaml as written (mm).
EYE_IN_HAND_MM = np.array(
    [
        [0.0, -0.9986295, -0.05233596, -12.5],
        [0.9848077, 0.009088043, -0.1734102, 61.2],
        [0.1736482, -0.05154086, 0.9834581, 95.8],
        [0.0, 0.0, 0.0, 1.0],
    ]
)
EYE_IN_HAND_M = scale_translation(EYE_IN_HAND_MM, 1e-3)

# T_flange_cam of some small eye-in-hand camera, metres.
T_SMALL_M = ur_pose_to_matrix([0.03, -0.06, 0.11, 0.1, -0.2, 1.5])


def write(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


def zivid_text(T: NDArray[np.float64]) -> str:
    rows = ",\n".join("    [" + ", ".join(repr(float(v)) for v in row) + "]" for row in T)
    return f"__version__:\n  serializer: 1\n  data: 1\nFloatMatrix:\n  Data: [\n{rows}]\n"


def opencv_text(T: NDArray[np.float64], directive: str = "%YAML:1.0", dt: str = "d") -> str:
    data = ", ".join(f"{v:.16e}" for v in T.ravel())
    return (
        f"{directive}\n---\nPoseState: !!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: {dt}\n"
        f"   data: [ {data} ]\n"
    )


# --- the bundled examples -------------------------------------------------------------------------


def test_zivid_example_reads_in_metres() -> None:
    np.testing.assert_allclose(read_transform_file(EYE_IN_HAND, "mm"), EYE_IN_HAND_M, atol=1e-15)


def test_legacy_opencv_example_holds_the_same_transform() -> None:
    T_opencv = read_transform_file(OPENCV_LEGACY, "mm")
    T_zivid = read_transform_file(EYE_IN_HAND, "mm")
    assert rotation_angle_between(T_opencv[:3, :3], T_zivid[:3, :3]) < 1e-6
    np.testing.assert_allclose(T_opencv[:3, 3], T_zivid[:3, 3], atol=1e-8)


@pytest.mark.parametrize(
    ("path", "mode"),
    [(EYE_IN_HAND, HandEyeMode.EYE_IN_HAND), (EYE_TO_HAND, HandEyeMode.EYE_TO_HAND)],
)
def test_examples_load_with_their_metadata(path: Path, mode: HandEyeMode) -> None:
    calibration = load_hand_eye(path, mode)
    assert calibration.mode is mode
    assert calibration.path == path
    assert calibration.units == "mm"
    assert calibration.inverted is False
    assert calibration.sha256 == hashlib.sha256(path.read_bytes()).hexdigest()
    assert not calibration.T_cal.flags.writeable


def test_robot_pose_example_matches_its_ur_vector() -> None:
    T_base_flange = read_robot_pose_file(ROBOT_POSE)
    T_ur = ur_pose_to_matrix([0.4503, 0.1207, 0.3811, 0.0213, 3.1102, -0.0417])
    assert rotation_angle_between(T_base_flange[:3, :3], T_ur[:3, :3]) < 1e-6
    np.testing.assert_allclose(T_base_flange[:3, 3], T_ur[:3, 3], atol=1e-12)


# --- Zivid format: write then read back -----------------------------------------------------------

transforms = st.builds(
    lambda t, axis, angle: ur_pose_to_matrix(
        np.concatenate([t, axis / np.linalg.norm(axis) * angle])
    ),
    st.tuples(*(st.floats(-1.5, 1.5) for _ in range(3))).map(np.array),
    st.tuples(*(st.floats(-1.0, 1.0) for _ in range(3)))
    .map(np.array)
    .filter(lambda v: np.linalg.norm(v) > 0.1),
    st.one_of(st.sampled_from([0.0, 1e-9, math.pi - 1e-7, math.pi]), st.floats(0.0, math.pi)),
)


@settings(suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(T_m=transforms, units=st.sampled_from(["mm", "m"]))
def test_zivid_write_then_read_is_the_same_transform(
    tmp_path: Path, T_m: NDArray[np.float64], units: str
) -> None:
    path = tmp_path / "T.yaml"
    write_zivid_transform(path, T_m, units)  # type: ignore[arg-type]
    np.testing.assert_allclose(read_transform_file(path, units), T_m, atol=1e-15)  # type: ignore[arg-type]


def test_zivid_file_is_written_in_the_declared_unit(tmp_path: Path) -> None:
    path = tmp_path / "T.yaml"
    write_zivid_transform(path, T_SMALL_M)
    text = path.read_text()
    assert text.startswith("__version__:\n  serializer: 1\n  data: 1\nFloatMatrix:\n  Data: [")
    assert "110.0" in text  # z = 0.11 m written as mm


def test_writing_a_bad_transform_is_refused(tmp_path: Path) -> None:
    with pytest.raises(TransformError, match="transform to write"):
        write_zivid_transform(tmp_path / "T.yaml", np.diag([1.0, 1.0, -1.0, 1.0]))


# --- OpenCV and plain formats ---------------------------------------------------------------------


@pytest.mark.parametrize("directive", ["%YAML:1.0", "%YAML 1.0", "%YAML:1.0   "])
@pytest.mark.parametrize("dt", ["d", "f"])
def test_opencv_file_is_read_without_opencv(tmp_path: Path, directive: str, dt: str) -> None:
    T_mm = EYE_IN_HAND_MM
    path = write(tmp_path / "cv.yaml", opencv_text(T_mm, directive, dt))
    np.testing.assert_allclose(read_transform_file(path, "mm"), EYE_IN_HAND_M, atol=1e-15)


# The exact layout OpenCV's FileStorage writes (as older Zivid tools did): a directive line, a
# document marker, a tagged node, 3-space indent, doubles in %.16e wrapped two per line, and
# "0." style zeros. Made-up numbers.
LEGACY_OPENCV_LAYOUT = """%YAML:1.0
---
PoseState: !!opencv-matrix
   rows: 4
   cols: 4
   dt: d
   data: [ -6.4359005269386413e-02, 9.8714838162626339e-01,
       1.4627368558077578e-01, -3.1250000000000000e+01,
       9.9523569315123983e-01, 5.2734813364959561e-02,
       8.2005820141826696e-02, 5.8399999999999999e+01,
       7.3238197127631688e-02, 1.5085460586939811e-01,
       -9.8583926396217458e-01, 4.7899999999999999e+01, 0., 0., 0., 1. ]
"""

# A hand-typed pose with its rotation rounded to 4 decimals (9e-5 away from orthonormal): the
# 1e-5 tolerance refuses it rather than guess a repair. Made-up numbers.
ROUNDED_ROBOT_POSE = """%YAML:1.0
---
PoseState: !!opencv-matrix
   rows: 4
   cols: 4
   dt: d
   data: [ 0.9871, -0.1497, -0.0575, 512.5,
       0.1335, 0.9657, -0.2227, 104.2,
       0.0889, 0.2122, 0.9732, 433.0, 0., 0., 0., 1. ]
"""


def test_opencv_file_storage_layout_is_read(tmp_path: Path) -> None:
    path = write(tmp_path / "eyeInHandTransform.yaml", LEGACY_OPENCV_LAYOUT)
    calibration = load_hand_eye(path, HandEyeMode.EYE_IN_HAND)
    np.testing.assert_allclose(calibration.T_cal[:3, 3], [-0.03125, 0.0584, 0.0479])
    np.testing.assert_allclose(
        calibration.T_cal[0, :3], [-0.064359005269386413, 0.98714838162626339, 0.14627368558077578]
    )


def test_robot_pose_with_rounded_rotation_is_refused(tmp_path: Path) -> None:
    path = write(tmp_path / "robotTransform.yaml", ROUNDED_ROBOT_POSE)
    with pytest.raises(TransformError, match=r"robotTransform.yaml: rotation is not orthonormal"):
        read_robot_pose_file(path)


@pytest.mark.parametrize(
    ("name", "text"),
    [
        (
            "list.yaml",
            "[[0, -0.9986295, -0.05233596, -12.5], [0.9848077, 0.009088043, -0.1734102,"
            " 61.2], [0.1736482, -0.05154086, 0.9834581, 95.8], [0, 0, 0, 1]]",
        ),
        (
            "mapping.yaml",
            "units: mm\nmatrix:\n" + "".join(f"  - {row.tolist()}\n" for row in EYE_IN_HAND_MM),
        ),
        ("list.json", json.dumps(EYE_IN_HAND_MM.tolist())),
        ("mapping.json", json.dumps({"matrix": EYE_IN_HAND_MM.tolist(), "units": "mm"})),
    ],
)
def test_plain_yaml_and_json(tmp_path: Path, name: str, text: str) -> None:
    path = write(tmp_path / name, text)
    np.testing.assert_allclose(read_transform_file(path, "mm"), EYE_IN_HAND_M, atol=1e-15)


def test_exponent_without_dot_is_a_number(tmp_path: Path) -> None:
    # PyYAML reads 1e-9 as a string; the reader still takes it as the number it is.
    path = write(
        tmp_path / "T.yaml", "[[1, 0, 0, 1e-9], [0, 1, 0, 0.1], [0, 0, 1, 0], [0, 0, 0, 1]]"
    )
    assert read_transform_file(path, "m")[0, 3] == 1e-9


def test_plain_units_that_contradict_the_declared_unit_are_refused(tmp_path: Path) -> None:
    path = write(tmp_path / "T.json", json.dumps({"matrix": T_SMALL_M.tolist(), "units": "m"}))
    message = r"says units: m but .* declared as mm; declare m \(--calibration-units m\)"
    with pytest.raises(CalibrationError, match=message):
        load_hand_eye(path, HandEyeMode.EYE_IN_HAND)
    calibration = load_hand_eye(path, HandEyeMode.EYE_IN_HAND, units="m")
    np.testing.assert_allclose(calibration.T_cal, T_SMALL_M, atol=1e-15)


# --- malformed files ------------------------------------------------------------------------------

ROW = "[1, 0, 0, 0]"
GOOD_DATA = f"[{ROW}, [0, 1, 0, 0], [0, 0, 1, 0.1], [0, 0, 0, 1]]"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "expected a Zivid transform"),
        ("hello", "expected a Zivid transform"),
        ("[[1, 2], [3, 4], [5, 6], [7, 8]]", "row 0 must have 4 numbers"),
        (f"[{ROW}, {ROW}, {ROW}]", "expected a list of 4 rows"),
        (f"[{ROW}, {ROW}, {ROW}, [0, 0, x, 1]]", "row 3 column 2: expected a number, found 'x'"),
        (f"[{ROW}, {ROW}, {ROW}, [0, 0, true, 1]]", "expected a number, found True"),
        ("{matrix: [], unit: mm}", "keys 'matrix' and optionally 'units'"),
        (f"{{matrix: {GOOD_DATA}, units: cm}}", "units must be 'mm' or 'm', found 'cm'"),
        ("a: [1, 2\nb: 3", "not valid YAML/JSON"),
        (
            f"__version__: {{serializer: 1, data: 2}}\nFloatMatrix: {{Data: {GOOD_DATA}}}",
            "unsupported Zivid __version__",
        ),
        (
            f"__version__: {{serializer: 1, data: 1}}\nFloatMatrix: {{Data: {GOOD_DATA}}}\nx: 1",
            "exactly the keys __version__ and FloatMatrix",
        ),
        (
            "__version__: {serializer: 1, data: 1}\nFloatMatrix: {Rows: []}",
            "FloatMatrix must be a mapping with the one key Data",
        ),
        ("%YAML:1.0\n---\nA: 1\n", r"exactly one !!opencv-matrix node .* found 0"),
        (
            "%YAML:1.0\n---\nA: !!opencv-matrix {rows: 4, cols: 4, dt: d, data: []}\n"
            "B: !!opencv-matrix {rows: 4, cols: 4, dt: d, data: []}\n",
            r"found 2: \['A', 'B'\]",
        ),
        (
            "%YAML:1.0\n---\nP: !!opencv-matrix {rows: 3, cols: 4, dt: d, data: []}\n",
            "expected rows: 4 and cols: 4, found rows: 3",
        ),
        (
            "%YAML:1.0\n---\nP: !!opencv-matrix {rows: 4, cols: 4, dt: i, data: []}\n",
            "expected dt: d or f, found 'i'",
        ),
        (
            "%YAML:1.0\n---\nP: !!opencv-matrix {rows: 4, cols: 4, dt: d, data: [1, 2]}\n",
            "expected data with 16 numbers, found 2",
        ),
        ("%YAML:1.0\n---\nP: !!opencv-matrix [1, 2]\n", "must be a mapping.* line 3"),
        ("!!python/object/apply:os.system ['true']", "not valid YAML/JSON"),
    ],
)
def test_malformed_file_is_refused_naming_file_and_defect(
    tmp_path: Path, text: str, message: str
) -> None:
    path = write(tmp_path / "bad.yaml", text)
    with pytest.raises(CalibrationError, match=message) as info:
        read_transform_file(path, "mm")
    assert str(path) in str(info.value)


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0.5, 1]], "bottom row"),
        ([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, -1, 0], [0, 0, 0, 1]], "determinant"),
        ([[1, 1e-4, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "not orthonormal"),
        ([[1, 0, 0, float("nan")], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "non-finite"),
    ],
)
def test_non_rigid_matrix_in_a_file_is_refused(
    tmp_path: Path, data: list[list[float]], message: str
) -> None:
    path = write(tmp_path / "bad.json", json.dumps(data))
    with pytest.raises(TransformError, match=message) as info:
        read_transform_file(path, "mm")
    assert str(path) in str(info.value)


def test_float32_rounding_is_accepted_and_worse_is_refused(tmp_path: Path) -> None:
    T = ur_pose_to_matrix([0.1, 0.2, 0.3, 0.7, -1.1, 2.9])
    T32 = T.astype(np.float32).astype(np.float64)
    read_transform_file(write(tmp_path / "ok.json", json.dumps(T32.tolist())), "m")
    T_bad = T.copy()
    T_bad[:3, :3] += 1e-4
    with pytest.raises(TransformError, match="not orthonormal"):
        read_transform_file(write(tmp_path / "bad.json", json.dumps(T_bad.tolist())), "m")


def test_missing_file_is_a_calibration_error(tmp_path: Path) -> None:
    with pytest.raises(CalibrationError, match=r"cannot read transform file .*nope\.yaml"):
        read_transform_file(tmp_path / "nope.yaml", "mm")
    with pytest.raises(CalibrationError, match="cannot read"):
        file_sha256(tmp_path / "nope.yaml")


def test_binary_file_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "cloud.zdf"
    path.write_bytes(b"\xff\xfe\x00binary")
    with pytest.raises(CalibrationError, match="not UTF-8 text"):
        read_transform_file(path, "mm")


# --- units: declared, never guessed; the magnitude check ------------------------------------------


def test_eye_in_hand_mm_file_declared_as_m_is_caught() -> None:
    with pytest.raises(CalibrationError, match=r"declare mm \(--calibration-units mm\)"):
        load_hand_eye(EYE_IN_HAND, HandEyeMode.EYE_IN_HAND, units="m")


def test_unit_hint_names_the_setting_where_the_user_is(tmp_path: Path) -> None:
    # A cell config declares the unit with hand_eye.units; --calibration-units is not there.
    with pytest.raises(CalibrationError, match=r"declare mm \(hand_eye\.units: mm\)$"):
        load_hand_eye(EYE_IN_HAND, HandEyeMode.EYE_IN_HAND, units="m", settings=CELL_CONFIG)
    path = write(tmp_path / "T.yaml", f"{{matrix: {np.eye(4).tolist()}, units: m}}")
    with pytest.raises(CalibrationError, match=r"\(hand_eye\.units: m\) or fix the file"):
        load_hand_eye(path, HandEyeMode.EYE_IN_HAND, settings=CELL_CONFIG)
    assert load_hand_eye(EYE_IN_HAND, HandEyeMode.EYE_IN_HAND).settings is COMMAND_LINE


def test_eye_in_hand_m_file_declared_as_mm_is_caught(tmp_path: Path) -> None:
    path = tmp_path / "T.yaml"
    write_zivid_transform(path, T_SMALL_M, units="m")
    with pytest.raises(CalibrationError, match=r"camera distance from the flange .* declare m"):
        load_hand_eye(path, HandEyeMode.EYE_IN_HAND)
    assert load_hand_eye(path, HandEyeMode.EYE_IN_HAND, units="m").units == "m"


def test_eye_to_hand_unit_mix_up_is_caught(tmp_path: Path) -> None:
    with pytest.raises(
        CalibrationError, match=r"camera distance from the robot base .* declare mm"
    ):
        load_hand_eye(EYE_TO_HAND, HandEyeMode.EYE_TO_HAND, units="m")
    path = tmp_path / "T.yaml"
    write_zivid_transform(path, read_transform_file(EYE_TO_HAND, "mm"), units="m")
    with pytest.raises(CalibrationError, match="declare m"):
        load_hand_eye(path, HandEyeMode.EYE_TO_HAND)


def test_robot_pose_unit_mix_up_is_caught(tmp_path: Path) -> None:
    with pytest.raises(CalibrationError, match=r"flange distance .* \(--robot-pose-units mm\)"):
        read_robot_pose_file(ROBOT_POSE, units="m")
    path = tmp_path / "pose.yaml"
    write_zivid_transform(path, read_robot_pose_file(ROBOT_POSE), units="m")
    with pytest.raises(CalibrationError, match=r"\(--robot-pose-units m\)"):
        read_robot_pose_file(path)


def test_implausible_in_any_unit_says_check_the_file(tmp_path: Path) -> None:
    path = write(tmp_path / "T.json", json.dumps(np.eye(4).tolist()))
    with pytest.raises(CalibrationError, match="no unit makes it plausible"):
        load_hand_eye(path, HandEyeMode.EYE_IN_HAND)


# --- direction: explicit invert, nothing inverted by guess ----------------------------------------


@pytest.mark.parametrize("mode", list(HandEyeMode))
def test_invert_is_explicit(tmp_path: Path, mode: HandEyeMode) -> None:
    T_file_m = read_transform_file(EYE_TO_HAND, "mm")
    path = tmp_path / "T.yaml"
    write_zivid_transform(path, T_file_m)
    as_written = load_hand_eye(path, mode)
    np.testing.assert_allclose(as_written.T_cal, T_file_m, atol=1e-15)
    inverted = load_hand_eye(path, mode, invert=True)
    assert inverted.inverted is True
    np.testing.assert_allclose(inverted.T_cal, invert(T_file_m), atol=1e-15)


def test_eye_in_hand_chain_and_its_order() -> None:
    calibration = load_hand_eye(EYE_IN_HAND, HandEyeMode.EYE_IN_HAND)
    T_base_flange = read_robot_pose_file(ROBOT_POSE)
    T_base_cam = calibration.T_base_cam(T_base_flange)
    np.testing.assert_allclose(T_base_cam, T_base_flange @ EYE_IN_HAND_M, atol=1e-15)
    p_cam = np.array([0.01, -0.02, 0.3])
    p_base = transform_point(T_base_cam, p_cam)
    # A swapped chain, an inverted file or a unit slip each give a clearly different point.
    swapped = transform_point(compose(calibration.T_cal, T_base_flange), p_cam)
    inverted = transform_point(compose(T_base_flange, invert(calibration.T_cal)), p_cam)
    mm_as_m = transform_point(compose(T_base_flange, calibration.T_cal), p_cam * 1e3) * 1e-3
    for wrong in (swapped, inverted, mm_as_m):
        assert np.linalg.norm(wrong - p_base) > 0.05


def test_eye_in_hand_chain_needs_the_flange_pose() -> None:
    calibration = load_hand_eye(EYE_IN_HAND, HandEyeMode.EYE_IN_HAND)
    with pytest.raises(CalibrationError, match="needs the flange pose"):
        calibration.T_base_cam(None)


def test_eye_to_hand_chain_is_the_file_and_ignores_the_robot() -> None:
    calibration = load_hand_eye(EYE_TO_HAND, HandEyeMode.EYE_TO_HAND)
    T_file_m = read_transform_file(EYE_TO_HAND, "mm")
    np.testing.assert_array_equal(calibration.T_base_cam(None), T_file_m)
    np.testing.assert_array_equal(
        calibration.T_base_cam(read_robot_pose_file(ROBOT_POSE)), T_file_m
    )
    calibration.T_base_cam(None)[0, 3] = 99.0  # a copy: the calibration stays as loaded
    np.testing.assert_array_equal(calibration.T_cal, T_file_m)


def test_mode_from_string() -> None:
    assert load_hand_eye(EYE_TO_HAND, "eye-to-hand").mode is HandEyeMode.EYE_TO_HAND  # type: ignore[arg-type]
    with pytest.raises(CalibrationError, match="unknown hand-eye mode 'eye-on-hand'"):
        load_hand_eye(EYE_TO_HAND, "eye-on-hand")  # type: ignore[arg-type]
