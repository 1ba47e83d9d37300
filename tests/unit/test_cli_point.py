"""The ``point`` and ``convert`` commands: results, JSON, exit statuses and one-line errors."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from handeye_pick.cli import main
from handeye_pick.geometry import (
    invert,
    rotation_angle_between,
    rotation_from_euler,
    rotation_from_quaternion,
    ur_pose_to_matrix,
)
from handeye_pick.hand_eye.files import read_transform_file, write_zivid_transform

EXAMPLES = Path(__file__).resolve().parents[2] / "config" / "calibration"
EYE_IN_HAND = str(EXAMPLES / "EyeInHandTransform.yaml")
EYE_TO_HAND = str(EXAMPLES / "EyeToHandTransform.yaml")
ROBOT_POSE = str(EXAMPLES / "RobotTransform.yaml")
ROBOT_POSE_UR = ["0.4503", "0.1207", "0.3811", "0.0213", "3.1102", "-0.0417"]

# EyeToHandTransform.yaml as written: T_base_cam, mm.
T_BASE_CAM_MM = np.array(
    [
        [-0.03455986, -0.9993908, 0.004857071, 512.4],
        [-0.9896649, 0.0348995, 0.1390883, -38.7],
        [-0.1391731, 0.0, -0.9902681, 1245.3],
        [0.0, 0.0, 0.0, 1.0],
    ]
)
P_CAM_MM = np.array([37.77, -145.92, 1227.1])
P_BASE_MM = T_BASE_CAM_MM[:3, :3] @ P_CAM_MM + T_BASE_CAM_MM[:3, 3]


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    status = main(list(argv))
    out, err = capsys.readouterr()
    return status, out, err


def run_json(capsys: pytest.CaptureFixture[str], *argv: str) -> dict[str, Any]:
    status, out, err = run(capsys, *argv, "--json")
    assert (status, err) == (0, "")
    report: dict[str, Any] = json.loads(out)
    return report


def assert_bad_input(capsys: pytest.CaptureFixture[str], message: str, *argv: str) -> None:
    status, out, err = run(capsys, *argv)
    assert status == 2
    assert out == ""
    assert err.startswith("error: ")
    assert err.count("\n") == 1, err  # one line, never a traceback
    assert message in err


# --- point: eye-to-hand ---------------------------------------------------------------------------


def test_eye_to_hand_point(capsys: pytest.CaptureFixture[str]) -> None:
    report = run_json(
        capsys, "point", "--mode", "eye-to-hand", "--calibration", EYE_TO_HAND,
        "--xyz", *map(str, P_CAM_MM),
    )  # fmt: skip
    np.testing.assert_allclose(report["point_camera_mm"], P_CAM_MM)
    np.testing.assert_allclose(report["point_base_mm"], P_BASE_MM, atol=1e-9)
    assert report["mode"] == "eye-to-hand"
    assert report["T_base_flange_m"] is None
    T_base_cam_m = np.array(report["T_base_cam_m"])
    np.testing.assert_allclose(T_base_cam_m[:3, 3], T_BASE_CAM_MM[:3, 3] * 1e-3, atol=1e-15)
    assert report["calibration"]["units"] == "mm"
    assert report["calibration"]["inverted"] is False
    assert len(report["calibration"]["sha256"]) == 64


def test_text_output_names_frames_and_units(capsys: pytest.CaptureFixture[str]) -> None:
    status, out, _ = run(
        capsys, "point", "--mode", "eye-to-hand", "--calibration", EYE_TO_HAND,
        "--xyz", *map(str, P_CAM_MM),
    )  # fmt: skip
    assert status == 0
    lines = out.splitlines()
    assert lines[0] == "point_camera_mm: 37.7700 -145.9200 1227.1000"
    assert lines[1].split()[0] == "point_base_mm:"
    np.testing.assert_allclose([float(v) for v in lines[1].split()[1:]], P_BASE_MM, atol=1e-4)


def test_invert_flag_inverts_and_nothing_else_does(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    # The same transform written the other way round (T_cam_base), then read with --invert.
    path = tmp_path / "T_cam_base.yaml"
    T_base_cam_m = T_BASE_CAM_MM.copy()
    T_base_cam_m[:3, 3] *= 1e-3
    write_zivid_transform(path, invert(T_base_cam_m))
    argv = ["point", "--mode", "eye-to-hand", "--calibration", str(path)]
    argv += ["--xyz", *map(str, P_CAM_MM)]
    inverted = run_json(capsys, *argv, "--invert")
    # The closed-form inverse uses R^T; the file's float32 rotation is orthonormal to 1e-7, so
    # two inversions move a point 1.2 m away by about 1e-4 mm.
    np.testing.assert_allclose(inverted["point_base_mm"], P_BASE_MM, atol=1e-3)
    assert inverted["calibration"]["inverted"] is True
    as_written = run_json(capsys, *argv)
    assert np.linalg.norm(np.subtract(as_written["point_base_mm"], P_BASE_MM)) > 100.0


# --- point: eye-in-hand ---------------------------------------------------------------------------


def test_eye_in_hand_pose_file_and_ur_vector_agree(capsys: pytest.CaptureFixture[str]) -> None:
    base = [
        "point",
        "--mode",
        "eye-in-hand",
        "--calibration",
        EYE_IN_HAND,
        "--xyz",
        "10",
        "-20",
        "300",
    ]
    from_file = run_json(capsys, *base, "--robot-pose", ROBOT_POSE)
    from_ur = run_json(capsys, *base, "--robot-pose-ur", *ROBOT_POSE_UR)
    # The file holds the UR vector's matrix rounded to float32 precision.
    np.testing.assert_allclose(from_file["point_base_mm"], from_ur["point_base_mm"], atol=1e-3)
    np.testing.assert_allclose(
        from_ur["T_base_flange_m"], ur_pose_to_matrix([float(v) for v in ROBOT_POSE_UR])
    )
    # Independent check of the chain: p_base = T_base_flange @ T_flange_cam @ p_cam.
    T_base_cam = np.array(from_ur["T_base_flange_m"]) @ np.array(
        [
            [0.0, -0.9986295, -0.05233596, -0.0125],
            [0.9848077, 0.009088043, -0.1734102, 0.0612],
            [0.1736482, -0.05154086, 0.9834581, 0.0958],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )
    p_base_m = T_base_cam @ [0.010, -0.020, 0.300, 1.0]
    np.testing.assert_allclose(from_ur["point_base_mm"], p_base_m[:3] * 1e3, atol=1e-9)


def test_eye_in_hand_from_a_cloud_pixel(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    xyz = np.full((4, 6, 3), np.nan, dtype=np.float32)
    xyz[2, 5] = [10.0, -20.0, 300.0]  # row 2, column 5
    cloud = tmp_path / "cloud.npy"
    np.save(cloud, xyz)
    base = [
        "point",
        "--mode",
        "eye-in-hand",
        "--calibration",
        EYE_IN_HAND,
        "--robot-pose",
        ROBOT_POSE,
    ]
    from_pixel = run_json(capsys, *base, "--cloud", str(cloud), "--pixel", "5", "2")
    from_xyz = run_json(capsys, *base, "--xyz", "10", "-20", "300")
    assert from_pixel["point_camera_mm"] == [10.0, -20.0, 300.0]
    assert from_pixel["point_base_mm"] == from_xyz["point_base_mm"]
    assert_bad_input(
        capsys, "(col 1, row 2)", *base, "--cloud", str(cloud), "--pixel", "1", "2"
    )  # NaN
    assert_bad_input(capsys, "", *base, "--cloud", str(cloud), "--pixel", "2", "5")  # outside
    assert_bad_input(capsys, "needs --pixel", *base, "--cloud", str(cloud))
    assert_bad_input(capsys, "no --cloud", *base, "--xyz", "1", "2", "3", "--pixel", "1", "1")


def test_wrong_robot_pose_unit_or_missing_pose_is_refused(
    capsys: pytest.CaptureFixture[str],
) -> None:
    base = ["point", "--mode", "eye-in-hand", "--calibration", EYE_IN_HAND, "--xyz", "1", "2", "3"]
    assert_bad_input(capsys, "needs the flange pose", *base)
    assert_bad_input(
        capsys,
        "--robot-pose-units mm",
        *base,
        "--robot-pose",
        ROBOT_POSE,
        "--robot-pose-units",
        "m",
    )
    assert_bad_input(capsys, "expected 6 arguments", *base, "--robot-pose-ur", "1", "2", "3")


def test_eye_to_hand_refuses_a_robot_pose(capsys: pytest.CaptureFixture[str]) -> None:
    assert_bad_input(
        capsys, "--mode eye-to-hand uses no robot pose",
        "point", "--mode", "eye-to-hand", "--calibration", EYE_TO_HAND, "--xyz", "1", "2", "3",
        "--robot-pose-ur", *ROBOT_POSE_UR,
    )  # fmt: skip


# --- point: the chain's plausibility --------------------------------------------------------------

EYE_IN_HAND_POINT = ["--robot-pose", ROBOT_POSE, "--xyz", "10", "-20", "300"]


def test_inverted_eye_in_hand_file_is_refused_saying_which_way(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    argv = ["point", "--mode", "eye-in-hand", "--calibration"]
    assert_bad_input(
        capsys, "camera-in-front-of-flange: the camera sits 84 mm behind the flange face, inside "
        "the wrist: the calibration looks inverted (drop --invert)",
        *argv, EYE_IN_HAND, "--invert", *EYE_IN_HAND_POINT,
    )  # fmt: skip
    written_inverted = tmp_path / "T_cam_flange.yaml"
    write_zivid_transform(written_inverted, invert(read_transform_file(EYE_IN_HAND, "mm")))
    assert_bad_input(
        capsys, "looks inverted (add --invert)", *argv, str(written_inverted), *EYE_IN_HAND_POINT
    )
    inverted_back = run_json(capsys, *argv, str(written_inverted), "--invert", *EYE_IN_HAND_POINT)
    as_written = run_json(capsys, *argv, EYE_IN_HAND, *EYE_IN_HAND_POINT)
    np.testing.assert_allclose(
        inverted_back["point_base_mm"], as_written["point_base_mm"], atol=1e-3
    )


def test_swapped_mode_is_refused_naming_the_right_one(capsys: pytest.CaptureFixture[str]) -> None:
    assert_bad_input(
        capsys, "this looks like an eye-in-hand file (T_flange_cam); for a camera on the arm set "
        "--mode eye-in-hand",
        "point", "--mode", "eye-to-hand", "--calibration", EYE_IN_HAND, "--xyz", "10", "-20", "300",
    )  # fmt: skip
    assert_bad_input(
        capsys, "this looks like an eye-to-hand file (T_base_cam); for a camera fixed in the cell "
        "set --mode eye-to-hand",
        "point", "--mode", "eye-in-hand", "--calibration", EYE_TO_HAND, *EYE_IN_HAND_POINT,
    )  # fmt: skip


def test_an_acknowledged_check_passes_with_a_warning(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["point", "--mode", "eye-in-hand", "--calibration", EYE_IN_HAND, "--invert"]
    argv += [*EYE_IN_HAND_POINT, "--acknowledge", "camera-in-front-of-flange"]
    status, out, err = run(capsys, *argv)
    assert status == 0
    assert out.startswith("point_camera_mm:")
    assert "acknowledged camera-in-front-of-flange: the camera sits 84 mm behind" in err
    # Only the named check: another one still refuses.
    argv[argv.index("camera-in-front-of-flange")] = "camera-near-flange"
    assert_bad_input(capsys, "--acknowledge camera-in-front-of-flange)", *argv)


# A camera 1.2 m up looking straight down, written the other way round (T_cam_base, mm): read
# without --invert it is another straight-down camera, at (100, 450, 1200) mm.
STRAIGHT_DOWN_INVERSE = "[[0, 1, 0, 100], [1, 0, 0, 450], [0, 0, -1, 1200], [0, 0, 0, 1]]\n"
TAPED = ["--camera-position-mm", "-430", "-120", "1180"]  # the true camera is at (-450, -100, 1200)


def test_a_measured_camera_position_catches_a_straight_down_file_read_the_wrong_way(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    path = tmp_path / "cal.yaml"
    path.write_text(STRAIGHT_DOWN_INVERSE)
    argv = ["point", "--mode", "eye-to-hand", "--calibration", str(path), "--xyz", "50", "-20"]
    argv += ["1100", *TAPED]
    assert_bad_input(
        capsys, "implausible camera chain: camera-at-measured-position: the calibration puts the "
        "camera at [100, 450, 1200] mm in the robot base frame, 779 mm from its measured "
        "position [-430, -120, 1180] mm (--camera-position-mm, tolerance 100 mm); the inverse "
        "file puts it 35 mm from there: the calibration looks inverted (add --invert)",
        *argv,
    )  # fmt: skip
    report = run_json(capsys, *argv, "--invert")
    np.testing.assert_allclose(report["point_base_mm"], [-470.0, -50.0, 100.0], atol=1e-9)
    status, out, err = run(capsys, *argv, "--acknowledge", "camera-at-measured-position")
    assert status == 0
    assert out.startswith("point_camera_mm:")
    assert "acknowledged camera-at-measured-position: the calibration puts the camera at" in err
    # Tighter than the tape's 35 mm error, the right file is refused too, blaming all three.
    assert_bad_input(
        capsys, "the file, its mode (--mode) or the measured position is wrong",
        *argv, "--invert", "--camera-position-tolerance-mm", "30",
    )  # fmt: skip


@pytest.mark.parametrize(
    ("flags", "message"),
    [
        (["--camera-position-mm", "-0.43", "-0.12", "1.18"], "--camera-position-mm: the camera "
         "distance from the robot base is 1.26163 mm, expected 50 to 10000 mm"),
        (["--camera-position-mm", "-430", "nan", "1180"], "expected 3 finite numbers"),
        ([*TAPED, "--camera-position-tolerance-mm", "0"], "--camera-position-tolerance-mm must "
         "be greater than 0 and at most 500 mm, got 0"),
        ([*TAPED, "--camera-position-tolerance-mm", "600"], "at most 500 mm, got 600"),
        (["--camera-position-tolerance-mm", "50"], "--camera-position-tolerance-mm applies to "
         "--camera-position-mm, which was not given"),
    ],
)  # fmt: skip
def test_bad_measured_camera_positions_are_refused(
    capsys: pytest.CaptureFixture[str], flags: list[str], message: str
) -> None:
    assert_bad_input(
        capsys, message,
        "point", "--mode", "eye-to-hand", "--calibration", EYE_TO_HAND, "--xyz", "1", "2", "300",
        *flags,
    )  # fmt: skip


def test_a_camera_point_in_metres_is_refused_as_pick_refuses_it(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert_bad_input(
        capsys, "--xyz: camera point [0.03777, -0.14592, 1.2271] mm is 1.23632 mm from the "
        "camera, expected 10 to 10000 mm (metres given as mm?)",
        "point", "--mode", "eye-to-hand", "--calibration", EYE_TO_HAND,
        "--xyz", "0.03777", "-0.14592", "1.2271",
    )  # fmt: skip


# --- point: bad files and arguments ---------------------------------------------------------------


def test_calibration_declared_in_the_wrong_unit_is_refused(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert_bad_input(
        capsys, "--calibration-units mm",
        "point", "--mode", "eye-to-hand", "--calibration", EYE_TO_HAND, "--xyz", "1", "2", "3",
        "--calibration-units", "m",
    )  # fmt: skip


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (None, "cannot read transform file"),
        ("[[1, 0], [0, 1]]", "expected a list of 4 rows"),
        ("[[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 900], [0, 0, 0, 1]]", "not orthonormal"),
        ("%YAML:1.0\n---\nPoseState: !!opencv-matrix {rows: 4}\n", "expected rows: 4 and cols: 4"),
    ],
)
def test_bad_calibration_file(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, content: str | None, message: str
) -> None:
    path = tmp_path / "cal.yaml"
    if content is not None:
        path.write_text(content)
    assert_bad_input(
        capsys, message,
        "point", "--mode", "eye-to-hand", "--calibration", str(path), "--xyz", "1", "2", "3",
    )  # fmt: skip


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--mode", "eye-to-hand", "--calibration", EYE_TO_HAND, "--xyz", "1", "2"], "--xyz"),
        (["--mode", "eye-to-hand", "--calibration", EYE_TO_HAND, "--xyz", "1", "x", "3"], "x"),
        (["--mode", "eye-on-hand", "--calibration", EYE_TO_HAND, "--xyz", "1", "2", "3"], "--mode"),
        (["--mode", "eye-to-hand", "--xyz", "1", "2", "3"], "--calibration"),
        (["--mode", "eye-to-hand", "--calibration", EYE_TO_HAND], "--xyz"),
        (
            ["--mode", "eye-to-hand", "--calibration", EYE_TO_HAND, "--xyz", "1", "nan", "3"],
            "finite",
        ),
    ],
)
def test_bad_arguments(capsys: pytest.CaptureFixture[str], argv: list[str], message: str) -> None:
    assert_bad_input(capsys, message, "point", *argv)


def test_console_script_exit_status_and_one_line_error(tmp_path: Path) -> None:
    result = subprocess.run(
        [sys.executable, "-c", "import sys; from handeye_pick.cli import main; sys.exit(main())",
         "point", "--mode", "eye-to-hand", "--calibration", str(tmp_path / "missing.yaml"),
         "--xyz", "1", "2", "3"],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert result.returncode == 2
    assert result.stdout == ""
    assert result.stderr.count("\n") == 1
    assert "missing.yaml" in result.stderr


@pytest.mark.parametrize("command", ["point", "convert"])
def test_help_names_units_and_frames(capsys: pytest.CaptureFixture[str], command: str) -> None:
    with pytest.raises(SystemExit) as info:
        main([command, "--help"])
    assert info.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    if command == "point":
        words = ["mm", "metres", "radians", "T_base_cam", "T_flange_cam", "T_base_flange"]
        words += ["camera frame", "robot base frame"]
    else:
        words = ["UR vectors: m", "rad", "--sequence xyz --angle-unit rad", "xyzw", "wxyz"]
    for word in words:
        assert word in text


# --- convert --------------------------------------------------------------------------------------


def convert(capsys: pytest.CaptureFixture[str], *argv: str) -> dict[str, Any]:
    return run_json(capsys, "convert", *argv)


def test_convert_ur_to_matrix_near_pi(capsys: pytest.CaptureFixture[str]) -> None:
    report = convert(
        capsys, "--from", "ur", "--to", "matrix", "0.1", "0.2", "0.3", "0", "3.14159", "0"
    )
    T = np.array(report["values"])
    assert T.shape == (4, 4)
    assert rotation_angle_between(T[:3, :3], np.diag([-1.0, 1.0, -1.0])) < 3e-6
    np.testing.assert_array_equal(T[:3, 3], [0.1, 0.2, 0.3])


@pytest.mark.parametrize("angle", [0.0, 1e-9, math.pi - 1e-7, math.pi, 2.0])
@pytest.mark.parametrize(
    ("fmt", "extra"),
    [
        ("matrix", []),
        ("quat-xyzw", []),
        ("quat-wxyz", []),
        ("euler", ["--sequence", "xyz", "--angle-unit", "deg"]),
        ("euler", ["--sequence", "ZYX", "--angle-unit", "rad"]),
    ],
)
def test_convert_round_trip_through_every_format(
    capsys: pytest.CaptureFixture[str], fmt: str, extra: list[str], angle: float
) -> None:
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    pose = [0.4, -0.1, 0.25, *(axis * angle)]
    there = convert(capsys, "--from", "ur", "--to", fmt, *extra, *(repr(float(v)) for v in pose))
    flat = np.ravel(there["values"])
    back = convert(capsys, "--from", fmt, "--to", "ur", *extra, *map(repr, flat.tolist()))
    R_in = ur_pose_to_matrix(pose)[:3, :3]
    assert rotation_angle_between(R_in, ur_pose_to_matrix(back["values"])[:3, :3]) < 1e-6
    np.testing.assert_allclose(back["values"][:3], pose[:3], atol=1e-12)


def test_convert_quaternion_orders_and_euler_conventions(
    capsys: pytest.CaptureFixture[str],
) -> None:
    pose = ["0", "0", "0", "0", "0", repr(math.pi / 2)]  # 90 deg about z
    xyzw = convert(capsys, "--from", "ur", "--to", "quat-xyzw", *pose)["values"]
    wxyz = convert(capsys, "--from", "ur", "--to", "quat-wxyz", *pose)["values"]
    np.testing.assert_allclose(xyzw[3:], [0.0, 0.0, math.sqrt(0.5), math.sqrt(0.5)], atol=1e-15)
    np.testing.assert_allclose(wxyz[3:], [math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5)], atol=1e-15)
    rpy = convert(
        capsys, "--from", "ur", "--to", "euler", "--sequence", "xyz", "--angle-unit", "deg", *pose
    )
    np.testing.assert_allclose(rpy["values"][3:], [0.0, 0.0, 90.0], atol=1e-12)
    assert (rpy["sequence"], rpy["angle_unit"]) == ("xyz", "deg")
    R = rotation_from_euler(rpy["values"][3:], "xyz", "deg")
    assert rotation_angle_between(R, rotation_from_quaternion(xyzw[3:], "xyzw")) < 1e-12


def test_negative_numbers_with_exponents_are_numbers(capsys: pytest.CaptureFixture[str]) -> None:
    report = run_json(
        capsys, "point", "--mode", "eye-in-hand", "--calibration", EYE_IN_HAND,
        "--robot-pose-ur", "0.45", "-1.2e-1", "0.38", "0", "3.1", "-4E-2",
        "--xyz", "-1e1", "2", "3e2",
    )  # fmt: skip
    assert report["point_camera_mm"] == [-10.0, 2.0, 300.0]
    assert report["T_base_flange_m"][1][3] == -0.12


def test_convert_text_output(capsys: pytest.CaptureFixture[str]) -> None:
    status, out, _ = run(
        capsys, "convert", "--from", "quat-wxyz", "--to", "ur", "1", "2", "3", "1", "0", "0", "0"
    )
    assert status == 0
    assert [float(v) for v in out.split()] == [1.0, 2.0, 3.0, 0.0, 0.0, 0.0]
    status, out, _ = run(
        capsys, "convert", "--from", "ur", "--to", "matrix", "1", "2", "3", "0", "0", "0"
    )
    assert status == 0
    assert np.array([line.split() for line in out.splitlines()], dtype=float).tolist() == [
        [1, 0, 0, 1], [0, 1, 0, 2], [0, 0, 1, 3], [0, 0, 0, 1]
    ]  # fmt: skip


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--from", "ur", "--to", "matrix", "1", "2", "3"], "expected 6 numbers, got 3"),
        (["--from", "ur", "--to", "euler", *["0"] * 6], "euler needs both --sequence"),
        (["--from", "ur", "--to", "euler", "--sequence", "xyz", *["0"] * 6], "--angle-unit"),
        (["--from", "ur", "--to", "matrix", "--sequence", "xyz", *["0"] * 6], "apply only to"),
        (["--from", "euler", "--to", "euler", "--sequence", "xyz", "--angle-unit", "deg",
          *["0"] * 6], "convert to matrix first"),
        (["--from", "ur", "--to", "euler", "--sequence", "xyx2", "--angle-unit", "deg",
          *["0"] * 6], "Euler sequence 'xyx2' is not valid"),
        (["--from", "quat-xyzw", "--to", "ur", *["0"] * 6, "2"], "unit norm"),
        (["--from", "matrix", "--to", "ur", *["1"] * 16], "convert --from matrix: bottom row"),
        (["--from", "ur", "--to", "rpy", *["0"] * 6], "--to"),
        (["--from", "ur", "--to", "matrix", "0", "0", "0", "0", "nan", "0"], "non-finite"),
    ],
)  # fmt: skip
def test_convert_bad_input(
    capsys: pytest.CaptureFixture[str], argv: list[str], message: str
) -> None:
    assert_bad_input(capsys, message, "convert", *argv)
