"""Cell config: the example loads, every bad value is refused with an error naming its key."""

from __future__ import annotations

import copy
import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from handeye_pick.config.gripper import GripperConfig
from handeye_pick.config.load import load_config
from handeye_pick.config.reader import read_yaml_mapping
from handeye_pick.config.schema import CellConfig
from handeye_pick.errors import ConfigError
from handeye_pick.hand_eye.files import HandEyeMode
from handeye_pick.hand_eye.plausibility import MeasuredCamera
from handeye_pick.robot.port import OutputBank

ROOT = Path(__file__).resolve().parents[2]

BASE: dict[str, Any] = {
    "robot": {
        "host": "192.168.1.10",
        "tcp_offset": [0, 0, 0.15, 0, 0, 0],
        "gripper": {"bank": "standard", "index": 3, "close_value": True, "settle_s": 0.2},
    },
    "hand_eye": {"mode": "eye-in-hand", "file": "calibration/hand_eye.yaml", "units": "mm"},
    "grasp": {"approach_mm": 100, "retreat_mm": 80},
    "motion": {"speed_mps": 0.25, "accel_mps2": 1.2, "grasp_speed_mps": 0.05},
    "workspace": {"min_mm": [-800, -800, 0], "max_mm": [800, 800, 800], "max_tilt_deg": 60},
    "audit": {"file": "picks.jsonl"},
}


def _set(data: dict[str, Any], dotted: str, value: object) -> None:
    *parents, last = dotted.split(".")
    for key in parents:
        data = data[key]
    data[last] = value


def _delete(data: dict[str, Any], dotted: str) -> None:
    *parents, last = dotted.split(".")
    for key in parents:
        data = data[key]
    del data[last]


@pytest.fixture
def cell(tmp_path: Path) -> Path:
    """A folder with a (dummy) calibration file next to where the config goes."""
    (tmp_path / "calibration").mkdir()
    (tmp_path / "calibration" / "hand_eye.yaml").write_text("not read by load_config\n")
    return tmp_path


def _write(folder: Path, data: dict[str, Any] | str) -> Path:
    path = folder / "cell.yaml"
    path.write_text(data if isinstance(data, str) else yaml.safe_dump(data))
    return path


def _load_with(folder: Path, **changes: object) -> CellConfig:
    data = copy.deepcopy(BASE)
    for dotted, value in changes.items():
        _set(data, dotted.replace("__", "."), value)
    return load_config(_write(folder, data))


# --- good files -----------------------------------------------------------------------------------


def test_repository_example_config_loads() -> None:
    config = load_config(ROOT / "config" / "cell.example.yaml")
    assert config.hand_eye.mode is HandEyeMode.EYE_IN_HAND
    assert config.hand_eye.file.is_file()
    assert config.grasp.approach_mm == 100.0
    assert config.robot.gripper is not None


def test_base_config_values_and_units(cell: Path) -> None:
    config = load_config(_write(cell, BASE))
    assert config.path == (cell / "cell.yaml").resolve()
    assert config.robot.host == "192.168.1.10"
    np.testing.assert_allclose(config.robot.T_flange_tcp[:3, 3], [0, 0, 0.15])  # metres
    assert config.robot.gripper == GripperConfig(OutputBank.STANDARD, 3, True, 0.2)
    assert config.hand_eye.units == "mm"
    assert config.grasp.retreat_mm == 80.0
    np.testing.assert_array_equal(config.grasp.T_obj_tcp, np.eye(4))
    assert config.motion.speed_mps == 0.25
    assert config.workspace.min_mm == (-800.0, -800.0, 0.0)
    assert config.workspace.max_tilt_deg == 60.0


def test_optional_keys_take_documented_defaults(cell: Path) -> None:
    data = copy.deepcopy(BASE)
    del data["robot"]["gripper"]
    config = load_config(_write(cell, data))
    assert config.robot.gripper is None
    assert config.robot.tcp_offset_tolerance_mm == 1.0
    assert config.robot.tcp_offset_tolerance_deg == 1.0
    assert config.hand_eye.invert is False
    assert config.motion.stop_decel_mps2 == 10.0
    assert config.motion.timeout_margin_s == 5.0


