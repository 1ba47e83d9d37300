"""``robot.model``, ``robot.links`` and ``scene.arm`` (docs/arm-model.md): the model is loaded
with its defaults and overrides, a scene without a model is refused in one line naming what to
add (exit 2) unless the config says ``scene.arm: unchecked``, and the connect-time agreement
rules (arm/agree.py)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from handeye_pick.arm.agree import (
    TCP_AGREEMENT_M,
    ArmModelMismatch,
    check_dashboard_model,
    check_tcp_agrees,
)
from handeye_pick.arm.kinematics import tcp_poses
from handeye_pick.arm.models import arm_model
from handeye_pick.cli import main
from handeye_pick.config.load import load_config
from handeye_pick.errors import ConfigError
from handeye_pick.geometry import make_transform, rotation_from_rotvec

ROOT = Path(__file__).resolve().parents[2]
SCENE = """
scene:
  bins:
    - {name: parts, pose: [-0.4, 0, 0.05, 0, 0, 0], inner_mm: [300, 200, 150], wall_mm: 10,
       floor_mm: 10}
tool:
  shape:
    - {name: body, box: {size_mm: [50, 50, 80], pose: [0, 0, 0.055, 0, 0, 0]}}
"""


def _write(tmp_path: Path, robot: str = "", scene: str = SCENE) -> Path:
    (tmp_path / "eih.yaml").write_text(
        "[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 60], [0, 0, 0, 1]]\n"
    )
    path = tmp_path / "cell.yaml"
    path.write_text(
        f"""
