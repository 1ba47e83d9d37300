"""``handeye-pick cloud`` end to end: files in, transformed files out, exit 2 on bad input."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from numpy.typing import NDArray

from handeye_pick.cli import main
from handeye_pick.cloud.files import PointCloud, read_cloud, write_cloud


def write_zivid_matrix(path: Path, rows: list[list[float]]) -> Path:
    """A 4x4 in Zivid's YAML format (translation in mm)."""
    data = ",\n".join("    [" + ", ".join(repr(float(v)) for v in row) + "]" for row in rows)
    path.write_text(f"__version__:\n  serializer: 1\n  data: 1\nFloatMatrix:\n  Data: [\n{data}]\n")
    return path


def camera_cloud(rows: int = 6, cols: int = 8) -> NDArray[np.float32]:
    """An organized camera-frame cloud in mm (a table about 1.2 m away) with missing points."""
    rng = np.random.default_rng(11)
    xyz = np.stack(
        [
            rng.uniform(-300.0, 300.0, (rows, cols)),
            rng.uniform(-200.0, 200.0, (rows, cols)),
            rng.uniform(1100.0, 1300.0, (rows, cols)),
        ],
        axis=-1,
    ).astype(np.float32)
    xyz[rng.random((rows, cols)) < 0.2] = np.nan
    return xyz


def assert_transformed(result: NDArray[Any], expected: NDArray[np.float64]) -> None:
    assert result.dtype == np.float32
    assert result.shape == expected.shape
    np.testing.assert_array_equal(np.isnan(result), np.isnan(expected))
    # float32 coordinates near 1.5 m in mm: a few ulp is well under 1e-3 mm.
    np.testing.assert_allclose(result, expected, rtol=0, atol=1e-3)


@pytest.fixture
def eye_to_hand_file(tmp_path: Path) -> Path:
    # T_base_cam: camera 1.2 m above the base, looking down, x and y swapped (mm).
    return write_zivid_matrix(
        tmp_path / "EyeToHandTransform.yaml",
        [[0, 1, 0, 500], [1, 0, 0, -40], [0, 0, -1, 1200], [0, 0, 0, 1]],
    )


@pytest.fixture
def eye_in_hand_file(tmp_path: Path) -> Path:
    # T_flange_cam: camera turned 90 degrees about the flange z axis, 50 mm aside, 100 mm out.
    return write_zivid_matrix(
        tmp_path / "EyeInHandTransform.yaml",
        [[0, -1, 0, 0], [1, 0, 0, 50], [0, 0, 1, 100], [0, 0, 0, 1]],
    )


