"""``collect`` and ``poses`` against the simulated controller: skipped poses leave nothing
behind, numbering, refusals before any motion, Ctrl-C and SIGTERM, the operator's Enter, and
``Cell.check_pose``.

Robot poses in the dataset are checked against the poses commanded (the simulated arm reaches
them exactly), motions against the controller's command record.
"""

from __future__ import annotations

import json
import math
import os
import pty
import select
import shlex
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from handeye_pick.calibration.dataset import read_dataset
from handeye_pick.cell.session import Cell
from handeye_pick.geometry import (
    invert,
    make_transform,
    rotation_from_rotvec,
    ur_pose_list,
    ur_pose_to_matrix,
)
from handeye_pick.hand_eye.files import read_robot_pose_file, write_zivid_transform
from mocks.ur_controller import SimulatedController
from tests.integration.handeye_cell import (
    CLI,
    ROOT,
    TCP_OFFSET,
    capture_command,
    cli,
    write_cell,
)

SimFactory = Callable[..., SimulatedController]
MODE = "eye-in-hand"
# TCP 335 mm above the board's centre, tool straight down: the wrist camera (55 mm below the
# flange, 120 mm TCP) looks down at the board from 400 mm. Yaw turns it about the optical axis.
BOARD_CENTRE_M = (-0.5, -0.12)
OUTSIDE_WORKSPACE = [-0.5, -0.12, 0.01, math.pi, 0.0, 0.0]  # TCP 10 mm above the base plane
# A stand-in for the integrator's capture program: behaves as its plan says on each call
# (counted in a state file) and logs what it was given; "ok" runs the real simulated camera.
CAPTURE_STUB = """\
import json, os, subprocess, sys, time
plan, state, log, camera = sys.argv[1].split(","), sys.argv[2], sys.argv[3], sys.argv[4:]
call = (int(open(state).read()) if os.path.exists(state) else 0) + 1
open(state, "w").write(str(call))
out = os.environ["HANDEYE_OBJECT_POSE_FILE"]
given = {"index": os.environ["HANDEYE_POSE_INDEX"], "file": out, "pid": os.getpid()}
with open(log, "a") as f:
    f.write(json.dumps(given) + "\\n")
kind = plan[call - 1] if call <= len(plan) else "ok"
if kind == "garbage":
    open(out, "w").write("FloatMatrix: {Data: [[1, 2, 3]]}\\n")
elif kind == "metres":
    open(out, "w").write("[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0.4], [0, 0, 0, 1]]\\n")
elif kind == "fail":
    print("camera not connected", file=sys.stderr)
    sys.exit(1)
elif kind == "hang":
    time.sleep(60)
elif kind == "ok":
    sys.exit(subprocess.call(camera))
"""


def tcp_pose_down(dx_m: float = 0.0, dy_m: float = 0.0, yaw_deg: float = 0.0) -> list[float]:
    """A TCP pose (UR vector) over the board, tool straight down, yawed about the vertical."""
    R = rotation_from_rotvec([0.0, 0.0, math.radians(yaw_deg)]) @ rotation_from_rotvec(
        [math.pi, 0.0, 0.0]
    )
    return ur_pose_list(
        make_transform(R, [BOARD_CENTRE_M[0] + dx_m, BOARD_CENTRE_M[1] + dy_m, 0.335])
    )