def test_tcp_offset_rotation_is_a_rotation_vector_in_radians(cell: Path) -> None:
    config = _load_with(cell, robot__tcp_offset=[0.01, 0, 0.2, 0, 0, math.pi / 2])
    np.testing.assert_allclose(
        config.robot.T_flange_tcp[:3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-12
    )


def test_object_T_tcp_is_a_ur_pose_vector(cell: Path) -> None:
    config = _load_with(cell, grasp__object_T_tcp=[0, 0, 0.01, math.pi, 0, 0])
    np.testing.assert_allclose(
        config.grasp.T_obj_tcp,
        [[1.0, 0.0, 0.0, 0.0], [0.0, -1.0, 0.0, 0.0], [0.0, 0.0, -1.0, 0.01], [0.0, 0.0, 0.0, 1.0]],
        atol=1e-12,
    )


def test_paths_are_relative_to_the_config_file_not_the_working_directory(
    cell: Path, tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = _write(cell, BASE)
    monkeypatch.chdir(tmp_path_factory.mktemp("elsewhere"))
    config = load_config(path)
    assert config.hand_eye.file == (cell / "calibration" / "hand_eye.yaml").resolve()
    assert config.audit.file == (cell / "picks.jsonl").resolve()


def test_eye_to_hand_tool_gripper_and_invert(cell: Path) -> None:
    config = _load_with(
        cell,
        hand_eye__mode="eye-to-hand",
        hand_eye__units="m",
        hand_eye__invert=True,
        robot__gripper={"bank": "tool", "index": 1, "close_value": False},
    )
    assert config.hand_eye.mode is HandEyeMode.EYE_TO_HAND
    assert config.hand_eye.units == "m"
    assert config.hand_eye.invert is True
    assert config.robot.gripper is not None
    assert config.robot.gripper.bank is OutputBank.TOOL
    assert config.robot.gripper.close_value is False
    assert config.robot.gripper.settle_s == 0.5


def test_acknowledged_plausibility_checks_are_named_each_once(cell: Path) -> None:
    assert _load_with(cell).hand_eye.acknowledge == ()
    names = ["camera-in-front-of-flange", "object-in-camera-range"]
    assert _load_with(cell, hand_eye__acknowledge=names).hand_eye.acknowledge == tuple(names)
    for value, message in [
        ([], r"hand_eye\.acknowledge: expected a list of check names, got a list of 0 items"),
        ("camera-in-front-of-flange", r"hand_eye\.acknowledge: expected a list"),
        (["all"], r"hand_eye\.acknowledge\[0\]: expected one of camera-near-flange, .*'all'"),
        (names + names[:1], r"hand_eye\.acknowledge\[2\]: given twice"),
    ]:
        with pytest.raises(ConfigError, match=message):
            _load_with(cell, hand_eye__acknowledge=value)


def test_measured_camera_position_and_its_tolerance(cell: Path) -> None:
    assert _load_with(cell).hand_eye.camera_position is None
    measured = _load_with(cell, hand_eye__camera_position_mm=[-10, 60.5, 100]).hand_eye
    assert measured.camera_position == MeasuredCamera((-10.0, 60.5, 100.0), 100.0)
    fixed = _load_with(
        cell,
        hand_eye__mode="eye-to-hand",
        hand_eye__camera_position_mm=[500, -40, 1250],
        hand_eye__camera_position_tolerance_mm=500,
    ).hand_eye
    assert fixed.camera_position == MeasuredCamera((500.0, -40.0, 1250.0), 500.0)


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"camera_position_mm": [0, 60]}, r"camera_position_mm: expected a list of 3 numbers"),
        ({"camera_position_mm": [0, math.nan, 100]}, r"camera_position_mm\[1\]: expected a finite"),
        ({"camera_position_mm": [0, 0.06, 0.1]}, r"camera_position_mm: the camera distance from "
         r"the flange is 0\.116619 mm, expected 1 to 2000 mm \(this is in mm: metres given\?\)"),
        ({"camera_position_mm": [0, 0, 2500]}, r"camera_position_mm: .* 2500 mm, expected 1 to"),
        ({"mode": "eye-to-hand", "camera_position_mm": [0.5, 0, 1.2]},
         r"camera_position_mm: the camera distance from the robot base is 1\.3 mm, expected 50"),
        ({"camera_position_mm": [0, 60, 100], "camera_position_tolerance_mm": 0},
         r"camera_position_tolerance_mm: must be greater than 0 mm, got 0"),
        ({"camera_position_mm": [0, 60, 100], "camera_position_tolerance_mm": 501},
         r"camera_position_tolerance_mm: must be at most 500 mm, got 501"),
        ({"camera_position_tolerance_mm": 50},
         r"camera_position_tolerance_mm: applies to hand_eye\.camera_position_mm, which is not"),
    ],
)  # fmt: skip
def test_bad_measured_camera_position_is_refused_naming_the_key(
    cell: Path, changes: dict[str, object], message: str
) -> None:
    with pytest.raises(ConfigError, match=r"hand_eye\." + message):
        _load_with(cell, **{f"hand_eye__{key}": value for key, value in changes.items()})


