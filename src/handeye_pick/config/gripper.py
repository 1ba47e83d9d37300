"""The gripper's configuration, ``robot.gripper`` in the cell config: one frozen dataclass per
kind (``type: digital-output`` or ``type: robotiq-2f``) and the parser that reads it.

A gripper without ``type`` is a digital-output gripper (configs from before the Robotiq kind).
"""

from __future__ import annotations

from dataclasses import dataclass

from handeye_pick.config.reader import Fields, Number
from handeye_pick.robot.port import OutputBank

STANDARD_OUTPUTS = 8  # standard digital outputs and inputs 0-7 on the control box
TOOL_OUTPUTS = 2  # tool digital outputs and inputs 0-1 on the tool flange connector


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

GRIPPER_TYPES = (GripperConfig.kind, Robotiq2FConfig.kind)

_DIGITAL_NUMBERS = {
    "settle_s": Number("s", minimum=0.0, maximum=10.0, default=GripperConfig.settle_s),
    "confirm_timeout_s": Number(
        "s", above=0.0, maximum=10.0, default=GripperConfig.confirm_timeout_s
    ),
}
_DIGITAL_KEYS = ("type", "bank", "index", "close_value", "confirm_input", *_DIGITAL_NUMBERS)

_ROBOTIQ_NUMBERS = {
    "stroke_mm": Number("mm", minimum=10.0, maximum=300.0, default=Robotiq2FConfig.stroke_mm),
    "speed_pct": Number("%", minimum=0.0, maximum=100.0, default=Robotiq2FConfig.speed_pct),
    "force_pct": Number("%", minimum=0.0, maximum=100.0, default=Robotiq2FConfig.force_pct),
    "timeout_s": Number("s", above=0.0, maximum=10.0, default=Robotiq2FConfig.timeout_s),
}
_ROBOTIQ_KEYS = ("type", "expected_width_mm", "port", *_ROBOTIQ_NUMBERS)


def read_gripper(robot: Fields) -> AnyGripperConfig:
    """``robot.gripper``, of the kind its ``type`` names (digital-output when it has none)."""
    raw = robot.raw("gripper")
    kind = raw.get("type", GripperConfig.kind) if isinstance(raw, dict) else None
    if kind == Robotiq2FConfig.kind:
        return _robotiq(robot.section("gripper", _ROBOTIQ_KEYS))
    # Another type is refused in _digital, once the keys are known to be a gripper's.
    return _digital(robot.section("gripper", _DIGITAL_KEYS))


def _digital(gripper: Fields) -> GripperConfig:
    if gripper.has("type"):
        gripper.string("type", choices=GRIPPER_TYPES)
    bank, index = _io_point(gripper)
    return GripperConfig(
        bank=bank,
        index=index,
        close_value=gripper.boolean("close_value"),
        settle_s=gripper.number("settle_s", _DIGITAL_NUMBERS),
        confirm_input=_feedback(gripper) if gripper.has("confirm_input") else None,
        confirm_timeout_s=gripper.number("confirm_timeout_s", _DIGITAL_NUMBERS),
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
    stroke_mm = gripper.number("stroke_mm", _ROBOTIQ_NUMBERS)
    low, high = (float(v) for v in gripper.vector("expected_width_mm", 2))
    if not 0.0 <= low <= high <= stroke_mm:
        gripper.fail(
            "expected_width_mm",
            f"expected [min, max] with 0 <= min <= max <= stroke_mm ({stroke_mm:g} mm), "
            f"got [{low:g}, {high:g}]",
        )
    return Robotiq2FConfig(
        expected_width_mm=(low, high),
        speed_pct=gripper.number("speed_pct", _ROBOTIQ_NUMBERS),
        force_pct=gripper.number("force_pct", _ROBOTIQ_NUMBERS),
        stroke_mm=stroke_mm,
        port=gripper.integer("port", minimum=1, maximum=65535)
        if gripper.has("port")
        else Robotiq2FConfig.port,
        timeout_s=gripper.number("timeout_s", _ROBOTIQ_NUMBERS),
    )
