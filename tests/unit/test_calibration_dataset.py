"""Reading a hand-eye dataset: pairs by number, Zivid and legacy OpenCV files, every refusal."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray

from handeye_pick.calibration.dataset import object_pose_path, read_dataset, robot_pose_path
from handeye_pick.errors import CalibrationError
from handeye_pick.geometry import scale_translation, ur_pose_to_matrix
from mocks.handeye_scene import NO_NOISE, make_scene, measure
from tests.unit.handeye_helpers import write_dataset

T_ROBOT = ur_pose_to_matrix([0.45, 0.12, 0.38, 0.02, 3.11, -0.04])
T_OBJECT = ur_pose_to_matrix([0.03, -0.02, 0.52, 0.1, -0.2, 1.4])


def opencv_text(T_mm: NDArray[np.float64]) -> str:
    """A legacy OpenCV FileStorage file as older Zivid tools wrote it (float32 data)."""
    data = ", ".join(f"{v:.8e}" for v in T_mm.astype(np.float32).ravel())
    return (
        "%YAML:1.0\n---\nPoseState: !!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: f\n"
        f"   data: [ {data} ]\n"
    )


def one_pair(folder: Path, number: int) -> Path:
    write_dataset(folder, [(T_ROBOT, T_OBJECT)], [number])
    return folder


def test_pairs_are_named_by_their_file_number_and_sorted(tmp_path: Path) -> None:
    scene = make_scene(np.random.default_rng(0), "eye-in-hand", 4)
    captures = measure(scene, np.random.default_rng(1), NO_NOISE)
    write_dataset(tmp_path, captures, [12, 5, 100, 7])
    pairs = read_dataset(tmp_path)
    assert [p.number for p in pairs] == [5, 7, 12, 100]
    by_number = dict(zip([12, 5, 100, 7], captures, strict=True))
    for pair in pairs:
        np.testing.assert_allclose(pair.T_base_flange, by_number[pair.number][0], atol=1e-12)
        np.testing.assert_allclose(pair.T_cam_obj, by_number[pair.number][1], atol=1e-12)


def test_legacy_opencv_files_read_like_zivid_files(tmp_path: Path) -> None:
    robot_pose_path(tmp_path, 1).write_text(opencv_text(scale_translation(T_ROBOT, 1e3)))
    object_pose_path(tmp_path, 1).write_text(opencv_text(scale_translation(T_OBJECT, 1e3)))
    one_pair(tmp_path, 2)  # a Zivid pair beside it: formats may be mixed
    first, second = read_dataset(tmp_path)
    # float32 data: 7 significant digits, so about 0.05 mm on a 450 mm translation.
    np.testing.assert_allclose(first.T_base_flange, second.T_base_flange, atol=1e-6)
    np.testing.assert_allclose(first.T_cam_obj, second.T_cam_obj, atol=1e-6)


def test_files_in_metres_read_with_units_m(tmp_path: Path) -> None:
    robot_pose_path(tmp_path, 0).write_text(opencv_text(T_ROBOT))
    object_pose_path(tmp_path, 0).write_text(opencv_text(T_OBJECT))
    (pair,) = read_dataset(tmp_path, "m")
    np.testing.assert_allclose(pair.T_cam_obj, T_OBJECT, atol=1e-6)
    with pytest.raises(CalibrationError, match=r"robot_pose_0.yaml.*declare m \(--units m\)"):
        read_dataset(tmp_path)


def test_object_pose_in_metres_read_as_mm_is_caught(tmp_path: Path) -> None:
    one_pair(tmp_path, 4)
    object_pose_path(tmp_path, 4).write_text(opencv_text(T_OBJECT))  # metres, declared mm
    with pytest.raises(CalibrationError, match=r"object_pose_4.yaml: calibration object distance"):
        read_dataset(tmp_path, flag="--units")


def test_other_files_are_ignored(tmp_path: Path) -> None:
    one_pair(tmp_path, 3)
    (tmp_path / "hand_eye_transform.yaml").write_text("not a pose")
    (tmp_path / "hand_eye_residuals.yaml").write_text("not a pose")
    (tmp_path / "img_3.zdf").write_bytes(b"\0")
    assert [p.number for p in read_dataset(tmp_path)] == [3]


@pytest.mark.parametrize(
    ("remove", "named", "missing"),
    [("object_pose_8.yaml", "robot_pose_8.yaml", "object_pose_8.yaml"),
     ("robot_pose_8.yaml", "object_pose_8.yaml", "robot_pose_8.yaml")],
)  # fmt: skip
def test_a_missing_half_is_an_error_naming_the_file(
    tmp_path: Path, remove: str, named: str, missing: str
) -> None:
    one_pair(tmp_path, 8)
    one_pair(tmp_path, 9)
    (tmp_path / remove).unlink()
    with pytest.raises(CalibrationError, match=rf"{tmp_path / named} has no {missing}"):
        read_dataset(tmp_path)


def test_two_files_for_one_number_are_refused(tmp_path: Path) -> None:
    one_pair(tmp_path, 3)
    (tmp_path / "robot_pose_03.yaml").write_text(robot_pose_path(tmp_path, 3).read_text())
    with pytest.raises(CalibrationError, match=r"robot_pose_03.yaml and .*robot_pose_3.yaml both"):
        read_dataset(tmp_path)


@pytest.mark.parametrize("name", ["robot_pose_3.yml", "robot_pose_a.yaml", "object_pose_-1.yaml"])
def test_a_misnamed_pose_file_is_refused_not_skipped(tmp_path: Path, name: str) -> None:
    one_pair(tmp_path, 1)
    (tmp_path / name).write_text(robot_pose_path(tmp_path, 1).read_text())
    with pytest.raises(CalibrationError, match=rf"{name}: a pose file must be named"):
        read_dataset(tmp_path)


def test_an_empty_folder_and_a_missing_folder_are_refused(tmp_path: Path) -> None:
    with pytest.raises(CalibrationError, match="holds no pairs"):
        read_dataset(tmp_path)
    with pytest.raises(CalibrationError, match="is not a folder"):
        read_dataset(tmp_path / "nowhere")


def test_an_invalid_transform_names_its_file(tmp_path: Path) -> None:
    one_pair(tmp_path, 6)
    object_pose_path(tmp_path, 6).write_text("[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]]\n")
    with pytest.raises(CalibrationError, match=r"object_pose_6.yaml.*list of 4 rows"):
        read_dataset(tmp_path)