def test_eye_to_hand_npy(
    tmp_path: Path, eye_to_hand_file: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    xyz = camera_cloud()
    write_cloud(tmp_path / "cam.npy", PointCloud(xyz=xyz))

    status = main(
        [
            "cloud",
            "--mode",
            "eye-to-hand",
            "--calibration",
            str(eye_to_hand_file),
            str(tmp_path / "cam.npy"),
            str(tmp_path / "base.npy"),
        ]
    )

    assert status == 0
    p = xyz.astype(np.float64)
    # p_base = (y + 500, x - 40, 1200 - z), worked out by hand from the file above.
    expected = np.stack([p[..., 1] + 500, p[..., 0] - 40, 1200 - p[..., 2]], axis=-1)
    assert_transformed(read_cloud(tmp_path / "base.npy").xyz, expected)
    missing = int(np.isnan(xyz).any(axis=-1).sum())
    assert f"48 points ({missing} without data)" in capsys.readouterr().out


def eye_in_hand_expected(xyz: NDArray[np.float32]) -> NDArray[np.float64]:
    # T_base_flange: flange at (400, 100, 300) mm, tool pointing down (rotation pi about y).
    # T_base_cam = T_base_flange @ T_flange_cam: R = [[0,1,0],[1,0,0],[0,0,-1]],
    # t = (400, 150, 200) mm, so p_base = (y + 400, x + 150, 200 - z).
    p = xyz.astype(np.float64)
    return np.stack([p[..., 1] + 400, p[..., 0] + 150, 200 - p[..., 2]], axis=-1)


def test_eye_in_hand_ply_with_ur_pose_keeps_colours(tmp_path: Path, eye_in_hand_file: Path) -> None:
    xyz = camera_cloud().reshape(-1, 3)
    rgb = np.random.default_rng(2).integers(0, 256, xyz.shape, dtype=np.uint8)
    write_cloud(tmp_path / "cam.ply", PointCloud(xyz=xyz, rgb=rgb))

    status = main(
        [
            "cloud",
            "--mode",
            "eye-in-hand",
            "--calibration",
            str(eye_in_hand_file),
            "--robot-pose-ur",
            "0.4",
            "0.1",
            "0.3",
            "0",
            str(np.pi),
            "0",
            str(tmp_path / "cam.ply"),
            str(tmp_path / "base.ply"),
        ]
    )

    assert status == 0
    result = read_cloud(tmp_path / "base.ply")
    assert_transformed(result.xyz, eye_in_hand_expected(xyz))
    assert result.rgb is not None
    np.testing.assert_array_equal(result.rgb, rgb)


def test_eye_in_hand_robot_pose_file_and_metre_cloud(
    tmp_path: Path, eye_in_hand_file: Path
) -> None:
    pose = write_zivid_matrix(
        tmp_path / "RobotTransform.yaml",
        [[-1, 0, 0, 400], [0, 1, 0, 100], [0, 0, -1, 300], [0, 0, 0, 1]],
    )
    xyz_mm = camera_cloud()
    write_cloud(tmp_path / "cam_m.npy", PointCloud(xyz=xyz_mm / np.float32(1000.0)))

    status = main(
        [
            "cloud",
            "--mode=eye-in-hand",
            f"--calibration={eye_in_hand_file}",
            f"--robot-pose={pose}",
            "--cloud-units=m",
            str(tmp_path / "cam_m.npy"),
            str(tmp_path / "base_m.ply"),
        ]
    )

    assert status == 0
    result_m = read_cloud(tmp_path / "base_m.ply").xyz
    assert result_m.shape == (48, 3)  # PLY holds a vertex list
    expected_mm = eye_in_hand_expected((xyz_mm / np.float32(1000.0)) * 1000).reshape(-1, 3)
    assert_transformed(result_m * 1000, expected_mm)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"in": "missing.npy"}, "file not found"),
        ({"out": "base.txt"}, "unsupported file type '.txt'"),
        ({"in": "bad.npy"}, "expected shape (H, W, 3) or (N, 3)"),
        ({"calibration": "missing.yaml"}, "missing.yaml"),
        ({"mode": "eye-in-hand"}, "needs the flange pose"),
        ({"out": None}, "OUT"),
    ],
    ids=[
        "missing-in",
        "bad-out-suffix",
        "bad-in-shape",
        "missing-calibration",
        "no-pose",
        "no-out",
    ],
)
def test_bad_input_exits_2_with_one_line(
    tmp_path: Path,
    eye_to_hand_file: Path,
    capsys: pytest.CaptureFixture[str],
    change: dict[str, str | None],
    message: str,
) -> None:
    write_cloud(tmp_path / "cam.npy", PointCloud(xyz=camera_cloud()))
    np.save(tmp_path / "bad.npy", np.zeros((5, 4), dtype=np.float32))
    calibration = tmp_path / change["calibration"] if "calibration" in change else eye_to_hand_file
    argv = [
        "cloud",
        "--mode",
        change.get("mode") or "eye-to-hand",
        "--calibration",
        str(calibration),
        str(tmp_path / (change.get("in") or "cam.npy")),
    ]
    out_name = change.get("out", "base.npy")
    if out_name is not None:
        argv.append(str(tmp_path / out_name))

    status = main(argv)

    assert status == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ")
    assert err.count("\n") == 1
    assert message in err
    assert not (tmp_path / "base.npy").exists()
    assert not (tmp_path / "base.txt").exists()