@pytest.mark.parametrize(
    "changes",
    [
        {"motion.speed_mps": 1.0, "motion.accel_mps2": 4.0, "motion.grasp_speed_mps": 0.25},
        {"workspace.max_tilt_deg": 0},
        {"workspace.max_tilt_deg": 180},
        {"grasp.approach_mm": 5, "grasp.retreat_mm": 500},
        {"motion.stop_decel_mps2": 1.2},
    ],
)
def test_limits_are_inclusive(cell: Path, changes: dict[str, object]) -> None:
    _load_with(cell, **{k.replace(".", "__"): v for k, v in changes.items()})


def test_config_is_frozen(cell: Path) -> None:
    config = load_config(_write(cell, BASE))
    with pytest.raises(dataclasses.FrozenInstanceError):
        config.motion.speed_mps = 2.0  # type: ignore[misc]


# --- bad values: every error names its key ------------------------------------------------------

BAD_VALUES = [
    ("robot.host", 5),
    ("robot.host", ""),
    ("robot.host", None),
    ("robot.tcp_offset", [0, 0, 150, 0, 0, 0]),  # mm in a m key
    ("robot.tcp_offset", [0, 0, 0.15, 0, 0, 180]),  # degrees in a rad key
    ("robot.tcp_offset", [0, 0, 0.15]),
    ("robot.tcp_offset", "0 0 0.15 0 0 0"),
    ("robot.tcp_offset", [0, 0, "x", 0, 0, 0]),
    ("robot.tcp_offset_tolerance_mm", 0),
    ("robot.tcp_offset_tolerance_mm", -1),
    ("robot.tcp_offset_tolerance_mm", 100),
    ("robot.tcp_offset_tolerance_deg", 45),
    ("robot.tcp_offset_tolerance_deg", True),
    ("robot.gripper", "tool 0"),
    ("robot.gripper.bank", "both"),
    ("robot.gripper.index", 8),
    ("robot.gripper.index", -1),
    ("robot.gripper.index", 1.0),
    ("robot.gripper.index", True),
    ("robot.gripper.close_value", "yes"),
    ("robot.gripper.close_value", 1),
    ("robot.gripper.settle_s", -0.1),
    ("robot.gripper.settle_s", 60),
    ("hand_eye.mode", "eye_in_hand"),
    ("hand_eye.file", "calibration/missing.yaml"),
    ("hand_eye.file", 3),
    ("hand_eye.units", "cm"),
    ("hand_eye.invert", "no"),
    ("grasp.approach_mm", -10),
    ("grasp.approach_mm", 0),
    ("grasp.approach_mm", 0.1),  # metres in a mm key
    ("grasp.approach_mm", 1000),
    ("grasp.approach_mm", True),
    ("grasp.approach_mm", "100"),
    ("grasp.retreat_mm", -1),
    ("grasp.object_T_tcp", [0, 0, 100, 0, 0, 0]),  # mm in a m key
    ("grasp.object_T_tcp", [0, 0, 0, 180, 0, 0]),  # degrees in a rad key
    ("motion.speed_mps", 0),
    ("motion.speed_mps", -0.1),
    ("motion.speed_mps", 1.5),  # above the pick cap
    ("motion.speed_mps", 3.5),  # above ur_rtde's limit
    ("motion.speed_mps", True),
    ("motion.speed_mps", "fast"),
    ("motion.speed_mps", "1e-1"),
    ("motion.speed_mps", float("nan")),
    ("motion.speed_mps", float("inf")),
    ("motion.accel_mps2", 0),
    ("motion.accel_mps2", 5),
    ("motion.accel_mps2", 200),  # above ur_rtde's limit
    ("motion.grasp_speed_mps", 0),
    ("motion.grasp_speed_mps", 0.3),  # above the grasp cap
    ("motion.stop_decel_mps2", 0.5),  # gentler than accel_mps2
    ("motion.stop_decel_mps2", 151),
    ("motion.timeout_margin_s", 0),
    ("motion.timeout_margin_s", 500),
    ("workspace.min_mm", [0, 0]),
    ("workspace.min_mm", [-5000, 0, 0]),
    ("workspace.max_mm", [800, 800, 5]),  # z extent under 10 mm
    ("workspace.max_tilt_deg", -1),
    ("workspace.max_tilt_deg", 181),
    ("workspace.max_tilt_deg", "60"),
    ("audit.file", "no-such-folder/picks.jsonl"),
    ("audit.file", 5),
]


