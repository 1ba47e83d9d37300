"""Detection files and camera points: mm in, metres out, every orientation form, clear refusals."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from handeye_pick.detection import Detection, Symmetry, detection_from_point_mm, load_detection
from handeye_pick.errors import DetectionError
from handeye_pick.geometry import rotation_angle_between

C45, S45 = math.cos(math.pi / 4), math.sin(math.pi / 4)
# The same rotation, 90 degrees about the camera z axis, in every accepted form.
R_Z90 = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
ORIENTATIONS = {
    "rotvec_rad": f"rotvec_rad: [0, 0, {math.pi / 2!r}]",
    "quaternion_xyzw": f"quaternion_xyzw: [0, 0, {S45!r}, {C45!r}]",
    "quaternion_wxyz": f"quaternion_wxyz: [{C45!r}, 0, 0, {S45!r}]",
    "rpy_deg": "rpy_deg: {angles: [0, 0, 90], convention: xyz}",
    "matrix": "matrix: [[0, -1, 0], [1, 0, 0], [0, 0, 1]]",
}


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "detection.yaml"
    path.write_text(text)
    return path


def test_position_only_file_is_metres_in_the_camera_frame(tmp_path: Path) -> None:
    path = _write(tmp_path, "position_mm: [83.95, 28.84, 305.7]\n")
    detection = load_detection(path)
    assert detection.position_only
    assert detection.source == str(path)
    np.testing.assert_allclose(detection.T_cam_obj[:3, 3], [0.08395, 0.02884, 0.3057])
    np.testing.assert_array_equal(detection.T_cam_obj[:3, :3], np.eye(3))


@pytest.mark.parametrize("form", sorted(ORIENTATIONS))
def test_every_orientation_form_gives_the_same_rotation(tmp_path: Path, form: str) -> None:
    path = _write(tmp_path, f"position_mm: [10, 20, 300]\norientation:\n  {ORIENTATIONS[form]}\n")
    detection = load_detection(path)
    assert not detection.position_only
    assert rotation_angle_between(detection.T_cam_obj[:3, :3], R_Z90) < 1e-9
    np.testing.assert_allclose(detection.T_cam_obj[:3, 3], [0.01, 0.02, 0.3])
    np.testing.assert_array_equal(detection.T_cam_obj[3], [0, 0, 0, 1])


def test_rpy_convention_matters(tmp_path: Path) -> None:
    def rotation(convention: str) -> np.ndarray:
        text = (
            "position_mm: [0, 0, 300]\norientation:\n"
            f"  rpy_deg: {{angles: [30, 40, 50], convention: {convention}}}\n"
        )
        return load_detection(_write(tmp_path, text)).T_cam_obj[:3, :3]

    assert rotation_angle_between(rotation("xyz"), rotation("XYZ")) > math.radians(1)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        (
            "position_mm: [1, 2, 300]\norientation:\n  rotvec_rad: [0, 0, 0]\n"
            "  matrix: [[1, 0, 0], [0, 1, 0], [0, 0, 1]]\n",
            r": orientation: give exactly one of .*\['rotvec_rad', 'matrix'\]",
        ),
        ("position_mm: [1, 2, 300]\norientation: {}\n", r": orientation: give exactly one of"),
        (
            "position_mm: [1, 2, 300]\norientation: [0, 0, 0]\n",
            r": orientation: expected a mapping",
        ),
        ("position_mm: [1, 2, 300]\nrotvec_rad: [0, 0, 0]\n", r": rotvec_rad: unknown key"),
        (
            "position_mm: [1, 2, 300]\norientation:\n  rotvec_deg: [0, 0, 90]\n",
            r": orientation\.rotvec_deg: unknown key",
        ),
        (
            "position_mm: [1, 2, 300]\norientation:\n  rpy_deg: {angles: [0, 0, 90]}\n",
            r": orientation\.rpy_deg\.convention: missing",
        ),
        (
            "position_mm: [1, 2, 300]\norientation:\n"
            "  rpy_deg: {angles: [0, 0, 90], convention: xyZ}\n",
            r": orientation\.rpy_deg: .*Euler sequence 'xyZ' is not valid",
        ),
        (
            "position_mm: [1, 2, 300]\norientation:\n  matrix: [[2, 0, 0], [0, 1, 0], [0, 0, 1]]\n",
            r": orientation\.matrix: .*not orthonormal",
        ),
        (
            "position_mm: [1, 2, 300]\norientation:\n"
            "  matrix: [[-1, 0, 0], [0, 1, 0], [0, 0, 1]]\n",
            r": orientation\.matrix: .*determinant",
        ),
        (
            "position_mm: [1, 2, 300]\norientation:\n  quaternion_xyzw: [0, 0, 0, 2]\n",
            r": orientation\.quaternion_xyzw: .*unit norm",
        ),
        (
            "position_mm: [1, 2, 300]\norientation:\n  quaternion_wxyz: [1, 0, 0]\n",
            r": orientation\.quaternion_wxyz: expected a list of 4 numbers",
        ),
        ("position_mm: [1, 2]\n", r": position_mm: expected a list of 3 numbers"),
        ("position_mm: [1, 2, .nan]\n", r": position_mm\[2\]: expected a finite number"),
        ("position_mm: [0.08, 0.03, 0.3]\n", r"position_mm: .*metres given as mm"),
        ("position_mm: [80, 30, -300]\n", r"position_mm: .*behind the camera"),
        ("orientation: {rotvec_rad: [0, 0, 0]}\n", r": position_mm: missing"),
        ("- 1\n- 2\n", r"top level: expected a mapping"),
        ("position_mm: [1, 2, 300\n", r"not valid YAML"),
        ("position_mm: [1, 2, 300]\nsize_mm: [0.05, 0.05, 0]\n", r": size_mm: .*metres given"),
        ("position_mm: [1, 2, 300]\nsymmetry: {axis: z, order: 5}\n", r"symmetry\.order: "),
        ("position_mm: [1, 2, 300]\nsymmetry: {axis: w, order: 2}\n", r"symmetry\.axis: "),
        ("position_mm: [1, 2, 300]\nsymmetry: {order: 2}\n", r"symmetry\.axis: missing"),
    ],
)
def test_bad_detection_file_is_refused_naming_file_and_key(
    tmp_path: Path, text: str, expected: str
) -> None:
    path = _write(tmp_path, text)
    with pytest.raises(DetectionError, match=expected) as info:
        load_detection(path)
    assert str(path) in str(info.value)


def test_missing_detection_file(tmp_path: Path) -> None:
    with pytest.raises(DetectionError, match="cannot read"):
        load_detection(tmp_path / "nope.yaml")


def test_point_detection_is_position_only_in_metres() -> None:
    detection = detection_from_point_mm([83.95, 28.84, 305.7], "--xyz")
    assert detection == Detection(detection.T_cam_obj, position_only=True, source="--xyz")
    np.testing.assert_allclose(detection.T_cam_obj[:3, 3], [0.08395, 0.02884, 0.3057])
    np.testing.assert_array_equal(detection.T_cam_obj[:3, :3], np.eye(3))


@pytest.mark.parametrize(
    ("point", "expected"),
    [
        ([1.0, 2.0], "3 coordinates"),
        ([1.0, float("nan"), 300.0], "non-finite"),
        ([0.08, 0.03, 0.3], "metres given as mm"),
        ([0.0, 0.0, 20_000.0], "20000 mm from the camera, expected 10 to 10000 mm$"),
        ([50.0, 0.0, -300.0], "behind the camera"),
    ],
)
def test_bad_camera_point_is_refused(point: list[float], expected: str) -> None:
    with pytest.raises(DetectionError, match=expected) as info:
        detection_from_point_mm(point, "--xyz")
    assert "--xyz" in str(info.value)


def test_size_and_symmetry_are_read_when_given(tmp_path: Path) -> None:
    text = (
        "position_mm: [1, 2, 300]\nsize_mm: [80, 60, 50]\nsymmetry: {axis: x, order: inf}\n"
    )
    detection = load_detection(_write(tmp_path, text))
    assert detection.size_mm == (80.0, 60.0, 50.0)
    assert detection.symmetry == Symmetry("x", 0)
    plain = load_detection(_write(tmp_path, "position_mm: [1, 2, 300]\n"))
    assert plain.size_mm is None
    assert plain.symmetry is None