def test_bundled_example_lands_on_the_table(tmp_path: Path) -> None:
    # The example cloud is a table (base z = 0) with an 80 mm box, seen by the example camera.
    root = Path(__file__).resolve().parents[2]
    status = main(
        [
            "cloud",
            "--mode",
            "eye-to-hand",
            "--calibration",
            str(root / "config" / "calibration" / "EyeToHandTransform.yaml"),
            str(root / "examples" / "table_box_camera_mm.npy"),
            str(tmp_path / "base.npy"),
        ]
    )

    assert status == 0
    z_mm = read_cloud(tmp_path / "base.npy").xyz[..., 2]
    valid = z_mm[~np.isnan(z_mm)]
    on_table = np.abs(valid) < 0.01
    on_box = np.abs(valid - 80.0) < 0.01
    assert np.all(on_table | on_box)
    assert on_box.sum() > 5


def test_a_wrist_camera_file_used_as_a_fixed_camera_is_refused(
    tmp_path: Path, eye_in_hand_file: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    write_cloud(tmp_path / "cam.npy", PointCloud(xyz=camera_cloud()))
    argv = ["cloud", "--mode", "eye-to-hand", "--calibration", str(eye_in_hand_file)]
    status = main([*argv, str(tmp_path / "cam.npy"), str(tmp_path / "base.npy")])
    assert status == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "camera-away-from-base: the camera is 112 mm from the robot base origin" in err
    assert "set --mode eye-in-hand" in err
    assert not (tmp_path / "base.npy").exists()


# Run under a 1 GiB address-space limit: reading a hostile file's data, or allocating what its
# header claims (terabytes), would end in a MemoryError (exit 1), not in exit 2 and one line.
_BOUNDED = """
import resource, sys
resource.setrlimit(resource.RLIMIT_AS, (1 << 30, 1 << 30))
from handeye_pick.cli import main
sys.exit(main(sys.argv[1:]))
"""


@pytest.mark.parametrize("name", ["claims-1e12.npy", "claims-1e10.ply"])
@pytest.mark.parametrize("command", ["cloud", "point"])
def test_header_claiming_terabytes_exits_2_with_one_line_in_bounded_memory(
    tmp_path: Path, eye_to_hand_file: Path, name: str, command: str
) -> None:
    path = tmp_path / name
    if name.endswith(".npy"):
        with path.open("wb") as file:  # a header claiming 10^12 float32 points, then 48 bytes
            header = {"descr": "<f4", "fortran_order": False, "shape": (10**6, 10**6, 3)}
            np.lib.format.write_array_header_1_0(file, header)
            file.write(bytes(48))
    else:
        path.write_bytes(
            b"ply\nformat binary_little_endian 1.0\nelement vertex 10000000000\n"
            b"property float x\nproperty float y\nproperty float z\nend_header\n" + bytes(48)
        )
    hand_eye = ["--mode", "eye-to-hand", "--calibration", str(eye_to_hand_file)]
    if command == "cloud":
        argv = ["cloud", *hand_eye, str(path), str(tmp_path / "out.ply")]
    else:
        argv = ["point", *hand_eye, "--cloud", str(path), "--pixel", "0", "0"]

    result = subprocess.run(
        [sys.executable, "-c", _BOUNDED, *argv],
        capture_output=True,
        text=True,
        timeout=60,  # a hang guard, not a timing assertion
        check=False,
    )

    assert result.returncode == 2, result.stderr
    assert result.stderr.startswith(f"error: read cloud {path}: not a readable")
    assert result.stderr.count("\n") == 1
    assert "declares" in result.stderr
    assert not (tmp_path / "out.ply").exists()


def test_in_and_out_may_be_the_same_file(tmp_path: Path, eye_to_hand_file: Path) -> None:
    # OUT is written next to itself and renamed into place, so IN is read whole first.
    xyz = camera_cloud(rows=40, cols=50)
    path = tmp_path / "cloud.npy"
    write_cloud(path, PointCloud(xyz=xyz))

    hand_eye = ["--mode", "eye-to-hand", "--calibration", str(eye_to_hand_file)]
    status = main(["cloud", *hand_eye, str(path), str(path)])

    assert status == 0
    p = xyz.astype(np.float64)
    expected = np.stack([p[..., 1] + 500, p[..., 0] - 40, 1200 - p[..., 2]], axis=-1)
    assert_transformed(read_cloud(path).xyz, expected)
    assert sorted(f.name for f in tmp_path.iterdir()) == ["EyeToHandTransform.yaml", "cloud.npy"]