@pytest.mark.parametrize(("dotted", "value"), BAD_VALUES)
def test_bad_value_is_refused_naming_the_key(cell: Path, dotted: str, value: object) -> None:
    data = copy.deepcopy(BASE)
    _set(data, dotted, value)
    path = _write(cell, data)
    with pytest.raises(ConfigError) as info:
        load_config(path)
    message = str(info.value)
    assert str(path.resolve()) in message
    assert f": {dotted}" in message


def test_grasp_move_faster_than_travel_is_refused(cell: Path) -> None:
    with pytest.raises(ConfigError, match=r"motion\.grasp_speed_mps: .*not be faster"):
        _load_with(cell, motion__speed_mps=0.1, motion__grasp_speed_mps=0.2)


def test_min_above_max_is_refused_on_max_mm(cell: Path) -> None:
    with pytest.raises(ConfigError, match=r"workspace\.max_mm: z must be at least 10 mm above min"):
        _load_with(cell, workspace__min_mm=[0, 0, 900])


def test_metre_workspace_is_refused(cell: Path) -> None:
    with pytest.raises(ConfigError, match=r"workspace\.max_mm.*metres given"):
        _load_with(cell, workspace__min_mm=[-0.8, -0.8, 0], workspace__max_mm=[0.8, 0.8, 0.8])


def test_yaml_exponent_without_dot_gets_a_hint(cell: Path) -> None:
    path = _write(cell, yaml.safe_dump(BASE).replace("speed_mps: 0.25", "speed_mps: 2.5e-1"))
    assert load_config(path).motion.speed_mps == 0.25  # with the dot YAML reads a number
    path = _write(cell, yaml.safe_dump(BASE).replace("speed_mps: 0.25", "speed_mps: 25e-2"))
    with pytest.raises(ConfigError, match=r"motion\.speed_mps: .*write 1\.0e-3"):
        load_config(path)
    # A dot is not enough: YAML 1.1 also wants the exponent's sign, and the hint says so.
    path = _write(cell, yaml.safe_dump(BASE).replace("speed_mps: 0.25", "speed_mps: 2.5e1"))
    with pytest.raises(ConfigError, match=r"motion\.speed_mps: .*a dot and a sign.*1\.0e\+3"):
        load_config(path)


def test_quoted_number_gets_a_hint(cell: Path) -> None:
    with pytest.raises(ConfigError, match=r"grasp\.approach_mm: .*remove the quotes"):
        _load_with(cell, grasp__approach_mm="100")


