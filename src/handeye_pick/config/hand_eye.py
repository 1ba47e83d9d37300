"""The ``hand_eye`` section: where the calibration result is, how to read it, and what tells it
from its inverse (a measured camera position, checks the cell's mount is known to fail)."""

from __future__ import annotations

from pathlib import Path

from handeye_pick.calibration.files import HandEyeMode
from handeye_pick.calibration.plausibility import (
    CHECKS,
    MAX_CAMERA_POSITION_TOLERANCE_MM,
    MeasuredCamera,
    measured_position_problem,
)
from handeye_pick.config.reader import Fields, Number, describe
from handeye_pick.config.schema import HandEyeConfig
from handeye_pick.geometry import LengthUnit

_NUMBERS = {
    "camera_position_tolerance_mm": Number(
        "mm",
        above=0.0,
        maximum=MAX_CAMERA_POSITION_TOLERANCE_MM,
        default=MeasuredCamera.tolerance_mm,
    ),
}
_KEYS = ("mode", "file", "units", "invert", "acknowledge", "camera_position_mm", *_NUMBERS)


def read_hand_eye(top: Fields, folder: Path) -> HandEyeConfig:
    """``hand_eye``; its ``file`` is resolved relative to ``folder`` (the config file's)."""
    hand_eye = top.section("hand_eye", _KEYS)
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
    tolerance_mm = hand_eye.number("camera_position_tolerance_mm", _NUMBERS)
    return MeasuredCamera((x, y, z), tolerance_mm)


def _acknowledged_checks(hand_eye: Fields) -> tuple[str, ...]:
    """Names of plausibility checks (``plausibility.CHECKS``), each given once."""
    value = hand_eye.raw("acknowledge")
    if not isinstance(value, list) or not value:
        hand_eye.fail("acknowledge", f"expected a list of check names, got {describe(value)}")
    for i, name in enumerate(value):
        if name not in CHECKS or name in value[:i]:
            problem = "given twice" if name in CHECKS else f"expected one of {', '.join(CHECKS)}"
            hand_eye.fail(f"acknowledge[{i}]", f"{problem}, got {describe(name)}")
    return tuple(value)


def _existing_file(fields: Fields, key: str, folder: Path) -> Path:
    path = (folder / fields.string(key)).resolve()
    if not path.is_file():
        fields.fail(key, f"file not found: {path}")
    return path
