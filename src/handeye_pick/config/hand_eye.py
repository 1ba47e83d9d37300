"""The ``hand_eye`` section: where the calibration result is, how to read it, and what tells it
from its inverse (a measured camera position, checks the cell's mount is known to fail); and the
calibration it names, loaded (``calibration_from_config``)."""

from __future__ import annotations

from pathlib import Path

from handeye_pick.config.reader import Fields, Number, describe
from handeye_pick.config.schema import CellConfig, HandEyeConfig
from handeye_pick.geometry import LengthUnit
from handeye_pick.hand_eye.files import CELL_CONFIG, HandEyeCalibration, HandEyeMode, load_hand_eye
from handeye_pick.hand_eye.plausibility import (
    CHECKS,
    MAX_CAMERA_POSITION_TOLERANCE_MM,
    MeasuredCamera,
    measured_position_problem,
)

_NUMBERS = {
    "camera_position_tolerance_mm": Number(
        "mm",
        above=0.0,
        maximum=MAX_CAMERA_POSITION_TOLERANCE_MM,
        default=MeasuredCamera.tolerance_mm,
    ),
}
_KEYS = ("mode", "file", "units", "invert", "acknowledge", "camera_position_mm", *_NUMBERS)


def calibration_from_config(config: CellConfig) -> HandEyeCalibration:
    """The hand-eye calibration the cell configuration names (file, mode, units, inversion)."""
    hand_eye = config.hand_eye
    return load_hand_eye(
        hand_eye.file, hand_eye.mode, hand_eye.units, hand_eye.invert, settings=CELL_CONFIG
    )


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