@pytest.mark.parametrize(
    ("dotted", "value"),
    [
        ("extra", 1),
        ("motion.speed", 0.25),
        ("robot.gripper.colour", "red"),
        ("hand_eye.unit", "mm"),
    ],
)
def test_unknown_key_is_refused_naming_it(cell: Path, dotted: str, value: object) -> None:
    data = copy.deepcopy(BASE)
    _set(data, dotted, value)
    with pytest.raises(ConfigError, match=rf": {dotted}: unknown key"):
        load_config(_write(cell, data))


def test_misspelt_key_suggests_the_right_one(cell: Path) -> None:
    data = copy.deepcopy(BASE)
    data["motion"]["sped_mps"] = data["motion"].pop("speed_mps")
    with pytest.raises(
        ConfigError, match=r"motion\.sped_mps: unknown key.*did you mean 'speed_mps'"
    ):
        load_config(_write(cell, data))


@pytest.mark.parametrize(
    "dotted",
    [
        "robot",
        "robot.host",
        "robot.tcp_offset",
        "hand_eye.mode",
        "hand_eye.file",
        "hand_eye.units",
        "grasp.approach_mm",
        "grasp.retreat_mm",
        "motion.speed_mps",
        "motion.accel_mps2",
        "motion.grasp_speed_mps",
        "workspace.min_mm",
        "workspace.max_tilt_deg",
        "audit.file",
    ],
)
def test_missing_required_key_is_refused_naming_it(cell: Path, dotted: str) -> None:
    data = copy.deepcopy(BASE)
    _delete(data, dotted)
    with pytest.raises(ConfigError, match=rf": {dotted}: missing"):
        load_config(_write(cell, data))


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("[1, 2, 3]\n", "top level: expected a mapping"),
        ("", "top level: expected a mapping"),
        ("robot: {host: a\n", "not valid YAML"),
        ("motion:\n  speed_mps: 0.1\n  speed_mps: 0.9\n", "appears twice"),
        ("robot: !!python/object:os.system {}\n", "not valid YAML"),
    ],
)
def test_malformed_file_is_refused_naming_the_file(cell: Path, text: str, expected: str) -> None:
    path = _write(cell, text)
    with pytest.raises(ConfigError, match=expected) as info:
        load_config(path)
    assert str(path.resolve()) in str(info.value)


def test_missing_file_is_a_config_error(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="cannot read"):
        load_config(tmp_path / "nope.yaml")


def test_yaml_merge_keys_may_override_but_plain_duplicates_may_not(tmp_path: Path) -> None:
    path = tmp_path / "merge.yaml"
    path.write_text("a: &x {b: 1, c: 2}\nd:\n  <<: *x\n  b: 3\n")
    assert read_yaml_mapping(path, ConfigError) == {"a": {"b": 1, "c": 2}, "d": {"b": 3, "c": 2}}
    path.write_text("d:\n  b: 1\n  b: 3\n")
    with pytest.raises(ConfigError, match="key 'b' appears twice"):
        read_yaml_mapping(path, ConfigError)


# --- poses, place, capture ------------------------------------------------------------------------

CELL_SECTIONS: dict[str, Any] = {
    "poses": {
        "capture": {"joints_rad": [0, -1.5708, 1.5708, -1.5708, -1.5708, 0]},
        "home": {"tcp_pose": [-0.4, -0.1, 0.45, 3.14159, 0, 0]},
    },
    "place": {"poses": [[-0.3, 0.35, 0.15, 3.14159, 0, 0]], "approach_mm": 80, "retreat_mm": 70},
    "capture": {"pose": "capture", "steady_timeout_s": 1.5},
}


def test_named_poses_place_and_capture_load_in_their_units(cell: Path) -> None:
    data = {**copy.deepcopy(BASE), **copy.deepcopy(CELL_SECTIONS)}
    config = load_config(_write(cell, data))
    capture, home = config.poses
    assert (capture.name, capture.q_rad, capture.T_base_tcp) == (
        "capture",
        (0.0, -1.5708, 1.5708, -1.5708, -1.5708, 0.0),
        None,
    )
    assert home.q_rad is None
    assert home.T_base_tcp is not None
    np.testing.assert_allclose(home.T_base_tcp[:3, 3], [-0.4, -0.1, 0.45])
    assert config.pose("home") is home
    assert config.place is not None
    np.testing.assert_allclose(config.place.T_base_tcp[0][:3, 3], [-0.3, 0.35, 0.15])
    assert (config.place.approach_mm, config.place.retreat_mm) == (80.0, 70.0)
    assert (config.capture.pose, config.capture.steady_timeout_s) == ("capture", 1.5)
    with pytest.raises(ConfigError, match=r"no pose named 'away' \(defined: capture, home\)"):
        config.pose("away")