# Six poses the board is seen from, 20 mm and 30 degrees of yaw apart.
GOOD_POSES = [tcp_pose_down(0.02 * (i % 3 - 1), 0.02 * (i // 3), 30.0 * i - 75.0) for i in range(6)]


def write_poses(path: Path, tcp_poses: list[list[float]]) -> Path:
    path.write_text(
        f"tcp_offset: {list(TCP_OFFSET)}\nposes:\n"
        + "".join(f"  - tcp_pose: {pose}\n" for pose in tcp_poses)
    )
    return path


def stub_command(tmp_path: Path, host: str, plan: str) -> str:
    stub = tmp_path / "capture_stub.py"
    stub.write_text(CAPTURE_STUB)
    camera = shlex.split(capture_command(host, MODE))
    argv = [sys.executable, str(stub), plan, str(tmp_path / "calls"), str(tmp_path / "calls.jsonl")]
    return shlex.join([*argv, *camera])


def stub_calls(tmp_path: Path) -> list[dict[str, Any]]:
    path = tmp_path / "calls.jsonl"
    return [json.loads(line) for line in path.read_text().splitlines()] if path.exists() else []


def audit(tmp_path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in (tmp_path / "audit.jsonl").read_text().splitlines()]


def motions(ctl: SimulatedController) -> list[str]:
    return [c["kind"] for c in ctl.commands if c["kind"].startswith("move")]


def dataset_files(dataset: Path) -> list[str]:
    return sorted(p.name for p in dataset.iterdir())


def collect_args(config: Path, poses: Path, dataset: Path, *extra: str) -> list[str]:
    return [
        "collect",
        "--config",
        str(config),
        "--poses",
        str(poses),
        "--out",
        str(dataset),
        *extra,
    ]


def test_failed_captures_and_refused_poses_are_skipped_without_a_trace(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    config = write_cell(tmp_path, ctl.host, MODE)
    listed = [*GOOD_POSES[:4], OUTSIDE_WORKSPACE, *GOOD_POSES[4:]]
    poses = write_poses(tmp_path / "poses.yaml", listed)
    dataset = tmp_path / "dataset"
    command = stub_command(tmp_path, ctl.host, "ok,garbage,metres,fail,ok,ok")

    result = cli(*collect_args(config, poses, dataset, "--capture-command", command, "--json"))

    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert report["status"] == "done"
    assert report["pairs"] == [0, 1, 2]  # a skipped pose does not use up its number
    skipped = {s["pose"]: s["reason"] for s in report["skipped"]}
    assert list(skipped) == ["pose 1", "pose 2", "pose 3", "pose 4"]
    assert "pending_object_pose_1.yaml" in skipped["pose 1"]  # the file that did not read
    assert "--units m" in skipped["pose 2"]  # a file in metres, with the unit to declare
    assert "exited with status 1: camera not connected" in skipped["pose 3"]
    assert "workspace" in skipped["pose 4"]
    assert [c["index"] for c in stub_calls(tmp_path)] == ["0", "1", "1", "1", "1", "2"]
    assert {c["file"] for c in stub_calls(tmp_path)} == {
        str(dataset / f"pending_object_pose_{n}.yaml") for n in (0, 1, 2)
    }
    # Only whole pairs: no pending file, no half pair, and calibrate's reader takes them all.
    assert dataset_files(dataset) == sorted(
        f"{kind}_pose_{n}.yaml" for kind in ("robot", "object") for n in (0, 1, 2)
    )
    assert [pair.number for pair in read_dataset(dataset)] == [0, 1, 2]
    T_tcp_flange = invert(ur_pose_to_matrix(list(TCP_OFFSET)))
    for number, pose in enumerate([GOOD_POSES[0], *GOOD_POSES[4:]]):  # pairs 0, 1, 2
        np.testing.assert_allclose(
            read_robot_pose_file(dataset / f"robot_pose_{number}.yaml"),
            ur_pose_to_matrix(pose) @ T_tcp_flange,
            atol=1e-4,
        )
    # The refused pose never moved; every other pose moved once and latched once, audited.
    assert motions(ctl) == ["moveL"] * 6
    records = audit(tmp_path)
    outcomes = [r for r in records if r["event"] == "outcome"]
    assert [r["status"] for r in outcomes] == ["done"] * 4 + ["refused"] + ["done"] * 2
    assert outcomes[4]["request_id"] == "collect pose 4"
    assert len([r for r in records if r["event"] == "capture"]) == 6


def test_a_dataset_with_pairs_needs_append_and_numbering_continues(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    config = write_cell(tmp_path, ctl.host, MODE)
    dataset = tmp_path / "dataset"
    dataset.mkdir()
    for number in (0, 3):  # an earlier collection; numbers need not be contiguous
        T_base_flange = ur_pose_to_matrix(GOOD_POSES[number])
        write_zivid_transform(dataset / f"robot_pose_{number}.yaml", T_base_flange, "mm")
        T_cam_obj = make_transform(np.eye(3), [0.0, 0.0, 0.4])
        write_zivid_transform(dataset / f"object_pose_{number}.yaml", T_cam_obj, "mm")
    command = capture_command(ctl.host, MODE)
    poses = write_poses(tmp_path / "poses.yaml", GOOD_POSES[1:3])

    refused = cli(*collect_args(config, poses, dataset, "--capture-command", command))
    assert refused.returncode == 2
    assert "--append" in refused.stderr
    assert motions(ctl) == []  # refused before connecting

    appended = cli(
        *collect_args(config, poses, dataset, "--capture-command", command, "--append", "--json")
    )
    assert appended.returncode == 0, appended.stderr
    assert json.loads(appended.stdout)["pairs"] == [4, 5]
    assert [pair.number for pair in read_dataset(dataset)] == [0, 3, 4, 5]


def test_sigterm_during_a_capture_kills_it_and_keeps_the_pairs(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    config = write_cell(tmp_path, ctl.host, MODE)
    poses = write_poses(tmp_path / "poses.yaml", GOOD_POSES[:3])
    dataset = tmp_path / "dataset"
    command = stub_command(tmp_path, ctl.host, "ok,hang")
    collect = subprocess.Popen(
        [*CLI, *collect_args(config, poses, dataset, "--capture-command", command, "--json")],
        cwd=ROOT,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.monotonic() + 60.0
        while len(stub_calls(tmp_path)) < 2 and time.monotonic() < deadline:
            time.sleep(0.05)  # the second capture is hanging
        hanging = stub_calls(tmp_path)[1]["pid"]
        collect.send_signal(signal.SIGTERM)
        out, err = collect.communicate(timeout=60)
    finally:
        if collect.poll() is None:
            collect.kill()
    assert collect.returncode == 143, err
    report = json.loads(out)
    assert report["status"] == "interrupted"
    assert report["pairs"] == [0]
    with pytest.raises(ProcessLookupError):  # the capture program did not outlive the run
        os.kill(hanging, 0)
    assert dataset_files(dataset) == ["object_pose_0.yaml", "robot_pose_0.yaml"]
    assert motions(ctl) == ["moveL"] * 2


def test_ctrl_c_during_a_move_stops_the_arm_and_keeps_the_pairs(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, speed_factor=0.2)
    config = write_cell(tmp_path, ctl.host, MODE)
    far = tcp_pose_down(0.25, 0.3)  # a long move after the first pair
    poses = write_poses(tmp_path / "poses.yaml", [GOOD_POSES[0], far, GOOD_POSES[1]])
    dataset = tmp_path / "dataset"
    command = capture_command(ctl.host, MODE)
    collect = subprocess.Popen(
        [*CLI, *collect_args(config, poses, dataset, "--capture-command", command)],
        cwd=ROOT,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert collect.stderr is not None
        for line in collect.stderr:
            if line.startswith("pose 1 (2 of 3)"):  # pair 0 is written, the long move starts
                break
        deadline = time.monotonic() + 30.0
        while not ctl.snapshot().moving and time.monotonic() < deadline:
            time.sleep(0.01)
        collect.send_signal(signal.SIGINT)
        out, rest = collect.communicate(timeout=60)
    finally:
        if collect.poll() is None:
            collect.kill()
    assert collect.returncode == 130, rest
    assert [c["kind"] for c in ctl.commands][-2:] == ["moveL", "stopL"]
    assert not ctl.snapshot().moving
    assert "collected 1 pairs" in out
    assert dataset_files(dataset) == ["object_pose_0.yaml", "robot_pose_0.yaml"]
    assert audit(tmp_path)[-1]["status"] == "interrupted"


def test_without_a_command_the_operator_captures_and_presses_enter(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    config = write_cell(tmp_path, ctl.host, MODE)
    poses = write_poses(tmp_path / "poses.yaml", GOOD_POSES[:2])
    dataset = tmp_path / "dataset"
    T_cam_obj = make_transform(np.eye(3), [0.01, -0.02, 0.4])  # what the operator's tool saw
    terminal, terminal_side = pty.openpty()
    collect = subprocess.Popen(
        [*CLI, *collect_args(config, poses, dataset, "--json")],
        cwd=ROOT,
        stdin=terminal_side,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    try:
        assert collect.stderr is not None
        prompt = read_until(collect.stderr.fileno(), b"press Enter")
        assert str(dataset / "pending_object_pose_0.yaml").encode() in prompt
        write_zivid_transform(dataset / "pending_object_pose_0.yaml", T_cam_obj, "mm")
        os.write(terminal, b"\n")
        read_until(collect.stderr.fileno(), b"press Enter")  # pose 1: Enter alone skips it
        os.write(terminal, b"\n")
        out, err = collect.communicate(timeout=60)
    finally:
        os.close(terminal)
        os.close(terminal_side)
        if collect.poll() is None:
            collect.kill()
    assert collect.returncode == 0, err
    report = json.loads(out)
    assert report["pairs"] == [0]
    assert [s["pose"] for s in report["skipped"]] == ["pose 1"]
    assert "no file was written" in report["skipped"][0]["reason"]
    assert dataset_files(dataset) == ["object_pose_0.yaml", "robot_pose_0.yaml"]


def read_until(fd: int, marker: bytes, timeout_s: float = 60.0) -> bytes:
    """Read ``fd`` until ``marker`` appears (a prompt ends without a newline)."""
    seen = b""
    deadline = time.monotonic() + timeout_s
    while marker not in seen:
        ready, _, _ = select.select([fd], [], [], max(0.0, deadline - time.monotonic()))
        chunk = os.read(fd, 4096) if ready else b""
        if not chunk:
            raise AssertionError(f"no {marker!r} before the end of output: {seen!r}")
        seen += chunk
    return seen


def test_check_pose_lists_every_problem_and_moves_nothing(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    with Cell(write_cell(tmp_path, ctl.host, MODE)) as cell:
        assert cell.check_pose(ur_pose_to_matrix(GOOD_POSES[0])) == []
        low = cell.check_pose(ur_pose_to_matrix(OUTSIDE_WORKSPACE))
        out_of_reach = cell.check_pose(ur_pose_to_matrix([0.7, 0.7, 0.6, math.pi, 0.0, 0.0]))
        tilted = cell.check_pose(
            ur_pose_to_matrix(tcp_pose_down())
            @ ur_pose_to_matrix([0.0, 0.0, 0.0, math.radians(60.0), 0.0, 0.0])
        )
    assert [p.split(":")[0] for p in low] == ["workspace"]
    assert [p.split(":")[0] for p in out_of_reach] == ["safety_limits", "ik"]
    assert [p.split(":")[0] for p in tilted] == ["tilt"]
    assert motions(ctl) == []


def test_poses_refuses_a_cell_that_is_not_ready(sim_controller: SimFactory, tmp_path: Path) -> None:
    ctl = sim_controller(tcp_offset=(0.0, 0.0, 0.2, 0.0, 0.0, 0.0), instant=True)  # wrong TCP
    config = write_cell(tmp_path, ctl.host, MODE)
    result = cli(
        "poses", "--config", str(config), "--look-at", "-500", "-120", "0",
        "--distance-mm", "400", "--count", "6", "--out", str(tmp_path / "poses.yaml"),
    )  # fmt: skip
    assert result.returncode == 3, result.stderr
    assert "TCP offset" in result.stderr
    assert not (tmp_path / "poses.yaml").exists()
