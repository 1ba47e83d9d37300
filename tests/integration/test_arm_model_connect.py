"""``robot.model`` against the simulated controller at connect (docs/arm-model.md): the
dashboard's robot model and the model's TCP must agree with the controller before anything
moves; a disagreement is a refusal (exit 3), and without ``robot.model`` nothing is asked.

The simulator's arm is chosen with its ``model`` option; its dashboard answers ``get robot
model`` as a real one does (``UR5`` for a UR5 and a UR5e), from PolyScope 3.12 and 5.6.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from handeye_pick.geometry import invert, transform_point, ur_pose_to_matrix
from handeye_pick.hand_eye.files import HandEyeMode, load_hand_eye
from mocks.ur_controller import SimulatedController
from tests.integration.test_pick_cli import (
    DEMO,
    TCP_OFFSET,
    audit_records,
    motion_commands,
    run_json,
    run_pick,
    write_config,
)
from tests.integration.test_robot_ur_dashboard import dashboard_connections

SimFactory = Callable[..., SimulatedController]


def _below_the_camera(ctl: SimulatedController) -> list[str]:
    """``--xyz`` (camera frame, mm) of a point 0.4 m below the flange: reachable for any arm."""
    T_base_flange = ur_pose_to_matrix(ctl.snapshot().flange_pose)
    T_flange_cam = load_hand_eye(DEMO / "hand_eye.yaml", HandEyeMode.EYE_IN_HAND, "mm").T_cal
    object_base_m = T_base_flange[:3, 3] + np.array([0.03, 0.02, -0.40])
    p_cam_mm = transform_point(invert(T_base_flange @ T_flange_cam), object_base_m) * 1000.0
    return ["--xyz", *(f"{v:.6f}" for v in p_cam_mm)]


def _asked(ctl: SimulatedController) -> list[str]:
    """Every request line the controller's dashboard received, over all connections."""
    return [line for c in dashboard_connections(ctl) for line in c["requests"]]


def _config(tmp_path: Path, ctl: SimulatedController, model: str | None, **extra: str) -> Path:
    robot = f"  model: {model}\n" if model is not None else ""
    return write_config(tmp_path, ctl.host, robot_extra=robot + extra.get("robot_extra", ""))


@pytest.mark.parametrize(("profile", "model"), [("e-series", "ur5e"), ("cb3", "ur5")])
def test_the_arm_on_the_controller_passes_and_the_pick_runs(
    sim_controller: SimFactory, tmp_path: Path, profile: str, model: str
) -> None:
    ctl = sim_controller(profile=profile, model=model, tcp_offset=TCP_OFFSET, instant=True)
    status, report = run_json(_config(tmp_path, ctl, model), *_below_the_camera(ctl))
    assert status == 0, report
    assert report["status"] == "picked"
    assert len(motion_commands(ctl)) == 3
    assert "get robot model" in _asked(ctl)


@pytest.mark.parametrize(
    ("profile", "arm", "configured", "said"),
    [
        ("e-series", "ur10e", "ur5e", "an e-Series UR10"),
        ("cb3", "ur5", "ur5e", "a CB3 UR5"),  # the dashboard says UR5 for both: PolyScope 3
        ("e-series", "ur5e", "ur5", "an e-Series UR5"),
    ],
)
def test_a_model_the_dashboard_contradicts_is_refused_before_anything_moves(
    sim_controller: SimFactory, tmp_path: Path, profile: str, arm: str, configured: str,
    said: str
) -> None:
    ctl = sim_controller(profile=profile, model=arm, tcp_offset=TCP_OFFSET, instant=True)
    result = run_pick(_config(tmp_path, ctl, configured), *_below_the_camera(ctl), "--quiet")
    assert result.returncode == 3, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, lines
    assert f"robot.model is {configured}" in lines[0]
    assert said in lines[0]
    assert "set robot.model to the arm on the controller" in lines[0]
    assert motion_commands(ctl) == []
    (outcome,) = audit_records(tmp_path)
    assert (outcome["step"], outcome["status"]) == ("connect", "refused")


@pytest.mark.parametrize(
    ("arm", "tcp_offset", "off"),
    [
        ("ur10e", TCP_OFFSET, "model puts the TCP"),  # a 5.4 dashboard cannot say
        ("ur5e", (0.0, 0.0, 0.11, 0.0, 0.0, 0.0), "model puts the TCP 10.0 mm"),
    ],
)
def test_a_model_whose_tcp_disagrees_with_the_controller_is_refused(
    sim_controller: SimFactory, tmp_path: Path, arm: str, tcp_offset: tuple[float, ...],
    off: str
) -> None:
    ctl = sim_controller(profile="e-series-5.4", model=arm, tcp_offset=tcp_offset, instant=True)
    result = run_pick(_config(tmp_path, ctl, "ur5e"), *_below_the_camera(ctl), "--quiet")
    assert result.returncode == 3, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, lines
    assert off in lines[0]
    assert "check robot.model, and that robot.tcp_offset is the TCP offset active" in lines[0]
    assert motion_commands(ctl) == []
    assert "get robot model" not in _asked(ctl)  # PolyScope 5.4 has no such command


def test_the_dashboard_is_asked_only_when_robot_model_is_set(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(model="ur10e", tcp_offset=TCP_OFFSET, instant=True)
    asked = []
    for model in ("ur10e", None):
        folder = tmp_path / str(model)
        folder.mkdir()
        status, report = run_json(_config(folder, ctl, model), *_below_the_camera(ctl),
                                  "--dry-run")
        assert status == 0, report
        asked.append(_asked(ctl).count("get robot model"))
    assert asked == [1, 1]  # the second session, without robot.model, asked nothing more