robot:
  host: 192.168.1.10
  tcp_offset: [0, 0, 0.15, 0, 0, 0]
{robot}
hand_eye: {{mode: eye-in-hand, file: eih.yaml, units: mm}}
grasp: {{approach_mm: 100, retreat_mm: 100}}
motion: {{speed_mps: 0.25, accel_mps2: 1.2, grasp_speed_mps: 0.05}}
workspace: {{min_mm: [-800, -800, 0], max_mm: [800, 800, 800], max_tilt_deg: 30}}
audit: {{file: picks.jsonl}}
{scene}
"""
    )
    return path


def test_robot_model_loads_the_arm_with_its_defaults_and_the_radii_it_overrides(
    tmp_path: Path,
) -> None:
    config = load_config(
        _write(tmp_path, "  model: ur10e\n  links: {forearm: {radius_mm: 70}, wrist_2: "
               "{radius_mm: 60}}")
    )
    model = config.robot.model
    assert model is not None
    assert model.name == "ur10e"
    assert model.link("forearm").radius_m == pytest.approx(0.070)
    assert model.link("wrist 2").radius_m == pytest.approx(0.060)
    assert model.link("wrist 1").radius_m == arm_model("ur10e").link("wrist 1").radius_m
    default = arm_model("ur10e").link("upper arm")
    assert model.link("upper arm").radius_m == default.radius_m
    np.testing.assert_array_equal(model.link("upper arm").T_frame_solid, default.T_frame_solid)
    assert config.scene is not None
    assert config.scene.arm_checked


def test_the_measured_radii_hold_for_the_small_arms_and_the_meshes_size_the_big_ones() -> None:
    for name in ("ur3", "ur5", "ur3e", "ur5e"):
        radii = [link.radius_m for link in arm_model(name).links]
        assert radii == [0.060, 0.054, 0.060, 0.040, 0.045, 0.045, 0.045], name
    ur10e = {link.name: link.radius_m for link in arm_model("ur10e").links}
    assert ur10e["upper arm"] == pytest.approx(0.153 / 2 + 0.005)
    assert ur10e["shoulder"] == pytest.approx(0.175 / 2 + 0.005)
    assert ur10e["forearm"] == pytest.approx(0.116 / 2 + 0.005)
    assert ur10e["wrist 1"] == pytest.approx(0.094 / 2 + 0.005)
    assert arm_model("ur30").link("wrist 3").radius_m == pytest.approx(0.100 / 2 + 0.005)


def test_a_scene_without_robot_model_is_refused_in_one_line_with_what_to_add(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _write(tmp_path)
    with pytest.raises(ConfigError) as refused:
        load_config(path)
    message = str(refused.value)
    assert message == (
        f"{path}: robot.model: missing: a scene checks the arm's links as well as the tool; add "
        "robot.model (the arm on the controller: ur3e, ur5e, ur10e, ur16e, ur20, ur30, ur3, ur5, "
        "ur10), or scene.arm: unchecked to check the tool alone"
    )
    assert main(["status", "--config", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert "robot.model: missing" in err[0]


def test_scene_arm_unchecked_keeps_the_tool_only_check_and_says_so_in_the_config(
    tmp_path: Path,
) -> None:
    config = load_config(_write(tmp_path, scene=SCENE.replace("scene:\n", "scene:\n  arm: "
                                                              "unchecked\n")))
    assert config.robot.model is None
    assert config.scene is not None
    assert config.scene.arm_checked is False


@pytest.mark.parametrize(
    ("robot", "scene", "expected"),
    [
        ("  model: ur5x", SCENE, "robot.model: expected one of ur3e, ur5e"),
        ("  model: UR5e", SCENE, "robot.model: expected one of"),
        ("  links: {forearm: {radius_mm: 50}}", "", "robot.links: link radii need robot.model"),
        ("  model: ur5e\n  links: {wrist: {radius_mm: 50}}", SCENE,
         "robot.links.wrist: unknown key"),
        ("  model: ur5e\n  links: {forearm: {radius_mm: 0.05}}", SCENE,
         "robot.links.forearm.radius_mm: must be at least 10 mm"),
        ("  model: ur5e", SCENE.replace("scene:\n", "scene:\n  arm: no\n"),
         "scene.arm: expected a non-empty string"),
        ("  model: ur5e", SCENE.replace("scene:\n", "scene:\n  arm: off\n"),
         "scene.arm: expected a non-empty string"),
        ("  model: ur5e", SCENE.replace("scene:\n", "scene:\n  arm: tool\n"),
         "scene.arm: expected one of checked, unchecked"),
    ],
)
def test_a_bad_arm_key_is_one_line_naming_it(
    tmp_path: Path, robot: str, scene: str, expected: str
) -> None:
    with pytest.raises(ConfigError, match=expected.replace("(", r"\(")) as refused:
        load_config(_write(tmp_path, robot, scene))
    assert "\n" not in str(refused.value)


def test_every_repository_config_with_a_scene_loads() -> None:
    config = load_config(ROOT / "config" / "bin.yaml")
    assert config.robot.model is not None
    assert config.robot.model.name == "ur5e"


@pytest.mark.parametrize(
    ("model", "answer", "version", "refused"),
    [
        ("ur5e", "UR5", (5, 15, 0), False),
        ("ur5e", "UR5e", (5, 15, 0), False),  # should a controller spell out the e-Series
        ("ur5", "UR5", (3, 15, 8), False),
        ("ur20", "UR20", (5, 15, 0), False),
        ("ur5e", "UR5", (3, 15, 8), True),  # a CB3 says UR5 too: its PolyScope tells
        ("ur5", "UR5", (5, 15, 0), True),
        ("ur5e", "UR10", (5, 15, 0), True),
        ("ur16e", "UR10", None, True),
        ("ur10e", "UR10", None, False),  # an unreadable version: the name alone decides
    ],
)
def test_the_dashboards_robot_model_and_polyscope_series_decide(
    model: str, answer: str, version: tuple[int, ...] | None, refused: bool
) -> None:
    arm = arm_model(model)
    if not refused:
        check_dashboard_model(arm, answer, version, "cell-7")
        return
    with pytest.raises(ArmModelMismatch, match=rf"robot.model is {model}, but the controller at "
                       rf"cell-7 drives .*{answer} \(dashboard 'get robot model'\)"):
        check_dashboard_model(arm, answer, version, "cell-7")


def test_the_models_tcp_must_lie_within_5_mm_and_half_a_degree_of_the_controllers() -> None:
    model = arm_model("ur5e")
    q = [0.2, -1.5, 1.3, -1.4, -1.57, 0.4]
    T_flange_tcp = make_transform(np.eye(3), [0.0, 0.0, 0.15])
    T_model = tcp_poses(model, q, T_flange_tcp)[0]
    calibrated = T_model.copy()
    calibrated[:3, 3] += [0.003, -0.002, 0.002]  # 4.1 mm: a real arm's calibration
    calibrated[:3, :3] = rotation_from_rotvec([0.0, math.radians(0.4), 0.0]) @ T_model[:3, :3]
    check_tcp_agrees(model, q, calibrated, T_flange_tcp, "cell-7")
    farther = T_model.copy()
    farther[:3, 3] += [TCP_AGREEMENT_M + 0.0005, 0.0, 0.0]
    with pytest.raises(ArmModelMismatch, match=r"puts the TCP 5.5 mm and 0.00 deg from where the "
                       r"controller at cell-7 has it \(at most 5 mm and 0.5 deg\)"):
        check_tcp_agrees(model, q, farther, T_flange_tcp, "cell-7")
    turned = T_model.copy()
    turned[:3, :3] = rotation_from_rotvec([math.radians(0.6), 0.0, 0.0]) @ T_model[:3, :3]
    with pytest.raises(ArmModelMismatch, match=r"0\.60 deg"):
        check_tcp_agrees(model, q, turned, T_flange_tcp, "cell-7")
