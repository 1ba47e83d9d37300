"""Gripper kinds and payloads in the cell config, and the payload the arm carries with a part."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import given
from hypothesis import strategies as st

from handeye_pick.cell.payload import held_payload
from handeye_pick.config.gripper import FeedbackInput, GripperConfig, Robotiq2FConfig
from handeye_pick.config.load import load_config
from handeye_pick.config.schema import ObjectConfig, Payload
from handeye_pick.errors import ConfigError
from handeye_pick.geometry import make_transform, rotation_from_euler, transform_point
from handeye_pick.gripper.robotiq import fault_text
from handeye_pick.robot.port import OutputBank
from tests.unit.test_config import BASE

ROBOTIQ = {"type": "robotiq-2f", "expected_width_mm": [38, 42], "force_pct": 30}


def _load(tmp_path: Path, **changes: Any) -> Any:
    (tmp_path / "calibration").mkdir(exist_ok=True)
    (tmp_path / "calibration" / "hand_eye.yaml").write_text("not read by load_config\n")
    data = copy.deepcopy(BASE)
    for key, value in changes.items():
        section, _, name = key.partition("__")
        if name:
            data[section][name] = value
        else:
            data[section] = value
    path = tmp_path / "cell.yaml"
    path.write_text(yaml.safe_dump(data))
    return load_config(path)


def test_an_old_digital_config_is_still_a_digital_output_gripper(tmp_path: Path) -> None:
    config = _load(tmp_path)
    assert config.robot.gripper == GripperConfig(OutputBank.STANDARD, 3, True, 0.2)
    assert config.robot.gripper.kind == "digital-output"
    assert config.robot.gripper.confirm_input is None
    assert (config.object, config.robot.tool_payload) == (None, None)


def test_digital_gripper_with_a_feedback_input(tmp_path: Path) -> None:
    gripper = {
        "type": "digital-output",
        "bank": "tool",
        "index": 0,
        "close_value": True,
        "confirm_input": {"bank": "standard", "index": 5, "value": False},
        "confirm_timeout_s": 0.4,
    }
    config = _load(tmp_path, robot__gripper=gripper)
    assert config.robot.gripper.confirm_input == FeedbackInput(OutputBank.STANDARD, 5, False)
    assert config.robot.gripper.confirm_timeout_s == 0.4


def test_robotiq_gripper_object_and_tool_payload(tmp_path: Path) -> None:
    config = _load(
        tmp_path,
        robot__gripper=ROBOTIQ,
        robot__tool_payload={"mass_kg": 0.9, "cog_mm": [0, 0, 55]},
        object={"mass_kg": 0.25, "cog_mm": [0, 0, 20]},
    )
    assert config.robot.gripper == Robotiq2FConfig(expected_width_mm=(38.0, 42.0), force_pct=30)
    assert config.robot.tool_payload == Payload(0.9, (0.0, 0.0, 0.055))
    assert config.object == ObjectConfig(0.25, (0.0, 0.0, 0.02))


@pytest.mark.parametrize(
    ("changes", "key"),
    [
        ({"robot__gripper": {**ROBOTIQ, "expected_width_mm": [42, 38]}}, "expected_width_mm"),
        ({"robot__gripper": {**ROBOTIQ, "expected_width_mm": [38, 90]}}, "expected_width_mm"),
        ({"robot__gripper": {**ROBOTIQ, "bank": "tool"}}, "robot.gripper.bank"),
        ({"robot__gripper": {**ROBOTIQ, "speed_pct": 150}}, "robot.gripper.speed_pct"),
        ({"robot__gripper": {"type": "vacuum-x", "bank": "tool"}}, "robot.gripper.type"),
        (
            {"robot__gripper": {**BASE["robot"]["gripper"], "expected_width_mm": [1, 2]}},
            "robot.gripper.expected_width_mm",
        ),
        ({"object": {"mass_kg": 0.2, "cog_mm": [0, 0, 0]}}, "robot.tool_payload"),
        (
            {
                "robot__tool_payload": {"mass_kg": 900, "cog_mm": [0, 0, 0]},
                "object": {"mass_kg": 0.2, "cog_mm": [0, 0, 0]},
            },
            "robot.tool_payload.mass_kg",
        ),
    ],
)
def test_bad_gripper_and_payload_keys_are_named(
    tmp_path: Path, changes: dict[str, Any], key: str
) -> None:
    with pytest.raises(ConfigError, match=key):
        _load(tmp_path, **changes)


def test_robotiq_fault_codes_say_what_they_mean() -> None:
    assert (
        fault_text(0x08)
        == "0x08 (maximum operating temperature exceeded: let the gripper cool down)"
    )
    assert "does not list" in fault_text(0x42)


masses = st.floats(0.0, 30.0)
coords = st.tuples(*[st.floats(-0.3, 0.3)] * 3)


@given(masses, coords, masses, coords, st.tuples(*[st.floats(-180.0, 180.0)] * 3), coords)
def test_held_payload_keeps_the_total_mass_and_moment_about_the_flange(
    tool_kg: float,
    tool_cog: tuple[float, float, float],
    part_kg: float,
    part_cog_tcp: tuple[float, float, float],
    euler_deg: tuple[float, float, float],
    tcp_m: tuple[float, float, float],
) -> None:
    T_flange_tcp = make_transform(rotation_from_euler(list(euler_deg), "xyz", "deg"), tcp_m)
    held = held_payload(
        Payload(tool_kg, tool_cog), ObjectConfig(part_kg, part_cog_tcp), T_flange_tcp
    )
    assert held.mass_kg == pytest.approx(tool_kg + part_kg)
    part_flange = transform_point(T_flange_tcp, np.array(part_cog_tcp))
    moment = tool_kg * np.array(tool_cog) + part_kg * part_flange
    np.testing.assert_allclose(held.mass_kg * np.array(held.cog_flange_m), moment, atol=1e-9)
