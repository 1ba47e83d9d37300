"""The cell configuration: one YAML file, read with PyYAML's safe loader, into frozen dataclasses.

Every key is checked where it is read: an unknown key, a wrong type or a value out of range is a
``ConfigError`` naming the file and the key path (``motion.speed_mps``). Units are in the key
names (``_mm``, ``_mps``, ``_deg``, ``_s``); inside the package everything is metres and radians.
``config/cell.example.yaml`` documents every key.

``Fields`` and ``read_yaml_mapping`` are also used by ``detection.py`` for its own files.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Collection
from dataclasses import dataclass, field
from pathlib import Path
from typing import NoReturn

import numpy as np
import yaml
from numpy.typing import NDArray

from handeye_pick.calibration.files import MAX_ROTVEC_RAD, HandEyeMode
from handeye_pick.calibration.plausibility import (
    CHECKS,
    MAX_CAMERA_POSITION_TOLERANCE_MM,
    MeasuredCamera,
    measured_position_problem,
)
from handeye_pick.errors import ConfigError, InputError
from handeye_pick.geometry import LengthUnit, Transform, ur_pose_to_matrix
from handeye_pick.inputfiles import BoundedLoader, read_input_bytes, shown, yaml_problem
from handeye_pick.limits import (
    MAX_ACCEL_MPS2,
    MAX_GRASP_SPEED_MPS,
    MAX_JOINT_ACCEL_RPS2,
    MAX_JOINT_SPEED_RPS,
    MAX_SPEED_MPS,
    stop_decel_problem,
)
from handeye_pick.robot.port import OutputBank

# Plausibility bounds that catch a value typed in the wrong unit. Each is far outside what a
# real cell uses, so it only fires on a mistake.
MAX_TCP_OFFSET_M = 1.0  # a TCP offset in mm (150) typed into this m key would be 150 m
MAX_OBJECT_OFFSET_M = 0.5  # same check for grasp.object_T_tcp
MIN_STANDOFF_MM = 5.0  # approach/retreat below 5 mm: metres typed into a mm key (0.1 -> 0.1 mm)
MAX_STANDOFF_MM = 500.0  # longer approach or retreat paths are not a pick any more
MAX_WORKSPACE_MM = 3000.0  # no UR arm reaches farther than 1.75 m from its base
MAX_REACH_M = MAX_WORKSPACE_MM / 1000.0  # a named or place TCP pose farther out is in mm
MAX_JOINT_RAD = 2.0 * math.pi  # UR joint range is +-2*pi: a larger value is in degrees
MIN_WORKSPACE_EXTENT_MM = 10.0  # a box thinner than 1 cm is a box written in metres
NAMED_POSE_KEYS = ("joints_rad", "tcp_pose")  # a named pose: one of the two
STANDARD_OUTPUTS = 8  # standard digital outputs 0-7 on the control box
TOOL_OUTPUTS = 2  # tool digital outputs 0-1 on the tool flange connector
MAX_PAYLOAD_KG = 35.0  # the largest UR arm (UR30) carries 30 kg: more is grams typed as kg
MAX_COG_MM = 1000.0  # no tool's centre of gravity lies a metre from its flange


@dataclass(frozen=True)
class FeedbackInput:
    """A digital input that reads ``value`` while the gripper holds a part (vacuum switch,
    finger sensor)."""

    bank: OutputBank  # standard (control box) or tool (flange connector)
    index: int  # input number: 0-7 standard, 0-1 tool
    value: bool  # input level that means "part held"


@dataclass(frozen=True)
class GripperConfig:
    """``type: digital-output``: one digital output that closes the gripper (suction valve,
    finger gripper), optionally with a feedback input that confirms the grasp."""

    bank: OutputBank  # standard (control box) or tool (flange connector)
    index: int  # output number: 0-7 standard, 0-1 tool
    close_value: bool  # output level that closes the gripper / switches suction on
    settle_s: float = 0.5  # wait after switching before the retreat starts (s)
    confirm_input: FeedbackInput | None = None  # None: grasps are never confirmed
    confirm_timeout_s: float = 1.0  # how long the input may take to follow the output (s)

    kind = "digital-output"


@dataclass(frozen=True)
class Robotiq2FConfig:
    """``type: robotiq-2f``: a Robotiq 2F-85/140 through its URCap's socket on the robot's host.

    Widths are between the fingers (mm); positions map linearly from ``stroke_mm`` (register 0,
    open) to 0 mm (register 255), which a calibrated gripper follows to a few millimetres.
    """

    expected_width_mm: tuple[float, float]  # a grasp stopping inside [min, max] is confirmed
    speed_pct: float = 100.0  # closing and opening speed, % of the gripper's range
    force_pct: float = 50.0  # grip force, % of the gripper's range
    stroke_mm: float = 85.0  # finger opening at position 0: 85 (2F-85) or 140 (2F-140)
    port: int = 63352  # the URCap's socket
    timeout_s: float = 1.0  # longest wait for one answer on the socket (s)

    kind = "robotiq-2f"


AnyGripperConfig = GripperConfig | Robotiq2FConfig


@dataclass(frozen=True)
class Payload:
    """A payload as UR's ``set_payload`` takes it: mass (kg) and centre of gravity (m) in the
    tool flange frame."""

    mass_kg: float
    cog_flange_m: tuple[float, float, float]


@dataclass(frozen=True)
class ObjectConfig:
    """The picked part: its mass (kg) and centre of gravity in the TCP frame at grasp (m)."""

    mass_kg: float
    cog_tcp_m: tuple[float, float, float]


@dataclass(frozen=True)
class RobotConfig:
    """The arm and what the pendant must be set to."""

    host: str  # controller IP address or host name
    T_flange_tcp: Transform  # expected active TCP offset on the controller (m), checked at connect
    tcp_offset_tolerance_mm: float = 1.0  # accepted translation difference, controller vs config
    tcp_offset_tolerance_deg: float = 1.0  # accepted rotation difference, controller vs config
    gripper: AnyGripperConfig | None = None  # None: the pick moves only, no gripper is used
    watchdog_s: float = 0.2  # the controller stops the program this long after the PC goes silent
    tool_payload: Payload | None = None  # the empty tool's payload, restored after a release


@dataclass(frozen=True)
class HandEyeConfig:
    """Where the hand-eye calibration result is and how to read it."""

    mode: HandEyeMode  # eye-in-hand: file holds T_flange_cam; eye-to-hand: T_base_cam
    file: Path  # absolute, resolved relative to the config file
    units: LengthUnit  # length unit of the file's translation ("mm" for Zivid)
    invert: bool = False  # the file was written the other way round (T_cam_flange / T_cam_base)
    acknowledge: tuple[str, ...] = ()  # plausibility checks this cell's unusual mount fails
    # camera_position_mm (base frame for eye-to-hand, flange frame for eye-in-hand) and its
    # tolerance: tells a file from its inverse; None when not measured
    camera_position: MeasuredCamera | None = None


@dataclass(frozen=True)
class GraspConfig:
    """Where the TCP goes relative to the detected object."""

    approach_mm: float  # approach point: grasp moved back along the grasp's tool z (mm)
    retreat_mm: float  # retreat point: grasp moved back along the grasp's tool z (mm)
    T_obj_tcp: Transform = field(default_factory=lambda: np.eye(4))  # TCP at grasp in object frame


@dataclass(frozen=True)
class MotionConfig:
    """moveL parameters of the TCP."""

    speed_mps: float  # approach and retreat moves (m/s)
    accel_mps2: float  # every move (m/s^2)
    grasp_speed_mps: float  # the final move from approach to grasp (m/s)
    stop_decel_mps2: float = 10.0  # stopL deceleration on a fault or Ctrl-C (m/s^2)
    timeout_margin_s: float = 5.0  # added to a move's expected duration before it counts as hung
    joint_speed_rps: float = 0.5  # moveJ to a named joint pose: fastest joint (rad/s)
    joint_accel_rps2: float = 1.0  # moveJ to a named joint pose (rad/s^2)


@dataclass(frozen=True)
class WorkspaceConfig:
    """A box in the robot base frame that every TCP target must lie in, and a tilt limit."""

    min_mm: tuple[float, float, float]  # lower corner, base frame (mm)
    max_mm: tuple[float, float, float]  # upper corner, base frame (mm)
    max_tilt_deg: float  # largest angle between tool z and straight down (base -z), degrees


@dataclass(frozen=True)
class AuditConfig:
    """Where pick records are appended."""

    file: Path  # JSON lines, absolute, resolved relative to the config file


@dataclass(frozen=True)
class NamedPose:
    """A pose the cell moves to by name (``capture``, ``home``, ``clear``): exactly one of a
    joint target (moveJ, rad) or a TCP target in the base frame (moveL, m)."""

    name: str
    q_rad: tuple[float, ...] | None  # six joint positions (rad), or None
    T_base_tcp: Transform | None  # TCP pose in base (m), or None


@dataclass(frozen=True)
class PlaceConfig:
    """Where a picked part is put down: TCP poses in the base frame used in turn (a pallet)."""

    T_base_tcp: tuple[Transform, ...]  # place poses (m), the n-th place uses n % len
    approach_mm: float  # approach point: place pose moved back along its tool z (mm)
    retreat_mm: float  # retreat point after the release, the same way back (mm)


@dataclass(frozen=True)
class CaptureConfig:
    """How a capture latches the flange pose."""

    pose: str | None = None  # named pose a capture moves to first (eye-to-hand: out of view)
    steady_timeout_s: float = 2.0  # longest wait for the arm to come to rest before latching (s)


@dataclass(frozen=True)
class CellConfig:
    """The whole cell configuration, as loaded from ``path``."""

    robot: RobotConfig
    hand_eye: HandEyeConfig
    grasp: GraspConfig
    motion: MotionConfig
    workspace: WorkspaceConfig
    audit: AuditConfig
    path: Path  # the config file itself (absolute)
    poses: tuple[NamedPose, ...] = ()  # named poses, in file order
    place: PlaceConfig | None = None  # None: a pick ends holding the part ("picked")
    capture: CaptureConfig = field(default_factory=CaptureConfig)
    object: ObjectConfig | None = None  # None: the payload is never changed

    def pose(self, name: str) -> NamedPose:
        """The named pose ``name``; ConfigError naming the known ones when it is not defined."""
        for pose in self.poses:
            if pose.name == name:
                return pose
        known = ", ".join(p.name for p in self.poses) or "none"
        raise ConfigError(f"{self.path}: poses: no pose named {name!r} (defined: {known})")


# --- reading YAML strictly ----------------------------------------------------------------------


def read_yaml_mapping(path: Path, error: type[InputError], what: str = "file") -> object:
    """Parse ``path`` (a ``what``: "cell config", "detection file") as YAML with
    ``inputfiles.BoundedLoader``: safe constructors only, duplicate keys refused, size, values
    and nesting bounded.

    Raises ``error`` with one line naming the file (and the line and column of a YAML error).
    """
    data = read_input_bytes(path, what, error)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise error(f"{path}: not UTF-8 text (a binary file?)") from None
    try:
        return yaml.load(text, Loader=BoundedLoader)  # a SafeLoader subclass: safe
    except yaml.YAMLError as exc:
        raise error(f"{path}: not valid YAML: {yaml_problem(exc)}") from None


class Fields:
    """Typed access to one YAML mapping; every error names the source file and the key path.

    Unknown keys are refused when the mapping is opened, so a misspelt key never falls back to a
    default.
    """

    def __init__(
        self,
        data: object,
        *,
        source: str,
        prefix: str,
        allowed: Collection[str],
        error: type[InputError],
    ) -> None:
        self.source = source
        self.prefix = prefix
        self.error = error
        if not isinstance(data, dict):
            self.fail("", f"expected a mapping of keys, got {_describe(data)}")
        self.data: dict[object, object] = data
        for key in data:
            if key not in allowed:
                name = str(key)[:80]  # a hostile file's key may be a megabyte long
                hint = difflib.get_close_matches(name, list(allowed), n=1)
                also = f"; did you mean {hint[0]!r}?" if hint else ""
                self.fail(name, f"unknown key (expected one of {', '.join(sorted(allowed))}){also}")

    def path(self, key: str) -> str:
        """The dotted key path, e.g. ``motion.speed_mps``."""
        if not self.prefix:
            return key
        return f"{self.prefix}.{key}" if key else self.prefix

    def fail(self, key: str, message: str) -> NoReturn:
        where = self.path(key) or "top level"
        raise self.error(f"{self.source}: {where}: {message}")

    def has(self, key: str) -> bool:
        return key in self.data

    def raw(self, key: str) -> object:
        """The value of a required key."""
        if key not in self.data:
            self.fail(key, "missing (required)")
        return self.data[key]

    def section(self, key: str, allowed: Collection[str]) -> Fields:
        """A nested mapping (required)."""
        return Fields(
            self.raw(key),
            source=self.source,
            prefix=self.path(key),
            allowed=allowed,
            error=self.error,
        )

    def number(
        self,
        key: str,
        *,
        default: float | None = None,
        minimum: float | None = None,
        above: float | None = None,
        maximum: float | None = None,
        unit: str = "",
    ) -> float:
        """A finite number (int or float, never bool) in ``[minimum, maximum]`` / ``> above``."""
        if default is not None and key not in self.data:
            return default
        value = self._to_float(key, self.raw(key))
        suffix = f" {unit}" if unit else ""
        if minimum is not None and value < minimum:
            self.fail(key, f"must be at least {minimum:g}{suffix}, got {value:g}")
        if above is not None and value <= above:
            self.fail(key, f"must be greater than {above:g}{suffix}, got {value:g}")
        if maximum is not None and value > maximum:
            self.fail(key, f"must be at most {maximum:g}{suffix}, got {value:g}")
        return value

    def integer(self, key: str, *, minimum: int, maximum: int) -> int:
        value = self.raw(key)
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(key, f"expected an integer, got {_describe(value)}")
        if not minimum <= value <= maximum:
            self.fail(key, f"must be between {minimum} and {maximum}, got {value}")
        return value

    def boolean(self, key: str, *, default: bool | None = None) -> bool:
        if default is not None and key not in self.data:
            return default
        value = self.raw(key)
        if not isinstance(value, bool):
            self.fail(key, f"expected true or false, got {_describe(value)}")
        return value

    def string(self, key: str, *, choices: Collection[str] | None = None) -> str:
        value = self.raw(key)
        if not isinstance(value, str) or not value.strip():
            self.fail(key, f"expected a non-empty string, got {_describe(value)}")
        if choices is not None and value not in choices:
            self.fail(key, f"expected one of {', '.join(choices)}, got {value!r}")
        return value

    def vector(self, key: str, length: int) -> NDArray[np.float64]:
        """A list of ``length`` finite numbers."""
        value = self.raw(key)
        if not isinstance(value, list) or len(value) != length:
            self.fail(key, f"expected a list of {length} numbers, got {_describe(value)}")
        return np.array([self._to_float(f"{key}[{i}]", v) for i, v in enumerate(value)])

    def matrix(self, key: str, rows: int, cols: int) -> NDArray[np.float64]:
        """A list of ``rows`` lists of ``cols`` finite numbers."""
        value = self.raw(key)
        if not isinstance(value, list) or len(value) != rows:
            self.fail(key, f"expected {rows} rows of {cols} numbers, got {_describe(value)}")
        out = np.empty((rows, cols))
        for i, row in enumerate(value):
            if not isinstance(row, list) or len(row) != cols:
                self.fail(f"{key}[{i}]", f"expected a row of {cols} numbers, got {_describe(row)}")
            out[i] = [self._to_float(f"{key}[{i}][{j}]", v) for j, v in enumerate(row)]
        return out

    def _to_float(self, key: str, value: object) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            hint = ""
            if isinstance(value, str) and _parses_as_float(value):
                if "e" in value.lower():
                    # YAML 1.1 (PyYAML) reads 1e-3 and 1.0e3 as text: it needs a dot and a sign.
                    hint = (
                        " (YAML reads an exponent as a number only with a dot and a sign: "
                        "write 1.0e-3 or 1.0e+3, not 1e-3 or 1.0e3)"
                    )
                else:
                    hint = " (remove the quotes around the number)"
            self.fail(key, f"expected a number, got {_describe(value)}{hint}")
        number = float(value)
        if not math.isfinite(number):
            self.fail(key, f"expected a finite number, got {number}")
        return number


def _parses_as_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _describe(value: object) -> str:
    if value is None:
        return "nothing (null)"
    if isinstance(value, bool):
        return f"boolean {value}"
    if isinstance(value, str):
        return f"string {shown(value)}"
    if isinstance(value, list):
        return f"a list of {len(value)} items"
    if isinstance(value, dict):
        return "a mapping"
    return f"{type(value).__name__} {shown(value)}"


# --- the cell config ----------------------------------------------------------------------------


def load_config(path: Path) -> CellConfig:
    """Read and validate a cell config; file paths in it are resolved relative to its folder."""
    path = Path(path).resolve()
    top = Fields(
        read_yaml_mapping(path, ConfigError, "cell config"),
        source=str(path),
        prefix="",
        allowed=(
            "robot",
            "hand_eye",
            "grasp",
            "motion",
            "workspace",
            "audit",
            "poses",
            "place",
            "capture",
            "object",
        ),
        error=ConfigError,
    )
    poses = _poses(top) if top.has("poses") else ()
    robot = _robot(top)
    part = _object(top) if top.has("object") else None
    if part is not None and robot.tool_payload is None:
        top.fail(
            "object",
            "a part's payload needs the empty tool's too: set robot.tool_payload "
            "{mass_kg, cog_mm} (as on the pendant's payload screen), restored after each release",
        )
    return CellConfig(
        robot=robot,
        hand_eye=_hand_eye(top, path.parent),
        grasp=_grasp(top),
        motion=_motion(top),
        workspace=_workspace(top),
        audit=_audit(top, path.parent),
        path=path,
        poses=poses,
        place=_place(top) if top.has("place") else None,
        capture=_capture(top, poses) if top.has("capture") else CaptureConfig(),
        object=part,
    )


def _pose_vector(fields: Fields, key: str, max_translation_m: float) -> Transform:
    """A UR pose vector [x, y, z, rx, ry, rz] in m and rad, checked for unit mix-ups."""
    pose = fields.vector(key, 6)
    distance = math.hypot(*pose[:3].tolist())  # no overflow (and no numpy warning) at 1e308
    if distance > max_translation_m:
        fields.fail(
            key,
            f"translation is {distance:g} m long, more than {max_translation_m:g} m: "
            "this key is in metres (millimetres given?)",
        )
    angle = math.hypot(*pose[3:].tolist())
    if angle > MAX_ROTVEC_RAD:
        fields.fail(
            key,
            f"rotation vector is {angle:g} rad long, more than 2*pi: "
            "this key is in radians (degrees given?)",
        )
    return ur_pose_to_matrix(pose)


def _robot(top: Fields) -> RobotConfig:
    robot = top.section(
        "robot",
        (
            "host",
            "tcp_offset",
            "tcp_offset_tolerance_mm",
            "tcp_offset_tolerance_deg",
            "gripper",
            "watchdog_s",
            "tool_payload",
        ),
    )
    return RobotConfig(
        host=robot.string("host"),
        T_flange_tcp=_pose_vector(robot, "tcp_offset", MAX_TCP_OFFSET_M),
        tcp_offset_tolerance_mm=robot.number(
            "tcp_offset_tolerance_mm",
            default=RobotConfig.tcp_offset_tolerance_mm,
            above=0.0,
            maximum=20.0,
            unit="mm",
        ),
        tcp_offset_tolerance_deg=robot.number(
            "tcp_offset_tolerance_deg",
            default=RobotConfig.tcp_offset_tolerance_deg,
            above=0.0,
            maximum=10.0,
            unit="deg",
        ),
        gripper=_gripper(robot) if robot.has("gripper") else None,
        watchdog_s=robot.number(
            "watchdog_s", default=RobotConfig.watchdog_s, minimum=0.05, maximum=2.0, unit="s"
        ),
        tool_payload=_tool_payload(robot) if robot.has("tool_payload") else None,
    )


GRIPPER_TYPES = ("digital-output", "robotiq-2f")
_DIGITAL_KEYS = ("bank", "index", "close_value", "settle_s", "confirm_input", "confirm_timeout_s")
_ROBOTIQ_KEYS = ("expected_width_mm", "speed_pct", "force_pct", "stroke_mm", "port", "timeout_s")


def _gripper(robot: Fields) -> AnyGripperConfig:
    raw = robot.raw("gripper")
    kind = raw.get("type", "digital-output") if isinstance(raw, dict) else None
    if kind == "robotiq-2f":
        return _robotiq(robot.section("gripper", ("type", *_ROBOTIQ_KEYS)))
    gripper = robot.section("gripper", ("type", *_DIGITAL_KEYS))
    if gripper.has("type"):
        gripper.string("type", choices=GRIPPER_TYPES)
    bank, index = _io_point(gripper)
    return GripperConfig(
        bank=bank,
        index=index,
        close_value=gripper.boolean("close_value"),
        settle_s=gripper.number(
            "settle_s", default=GripperConfig.settle_s, minimum=0.0, maximum=10.0, unit="s"
        ),
        confirm_input=_feedback(gripper) if gripper.has("confirm_input") else None,
        confirm_timeout_s=gripper.number(
            "confirm_timeout_s",
            default=GripperConfig.confirm_timeout_s,
            above=0.0,
            maximum=10.0,
            unit="s",
        ),
    )


def _io_point(fields: Fields) -> tuple[OutputBank, int]:
    """``bank`` and ``index`` of one digital output or input (0-7 standard, 0-1 tool)."""
    bank = OutputBank(fields.string("bank", choices=[b.value for b in OutputBank]))
    count = TOOL_OUTPUTS if bank is OutputBank.TOOL else STANDARD_OUTPUTS
    return bank, fields.integer("index", minimum=0, maximum=count - 1)


def _feedback(gripper: Fields) -> FeedbackInput:
    feedback = gripper.section("confirm_input", ("bank", "index", "value"))
    bank, index = _io_point(feedback)
    return FeedbackInput(bank, index, feedback.boolean("value"))


def _robotiq(gripper: Fields) -> Robotiq2FConfig:
    stroke_mm = gripper.number(
        "stroke_mm", default=Robotiq2FConfig.stroke_mm, minimum=10.0, maximum=300.0, unit="mm"
    )
    low, high = (float(v) for v in gripper.vector("expected_width_mm", 2))
    if not 0.0 <= low <= high <= stroke_mm:
        gripper.fail(
            "expected_width_mm",
            f"expected [min, max] with 0 <= min <= max <= stroke_mm ({stroke_mm:g} mm), "
            f"got [{low:g}, {high:g}]",
        )
    return Robotiq2FConfig(
        expected_width_mm=(low, high),
        speed_pct=gripper.number(
            "speed_pct", default=Robotiq2FConfig.speed_pct, minimum=0.0, maximum=100.0, unit="%"
        ),
        force_pct=gripper.number(
            "force_pct", default=Robotiq2FConfig.force_pct, minimum=0.0, maximum=100.0, unit="%"
        ),
        stroke_mm=stroke_mm,
        port=gripper.integer("port", minimum=1, maximum=65535)
        if gripper.has("port")
        else Robotiq2FConfig.port,
        timeout_s=gripper.number(
            "timeout_s", default=Robotiq2FConfig.timeout_s, above=0.0, maximum=10.0, unit="s"
        ),
    )


def _mass_and_cog(fields: Fields) -> tuple[float, tuple[float, float, float]]:
    """``mass_kg`` and ``cog_mm`` (converted to m), checked for unit mix-ups."""
    mass_kg = fields.number("mass_kg", minimum=0.0, maximum=MAX_PAYLOAD_KG, unit="kg")
    cog_m = fields.vector("cog_mm", 3) / 1000.0
    if float(np.linalg.norm(cog_m)) * 1000.0 > MAX_COG_MM:
        fields.fail("cog_mm", f"more than {MAX_COG_MM:g} mm from the origin (metres typed?)")
    return mass_kg, (float(cog_m[0]), float(cog_m[1]), float(cog_m[2]))


def _tool_payload(robot: Fields) -> Payload:
    mass_kg, cog_m = _mass_and_cog(robot.section("tool_payload", ("mass_kg", "cog_mm")))
    return Payload(mass_kg, cog_m)


def _object(top: Fields) -> ObjectConfig:
    mass_kg, cog_m = _mass_and_cog(top.section("object", ("mass_kg", "cog_mm")))
    return ObjectConfig(mass_kg, cog_m)


def _hand_eye(top: Fields, folder: Path) -> HandEyeConfig:
    hand_eye = top.section(
        "hand_eye",
        (
            "mode",
            "file",
            "units",
            "invert",
            "acknowledge",
            "camera_position_mm",
            "camera_position_tolerance_mm",
        ),
    )
    mode = HandEyeMode(hand_eye.string("mode", choices=[m.value for m in HandEyeMode]))
    units: LengthUnit = "mm" if hand_eye.string("units", choices=("mm", "m")) == "mm" else "m"
    return HandEyeConfig(
        mode=mode,
        file=_existing_file(hand_eye, "file", folder),
        units=units,
        invert=hand_eye.boolean("invert", default=HandEyeConfig.invert),
        acknowledge=_acknowledged_checks(hand_eye) if hand_eye.has("acknowledge") else (),
        camera_position=_measured_camera(hand_eye, mode),
    )


def _measured_camera(hand_eye: Fields, mode: HandEyeMode) -> MeasuredCamera | None:
    """``camera_position_mm`` and ``camera_position_tolerance_mm``; None when not measured."""
    if not hand_eye.has("camera_position_mm"):
        if hand_eye.has("camera_position_tolerance_mm"):
            hand_eye.fail(
                "camera_position_tolerance_mm",
                f"applies to {hand_eye.path('camera_position_mm')}, which is not set",
            )
        return None
    x, y, z = (float(v) for v in hand_eye.vector("camera_position_mm", 3))
    problem = measured_position_problem(mode, (x, y, z))
    if problem is not None:
        hand_eye.fail("camera_position_mm", problem)
    tolerance_mm = hand_eye.number(
        "camera_position_tolerance_mm",
        default=MeasuredCamera.tolerance_mm,
        above=0.0,
        maximum=MAX_CAMERA_POSITION_TOLERANCE_MM,
        unit="mm",
    )
    return MeasuredCamera((x, y, z), tolerance_mm)


def _acknowledged_checks(hand_eye: Fields) -> tuple[str, ...]:
    """Names of plausibility checks (``plausibility.CHECKS``), each given once."""
    value = hand_eye.raw("acknowledge")
    if not isinstance(value, list) or not value:
        hand_eye.fail("acknowledge", f"expected a list of check names, got {_describe(value)}")
    for i, name in enumerate(value):
        if name not in CHECKS or name in value[:i]:
            problem = "given twice" if name in CHECKS else f"expected one of {', '.join(CHECKS)}"
            hand_eye.fail(f"acknowledge[{i}]", f"{problem}, got {_describe(name)}")
    return tuple(value)


def _existing_file(fields: Fields, key: str, folder: Path) -> Path:
    path = (folder / fields.string(key)).resolve()
    if not path.is_file():
        fields.fail(key, f"file not found: {path}")
    return path


def _grasp(top: Fields) -> GraspConfig:
    grasp = top.section("grasp", ("approach_mm", "retreat_mm", "object_T_tcp"))
    return GraspConfig(
        approach_mm=grasp.number(
            "approach_mm", minimum=MIN_STANDOFF_MM, maximum=MAX_STANDOFF_MM, unit="mm"
        ),
        retreat_mm=grasp.number(
            "retreat_mm", minimum=MIN_STANDOFF_MM, maximum=MAX_STANDOFF_MM, unit="mm"
        ),
        T_obj_tcp=(
            _pose_vector(grasp, "object_T_tcp", MAX_OBJECT_OFFSET_M)
            if grasp.has("object_T_tcp")
            else np.eye(4)
        ),
    )


def _motion(top: Fields) -> MotionConfig:
    motion = top.section(
        "motion",
        (
            "speed_mps",
            "accel_mps2",
            "grasp_speed_mps",
            "stop_decel_mps2",
            "timeout_margin_s",
            "joint_speed_rps",
            "joint_accel_rps2",
        ),
    )
    speed = motion.number("speed_mps", above=0.0, maximum=MAX_SPEED_MPS, unit="m/s")
    grasp_speed = motion.number(
        "grasp_speed_mps", above=0.0, maximum=MAX_GRASP_SPEED_MPS, unit="m/s"
    )
    if grasp_speed > speed:
        motion.fail(
            "grasp_speed_mps",
            f"the grasp move must not be faster than motion.speed_mps ({speed:g} m/s), "
            f"got {grasp_speed:g} m/s",
        )
    accel = motion.number("accel_mps2", above=0.0, maximum=MAX_ACCEL_MPS2, unit="m/s^2")
    stop_decel = motion.number(
        "stop_decel_mps2", default=MotionConfig.stop_decel_mps2, above=0.0, unit="m/s^2"
    )
    problem = stop_decel_problem(stop_decel, accel)
    if problem is not None:
        motion.fail("stop_decel_mps2", problem)
    return MotionConfig(
        speed_mps=speed,
        accel_mps2=accel,
        grasp_speed_mps=grasp_speed,
        stop_decel_mps2=stop_decel,
        timeout_margin_s=motion.number(
            "timeout_margin_s",
            default=MotionConfig.timeout_margin_s,
            above=0.0,
            maximum=120.0,
            unit="s",
        ),
        joint_speed_rps=motion.number(
            "joint_speed_rps",
            default=MotionConfig.joint_speed_rps,
            above=0.0,
            maximum=MAX_JOINT_SPEED_RPS,
            unit="rad/s",
        ),
        joint_accel_rps2=motion.number(
            "joint_accel_rps2",
            default=MotionConfig.joint_accel_rps2,
            above=0.0,
            maximum=MAX_JOINT_ACCEL_RPS2,
            unit="rad/s^2",
        ),
    )


def _workspace(top: Fields) -> WorkspaceConfig:
    workspace = top.section("workspace", ("min_mm", "max_mm", "max_tilt_deg"))
    corners = {}
    for key in ("min_mm", "max_mm"):
        corner = workspace.vector(key, 3)
        if np.any(np.abs(corner) > MAX_WORKSPACE_MM):
            workspace.fail(
                key, f"coordinates must lie within +-{MAX_WORKSPACE_MM:g} mm, got {corner.tolist()}"
            )
        corners[key] = corner
    extent = corners["max_mm"] - corners["min_mm"]
    for axis, size in zip("xyz", extent, strict=True):
        if size < MIN_WORKSPACE_EXTENT_MM:
            workspace.fail(
                "max_mm",
                f"{axis} must be at least {MIN_WORKSPACE_EXTENT_MM:g} mm above min_mm "
                f"(min {corners['min_mm'].tolist()}, max {corners['max_mm'].tolist()}; "
                "min above max, or metres given?)",
            )
    lo, hi = corners["min_mm"], corners["max_mm"]
    return WorkspaceConfig(
        min_mm=(float(lo[0]), float(lo[1]), float(lo[2])),
        max_mm=(float(hi[0]), float(hi[1]), float(hi[2])),
        max_tilt_deg=workspace.number("max_tilt_deg", minimum=0.0, maximum=180.0, unit="deg"),
    )


def _audit(top: Fields, folder: Path) -> AuditConfig:
    audit = top.section("audit", ("file",))
    path = (folder / audit.string("file")).resolve()
    if not path.parent.is_dir():
        audit.fail("file", f"folder does not exist: {path.parent}")
    return AuditConfig(file=path)


def _poses(top: Fields) -> tuple[NamedPose, ...]:
    data = top.raw("poses")
    if not isinstance(data, dict) or not data:
        top.fail("poses", f"expected a mapping of pose names, got {_describe(data)}")
    poses = []
    for name in data:
        if not isinstance(name, str) or not name.strip():
            top.fail("poses", f"pose names must be non-empty strings, got {name!r}")
        pose = top.section("poses", data.keys()).section(name, NAMED_POSE_KEYS)
        poses.append(named_pose(pose, name))
    return tuple(poses)


def named_pose(pose: Fields, name: str) -> NamedPose:
    """One pose entry, opened with ``NAMED_POSE_KEYS``: exactly one of ``joints_rad`` (six
    joints, rad, moveJ) or ``tcp_pose`` (``T_base_tcp`` as a UR vector, m and rad, moveL), each
    checked for a unit mix-up. The calibration pose list (``pose_list``) reads its entries so."""
    if pose.has("joints_rad") == pose.has("tcp_pose"):
        pose.fail("", "give exactly one of joints_rad (6 joints, rad) or tcp_pose (m, rad)")
    if pose.has("joints_rad"):
        q = pose.vector("joints_rad", 6)
        if np.any(np.abs(q) > MAX_JOINT_RAD):
            pose.fail(
                "joints_rad",
                f"joint positions must lie within +-2*pi rad, got {q.tolist()} (degrees given?)",
            )
        return NamedPose(name, tuple(float(v) for v in q), None)
    return NamedPose(name, None, _pose_vector(pose, "tcp_pose", MAX_REACH_M))


def _place(top: Fields) -> PlaceConfig:
    place = top.section("place", ("poses", "approach_mm", "retreat_mm"))
    listed = place.raw("poses")
    if not isinstance(listed, list) or not listed:
        place.fail("poses", f"expected a list of TCP poses (m, rad), got {_describe(listed)}")
    indexed = Fields(
        {str(i): v for i, v in enumerate(listed)},
        source=place.source,
        prefix=place.path("poses"),
        allowed=[str(i) for i in range(len(listed))],
        error=ConfigError,
    )
    return PlaceConfig(
        T_base_tcp=tuple(_pose_vector(indexed, str(i), MAX_REACH_M) for i in range(len(listed))),
        approach_mm=place.number(
            "approach_mm", minimum=MIN_STANDOFF_MM, maximum=MAX_STANDOFF_MM, unit="mm"
        ),
        retreat_mm=place.number(
            "retreat_mm", minimum=MIN_STANDOFF_MM, maximum=MAX_STANDOFF_MM, unit="mm"
        ),
    )


def _capture(top: Fields, poses: tuple[NamedPose, ...]) -> CaptureConfig:
    capture = top.section("capture", ("pose", "steady_timeout_s"))
    name = capture.string("pose") if capture.has("pose") else None
    if name is not None and name not in {pose.name for pose in poses}:
        known = ", ".join(pose.name for pose in poses) or "none"
        capture.fail("pose", f"no pose named {name!r} under poses (defined: {known})")
    return CaptureConfig(
        pose=name,
        steady_timeout_s=capture.number(
            "steady_timeout_s",
            default=CaptureConfig.steady_timeout_s,
            above=0.0,
            maximum=30.0,
            unit="s",
        ),
    )
