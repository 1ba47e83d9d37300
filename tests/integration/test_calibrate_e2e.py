"""The three calibration commands end to end in the simulator, for both hand-eye modes:
``poses`` against the simulated controller, ``collect`` with the simulated camera as the capture
command, ``calibrate``; the result compared with the camera mount the simulator used.

The simulated camera measures the board with 0.1 mm noise across its view, 0.3 mm along its
optical axis and 0.02 degrees (one standard deviation per axis); the simulated arm reports its
flange exactly. With 8 pairs the accuracy benchmark's p90 at this noise is about 0.25 mm and
0.025 degrees, so the tolerances (1 mm, 0.1 degree) hold with a wide margin and still fail on a
wrong direction, a mm/m slip, a mispaired pose or a stale flange pose (each costs millimetres to
centimetres). The noise is seeded by the pair number, so a run is reproducible. The rough mount
in the cell's hand-eye file is 7 mm and about 1 degree off: the result must come from the data.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from handeye_pick.geometry import rotation_angle_between, ur_pose_to_matrix
from handeye_pick.hand_eye.files import read_transform_file
from mocks.ur_controller import SimulatedController
from tests.integration.handeye_cell import (
    TCP_OFFSET,
    TRUE_CAMERA,
    capture_command,
    cli,
    poses_args,
    write_cell,
)

SimFactory = Callable[..., SimulatedController]
POSE_COUNT = 8
TOLERANCE_MM = 1.0
TOLERANCE_DEG = 0.1


def error_mm_deg(T: np.ndarray, T_true: np.ndarray) -> tuple[float, float]:
    position_mm = float(np.linalg.norm(T[:3, 3] - T_true[:3, 3])) * 1000.0
    return position_mm, math.degrees(rotation_angle_between(T[:3, :3], T_true[:3, :3]))


@pytest.mark.parametrize("mode", ["eye-in-hand", "eye-to-hand"])
def test_poses_collect_calibrate_finds_the_true_mount(
    sim_controller: SimFactory, tmp_path: Path, mode: str
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    config = write_cell(tmp_path, ctl.host, mode)
    poses_file, dataset = tmp_path / "poses.yaml", tmp_path / "dataset"

    proposed = cli(
        "poses", "--config", str(config), *poses_args(mode), "--count", str(POSE_COUNT),
        "--out", str(poses_file), "--json",
    )  # fmt: skip
    assert proposed.returncode == 0, proposed.stderr
    assert len(json.loads(proposed.stdout)["poses"]) == POSE_COUNT

    collected = cli(
        "collect", "--config", str(config), "--poses", str(poses_file), "--out", str(dataset),
        "--capture-command", capture_command(ctl.host, mode), "--json",
    )  # fmt: skip
    assert collected.returncode == 0, collected.stderr
    report = json.loads(collected.stdout)
    assert report["pairs"] == list(range(POSE_COUNT)), report
    assert report["skipped"] == []

    solved = cli("calibrate", "--mode", mode, str(dataset), "--json")
    assert solved.returncode == 0, solved.stderr
    result = json.loads(solved.stdout)
    assert result["suspects"] == []
    T_true = ur_pose_to_matrix(TRUE_CAMERA[mode])
    T_rough = read_transform_file(tmp_path / "hand_eye.yaml", "mm")
    T_file = read_transform_file(dataset / "hand_eye_transform.yaml", "mm")
    np.testing.assert_allclose(T_file, np.array(result["transform_m"]), atol=1e-9)
    position_mm, rotation_deg = error_mm_deg(T_file, T_true)
    assert position_mm < TOLERANCE_MM, (position_mm, rotation_deg)
    assert rotation_deg < TOLERANCE_DEG, (position_mm, rotation_deg)
    rough_mm, rough_deg = error_mm_deg(T_rough, T_true)  # the data, not the start, gave it
    assert rough_mm > 5 * TOLERANCE_MM
    assert rough_deg > 5 * TOLERANCE_DEG
