"""A pick without a capture pose chains the detection from the live flange pose: when the arm has
moved since the image, its targets are wrong and a check refuses them. The refusal must say that
the pose it used is where the arm stands now, not where the image was taken, and how to give
the capture pose. The real ur_rtde against the simulated controller; judged on what the
operator reads, the audit file and the controller's command record.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path

import numpy as np

from handeye_pick import Cell
from mocks.ur_controller import SimulatedController
from tests.integration.test_pick_cli import (
    DEMO,
    TCP_OFFSET,
    assert_pose,
    audit_records,
    motion_commands,
    run_pick,
    write_config,
)

SimFactory = Callable[..., SimulatedController]
# The simulated arm's home TCP (where the demo detection's image was taken), 10 cm lower: the
# demo grasp chained from there lies 5 cm below the workspace's floor.
LOWER = [-0.4919, -0.1333, 0.2679, 2.221441469, 2.221441469, 0.0]
LIVE_POSE = re.compile(r"live flange pose \[([^\]]+)\] \(m, rad\)")


def test_a_refusal_from_the_live_pose_says_so_and_how_to_give_the_capture_pose(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    at_image = ctl.snapshot().flange_pose
    config = write_config(tmp_path, ctl.host, poses=f"  lower: {{tcp_pose: {LOWER}}}\n")
    with Cell(config) as cell:  # the arm moves on after the image was taken
        cell.move_to("lower")
    moved = len(motion_commands(ctl))
    now = ctl.snapshot().flange_pose
    assert abs(now[2] - at_image[2]) > 0.09

    refused = run_pick(config, "--detection", str(DEMO / "detection.yaml"))

    assert refused.returncode == 3, refused.stderr
    error = refused.stderr.strip().splitlines()[-1]
    assert error.startswith("error: pre-flight checks refused the pick"), error
    assert "grasp workspace" in error, error
    used = LIVE_POSE.search(error)
    assert used is not None, error
    assert_pose([float(v) for v in used.group(1).split(",")], now, atol=2e-4)
    assert "where the arm stands now, not where the image was taken" in error, error
    assert "capture.flange_pose_ur" in error, error
    assert "--capture-pose-ur X Y Z RX RY RZ" in error, error
    assert len(motion_commands(ctl)) == moved  # nothing moved
    outcome = audit_records(tmp_path)[-1]
    assert (outcome["event"], outcome["status"]) == ("outcome", "refused")
    assert outcome["error"]["message"] == error.removeprefix("error: ")

    # The advice works: given the pose the image was taken at, the same pick passes every check.
    given = run_pick(
        config,
        "--detection",
        str(DEMO / "detection.yaml"),
        "--dry-run",
        "--capture-pose-ur",
        *(repr(v) for v in at_image),
    )
    assert given.returncode == 0, given.stderr
    assert np.allclose(ctl.snapshot().flange_pose, now)
