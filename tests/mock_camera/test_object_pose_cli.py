"""`python -m mocks.camera object-pose`: a capture command for `handeye-pick collect`, reading
the simulated arm over RTDE from a process of its own."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from mocks.camera import read_flange_pose, read_zivid_matrix
from mocks.ur_controller import SimulatedController
from tests.conftest import next_loopback_host
from tests.mock_camera.helpers import pose

ROOT = Path(__file__).resolve().parents[2]
CAMERA = ["0", "0", "0.05", "0", "0", "0"]  # T_flange_cam: 50 mm along the tool, looking down
EXACT = ["--noise-mm", "0", "--noise-deg", "0"]


def _flange(ctl: SimulatedController) -> np.ndarray:
    return pose(*ctl.snapshot().flange_pose)


def _args(*values: float) -> list[str]:
    """Floats spelled for a command line, exactly."""
    return [repr(float(v)) for v in values]


def _object_pose(host: str, *args: str, env: dict[str, str] | None = None,
                 ) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "mocks.camera", "object-pose", "--host", host, *args],
        cwd=ROOT, env={**os.environ, **(env or {})}, capture_output=True, text=True,
        timeout=60, check=False,
    )


@pytest.fixture
def ctl(sim_controller: Callable[..., SimulatedController]) -> SimulatedController:
    return sim_controller(instant=True, tcp_offset=(0, 0, 0.12, 0, 0, 0))


def test_the_flange_pose_read_over_rtde_is_the_controllers(ctl: SimulatedController) -> None:
    np.testing.assert_allclose(read_flange_pose(ctl.host), _flange(ctl), atol=1e-9)


def test_eye_in_hand_writes_the_boards_pose_to_the_file_collect_names(
    ctl: SimulatedController, tmp_path: Path
) -> None:
    T_base_flange = _flange(ctl)
    x, y = T_base_flange[0, 3], T_base_flange[1, 3]
    board = _args(x + 0.02, y, 0, math.pi, 0, 0)  # on the table, face up
    out = tmp_path / "object_pose_3.yaml"
    result = _object_pose(ctl.host, "--mode", "eye-in-hand", "--camera", *CAMERA,
                          "--board", *board, *EXACT, env={"HANDEYE_OBJECT_POSE_FILE": str(out)})
    assert result.returncode == 0, result.stderr
    T_cam_obj = np.linalg.inv(T_base_flange @ pose(*map(float, CAMERA))) \
        @ pose(*map(float, board))
    T_cam_obj[:3, 3] *= 1000.0
    np.testing.assert_allclose(read_zivid_matrix(out), T_cam_obj, atol=1e-6)


def test_eye_to_hand_measures_the_board_the_arm_carries(
    ctl: SimulatedController, tmp_path: Path
) -> None:
    T_base_flange = _flange(ctl)
    # On the table under the flange, looking up at a board hanging face down from the flange.
    camera = _args(T_base_flange[0, 3], T_base_flange[1, 3], 0, 0, 0, 0.3)
    board = _args(0, 0, 0.02, math.pi, 0, 0)
    out = tmp_path / "pose.yaml"
    result = _object_pose(ctl.host, "--mode", "eye-to-hand", "--camera", *camera,
                          "--board", *board, *EXACT, "--out", str(out))
    assert result.returncode == 0, result.stderr
    T_cam_obj = np.linalg.inv(pose(*map(float, camera))) @ T_base_flange \
        @ pose(*map(float, board))
    T_cam_obj[:3, 3] *= 1000.0
    np.testing.assert_allclose(read_zivid_matrix(out), T_cam_obj, atol=1e-6)


def test_each_pose_index_gets_its_own_reproducible_noise(
    ctl: SimulatedController, tmp_path: Path
) -> None:
    T_base_flange = _flange(ctl)
    board = _args(T_base_flange[0, 3], T_base_flange[1, 3], 0, math.pi, 0, 0)

    def measure(index: str, name: str) -> np.ndarray:
        out = tmp_path / name
        result = _object_pose(ctl.host, "--mode", "eye-in-hand", "--camera", *CAMERA,
                              "--board", *board, "--seed", "5", "--out", str(out),
                              env={"HANDEYE_POSE_INDEX": index})
        assert result.returncode == 0, result.stderr
        return read_zivid_matrix(out)

    first, again, other = measure("0", "a.yaml"), measure("0", "b.yaml"), measure("1", "c.yaml")
    np.testing.assert_array_equal(first, again)
    assert not np.allclose(first, other)
    assert np.abs(first - other)[:3, 3].max() < 3.0  # noise of a few tenths of a mm, not more


def test_a_board_out_of_view_writes_nothing_and_exits_3(
    ctl: SimulatedController, tmp_path: Path
) -> None:
    out = tmp_path / "pose.yaml"
    result = _object_pose(ctl.host, "--mode", "eye-in-hand", "--camera", *CAMERA,
                          "--board", *_args(0.5, 0.5, 0, math.pi, 0, 0), "--out", str(out))
    assert result.returncode == 3
    assert "no board found: the board's centre is off the image" in result.stderr
    assert not out.exists()


def test_no_robot_to_read_writes_nothing_and_exits_4(tmp_path: Path) -> None:
    out = tmp_path / "pose.yaml"
    result = _object_pose(next_loopback_host(), "--mode", "eye-in-hand", "--camera", *CAMERA,
                          "--board", "0", "0", "0", "0", "0", "0", "--out", str(out))
    assert result.returncode == 4
    assert "cannot read the robot's pose" in result.stderr
    assert not out.exists()


def test_without_an_output_file_it_exits_2() -> None:
    env = {k: v for k, v in os.environ.items() if k != "HANDEYE_OBJECT_POSE_FILE"}
    result = subprocess.run(
        [sys.executable, "-m", "mocks.camera", "object-pose", "--host", "127.0.0.9",
         "--mode", "eye-in-hand", "--camera", *CAMERA, "--board", *CAMERA],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=60, check=False,
    )
    assert result.returncode == 2
    assert "give --out or set HANDEYE_OBJECT_POSE_FILE" in result.stderr