def test_a_config_without_the_cell_sections_has_none(cell: Path) -> None:
    config = _load_with(cell)
    assert (config.poses, config.place, config.capture.pose) == ((), None, None)


@pytest.mark.parametrize(
    ("section", "value", "key", "message"),
    [
        ("poses", {"home": {"joints_rad": [0, 90, 0, 0, 0, 0]}}, "poses.home.joints_rad", "deg"),
        ("poses", {"home": {"tcp_pose": [400, 0, 300, 0, 0, 0]}}, "poses.home.tcp_pose", "metres"),
        ("poses", {"home": {"joints_rad": [0] * 6, "tcp_pose": [0] * 6}}, "poses.home", "one of"),
        ("poses", {"home": {}}, "poses.home", "exactly one"),
        ("poses", {"home": {"joint_rad": [0] * 6}}, "poses.home.joint_rad", "unknown key"),
        ("poses", [], "poses", "mapping"),
        ("place", {"poses": [], "approach_mm": 80, "retreat_mm": 80}, "place.poses", "list"),
        (
            "place",
            {"poses": [[-300, 350, 150, 3.1, 0, 0]], "approach_mm": 80, "retreat_mm": 80},
            "place.poses.0",
            "metres",
        ),
        (
            "place",
            {"poses": [[-0.3, 0.3, 0.1, 0, 0, 0]], "approach_mm": 0.08, "retreat_mm": 80},
            "place.approach_mm",
            "at least",
        ),
        ("capture", {"pose": "nowhere"}, "capture.pose", "no pose named"),
    ],
)
def test_bad_cell_sections_are_refused_naming_the_key(
    cell: Path, section: str, value: object, key: str, message: str
) -> None:
    data = {**copy.deepcopy(BASE), section: value}
    with pytest.raises(ConfigError, match=rf"{key}: .*{message}"):
        load_config(_write(cell, data))


def test_joint_speed_caps_are_enforced(cell: Path) -> None:
    with pytest.raises(ConfigError, match=r"motion.joint_speed_rps: must be at most 1.05"):
        _load_with(cell, motion__joint_speed_rps=2.0)


def _keys_allowed(tmp_path: Path, data: dict[str, Any], section: tuple[str, ...]) -> set[str]:
    """The keys the reader allows in ``section`` of ``data``, from its own refusal of one it
    does not know ("unknown key (expected one of a, b, c)")."""
    trial = copy.deepcopy(data)
    target = trial
    for key in section:
        target = target[key]
    target["zz_not_a_key"] = 1
    with pytest.raises(ConfigError, match="unknown key") as refused:
        load_config(_write(tmp_path, trial))
    listed = str(refused.value).split("expected one of ", 1)[1].split(")", 1)[0]
    return {key.strip() for key in listed.split(",")}


def test_the_example_config_names_every_key_the_reader_allows(tmp_path: Path) -> None:
    """config/cell.example.yaml says it explains every key: each key the reader allows in each
    of its sections appears there, set or in a comment (``key:``)."""
    example = ROOT / "config" / "cell.example.yaml"
    text = example.read_text()
    data = yaml.safe_load(text)
    data["hand_eye"]["file"] = str(ROOT / "config" / data["hand_eye"]["file"])
    sections = [(), ("robot",), ("robot", "gripper")]
    # poses: holds names the integrator chooses, not keys
    sections += [
        (key,) for key, value in data.items() if isinstance(value, dict) and key != "robot"
    ]
    sections.remove(("poses",))
    missing = {
        ".".join((*section, key))
        for section in sections
        for key in _keys_allowed(tmp_path, data, section)
        if f"{key}:" not in text
    }
    assert not missing, f"keys the example config does not explain: {sorted(missing)}"
