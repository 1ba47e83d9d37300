"""Plausibility of the camera-to-base chain, in one place: catches an inverted hand-eye file, a
file used in the wrong mode and a detection no camera could have made, before any base-frame
target is used. Pure: no I/O.

Every command that turns camera data into base-frame data calls ``chain_problems`` and refuses
the problems not acknowledged: ``point`` and ``cloud`` with ``InputError`` (exit 2), motion
commands with ``SafetyRefusal`` (exit 3). A cell with an unusual mount acknowledges one named
check (``hand_eye.acknowledge: [camera-in-front-of-flange]`` in its config, ``--acknowledge
camera-in-front-of-flange`` on the command line); an acknowledged problem is still returned, for
a warning and the audit record, never switched off globally.

The checks (all distances in mm, frames as in the README):

``camera-near-flange`` (eye-in-hand): the camera origin lies at most 500 mm from the flange. A
wrist camera sits 5 to 25 cm from it; a fixed camera's ``T_base_cam`` read as ``T_flange_cam``
puts it a metre or more away.

``camera-in-front-of-flange`` (eye-in-hand): the camera origin lies no more than 10 mm behind the
flange face (z >= -10 mm in the flange frame); behind that it would be inside the wrist. An
inverted file moves the camera to z = -(a . t), where a is its optical axis and t its position:
for a camera mounted in front of the flange and looking along the tool that is behind the face
by about its real height. Limit: a camera whose origin is within 10 mm of the flange plane (or
that looks sideways) gives no such sign when inverted.

``camera-looks-along-tool`` (eye-in-hand): the optical axis (camera z, out of the lens) is within
90 degrees of the tool axis (flange z); a camera looking back into the wrist sees the arm, not
the work. Inversion keeps this angle, so this check finds a fixed camera's file (which looks
down, toward -z of a flange pointing down) and camera frames that are not optical frames.

``camera-away-from-base`` (eye-to-hand): the camera origin lies at least 200 mm from the robot
base origin; closer, it would sit inside the robot's base and shoulder. A wrist camera's
``T_flange_cam`` read as ``T_base_cam`` lands there (5 to 25 cm).

``camera-above-floor`` (eye-to-hand): the camera origin is not below the workspace box's floor
(its min z), or below the robot base plane (z = 0) when no workspace is given.

``camera-looks-at-workspace`` (eye-to-hand, needs a workspace): the optical axis, followed from
the camera forward, passes through the workspace box grown by 100 mm on every side. An inverted
file of a tilted camera looks away from the cell. A camera looking (nearly) straight down,
inverted, is another camera looking straight down from the same height and distance from the
base, mirrored about a vertical plane through the base origin (t' = -R^T t): it passes the three
eye-to-hand checks whenever the mirrored camera still sees the box; the next two checks catch it.

``camera-at-measured-position`` (both modes, when the camera's rough measured position is given:
``hand_eye.camera_position_mm`` in a config, ``--camera-position-mm`` on the command line): the
camera origin lies within the tolerance (default 100 mm: the optical origin is inside the camera
body and a tape measure is rough) of the measured position, which is in the robot base frame for
eye-to-hand and in the flange frame for eye-in-hand. When the inverse file's camera lies within
it instead, the file looks inverted; otherwise the file, its mode or the measurement is wrong.

``camera-position-measured`` (eye-to-hand, needs a workspace, when no position is measured and
the file passes the three eye-to-hand checks): the inverse file fails one of those checks too,
or puts the camera within 100 mm of the file's. Otherwise the file cannot be told from its
inverse and the refusal asks for the measured position.

Limits: without a measured position, ``point`` and ``cloud`` (which know no workspace) cannot
tell a straight-down camera's file from its inverse. An inverse whose camera lies within the
tolerance of the file's is never told apart: for a camera at distance r from the origin (base or
flange) the two rotations then differ by up to about 4 asin(tolerance / 2r), 8 degrees at 1.4 m
with 100 mm (exactly equal positions mean the file is its own inverse).

``object-in-camera-range`` (with a detection): the object lies 50 to 5000 mm from the camera,
the working range of 3D cameras used for picking (a point in cm or m read as mm lands closer).

``object-within-reach`` (with a detection, and the flange pose for eye-in-hand): the object lies
at most 2000 mm from the robot base origin; no UR arm reaches farther than 1750 mm, so a chain
that puts the object beyond is wrong.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from dataclasses import dataclass, replace
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from handeye_pick.errors import HandEyePickError
from handeye_pick.geometry import Transform, compose, invert
from handeye_pick.hand_eye.files import (
    EYE_IN_HAND_RANGE,
    EYE_TO_HAND_RANGE,
    HandEyeCalibration,
    HandEyeMode,
    SettingNames,
)

MAX_CAMERA_FROM_FLANGE_MM = 500.0
MAX_CAMERA_BEHIND_FLANGE_MM = 10.0
MAX_CAMERA_TO_TOOL_AXIS_DEG = 90.0
MIN_CAMERA_FROM_BASE_MM = 200.0
WORKSPACE_VIEW_MARGIN_MM = 100.0
CAMERA_RANGE_MM = (50.0, 5000.0)
MAX_REACH_MM = 2000.0
CAMERA_POSITION_TOLERANCE_MM = 100.0  # default; also how far apart a file and its inverse must be
MAX_CAMERA_POSITION_TOLERANCE_MM = 500.0  # wider, a file and its mirrored inverse may both fit

CHECKS = (
    "camera-near-flange",
    "camera-in-front-of-flange",
    "camera-looks-along-tool",
    "camera-away-from-base",
    "camera-above-floor",
    "camera-looks-at-workspace",
    "camera-at-measured-position",
    "camera-position-measured",
    "object-in-camera-range",
    "object-within-reach",
)


@dataclass(frozen=True)
class Problem:
    """One failed check: its name (as acknowledged), what was found and the likely mistake."""

    check: str
    message: str
    acknowledged: bool  # the cell acknowledged this check: report it, do not refuse


@dataclass(frozen=True)
class MeasuredCamera:
    """The camera origin as the integrator measured it (a tape, a drawing), mm: in the robot base
    frame for eye-to-hand, in the flange frame for eye-in-hand; and how far (mm) the
    calibration's camera origin may lie from it."""

    position_mm: tuple[float, float, float]
    tolerance_mm: float = CAMERA_POSITION_TOLERANCE_MM


def measured_position_problem(mode: HandEyeMode, position_mm: Sequence[float]) -> str | None:
    """Why ``position_mm`` (mm) cannot be a camera position measured for ``mode``, or None: it
    must be 3 finite numbers whose distance from the base (eye-to-hand) or flange (eye-in-hand)
    is in the range the calibration file's own unit check accepts, which catches metres."""
    if len(position_mm) != 3 or not all(math.isfinite(v) for v in position_mm):
        return f"expected 3 finite numbers (mm), got {list(position_mm)}"
    limits = EYE_IN_HAND_RANGE if mode is HandEyeMode.EYE_IN_HAND else EYE_TO_HAND_RANGE
    distance_mm = math.hypot(*position_mm)
    low_mm, high_mm = limits.low_m * 1000.0, limits.high_m * 1000.0
    if low_mm <= distance_mm <= high_mm:
        return None
    return (
        f"the {limits.what} is {distance_mm:g} mm, expected {low_mm:g} to {high_mm:g} mm "
        "(this is in mm: metres given?)"
    )


class WorkspaceBox(Protocol):
    """The workspace box in the robot base frame (``config.WorkspaceConfig`` is one)."""

    @property
    def min_mm(self) -> tuple[float, float, float]: ...

    @property
    def max_mm(self) -> tuple[float, float, float]: ...


def chain_problems(
    calibration: HandEyeCalibration,
    T_base_flange: Transform | None,
    T_cam_obj: Transform | None,
    workspace: WorkspaceBox | None,
    acknowledged: Collection[str] = (),
    *,
    measured: MeasuredCamera | None = None,
) -> list[Problem]:
    """Every check in ``CHECKS`` that fails for this chain, in that order.

    ``T_base_flange`` (m): the flange pose at capture time (eye-in-hand; None when unknown or
    eye-to-hand). ``T_cam_obj`` (m): the detection, None for a whole cloud. ``workspace``: the
    cell's box, None where there is no cell config (``point``, ``cloud``). ``measured``: the
    camera's measured position, None when not given. A problem whose check is in
    ``acknowledged`` comes back with ``acknowledged=True``.
    """
    unknown = sorted(set(acknowledged) - set(CHECKS))
    if unknown:
        raise ValueError(f"unknown plausibility checks {unknown}; known: {', '.join(CHECKS)}")
    found: dict[str, str] = {}
    T_cal_mm = calibration.T_cal[:3, 3] * 1000.0
    optical_axis = calibration.T_cal[:3, 2]
    if calibration.mode is HandEyeMode.EYE_IN_HAND:
        found.update(_eye_in_hand(calibration, T_cal_mm, optical_axis))
    else:
        found.update(_eye_to_hand(calibration, T_cal_mm, optical_axis, workspace))
    if measured is not None:
        found.update(_measured_position(calibration, T_cal_mm, measured))
    elif calibration.mode is HandEyeMode.EYE_TO_HAND and workspace is not None and not found:
        found.update(_inverse_alike(calibration, T_cal_mm, workspace))
    if T_cam_obj is not None:
        found.update(_object(calibration, T_base_flange, T_cam_obj))
    return [
        Problem(check, found[check], check in acknowledged) for check in CHECKS if check in found
    ]


def refuse_implausible(
    problems: Sequence[Problem], settings: SettingNames, error: type[HandEyePickError]
) -> None:
    """Raise ``error`` with one line listing every problem that is not acknowledged and how a
    cell with an unusual mount acknowledges it (``settings.acknowledge``)."""
    refused = [problem for problem in problems if not problem.acknowledged]
    if not refused:
        return
    found = "; ".join(f"{problem.check}: {problem.message}" for problem in refused)
    names = ", ".join(problem.check for problem in refused)
    how = (
        " ".join(f"{settings.acknowledge} {problem.check}" for problem in refused)
        if settings.on_command_line
        else f"{settings.acknowledge}: [{names}]"
    )
    raise error(
        f"implausible camera chain: {found} (if the mount really is unusual, acknowledge the "
        f"check: {how})"
    )


def _eye_in_hand(
    calibration: HandEyeCalibration, t_flange_cam_mm: NDArray[np.float64], axis: NDArray[np.float64]
) -> dict[str, str]:
    names = calibration.settings
    found: dict[str, str] = {}
    distance_mm = float(np.linalg.norm(t_flange_cam_mm))
    if distance_mm > MAX_CAMERA_FROM_FLANGE_MM:
        found["camera-near-flange"] = (
            f"the camera is {distance_mm:.0f} mm from the flange, more than the "
            f"{MAX_CAMERA_FROM_FLANGE_MM:.0f} mm a wrist camera sits from it: this looks like an "
            f"eye-to-hand file (T_base_cam); for a camera fixed in the cell set "
            f"{names.assignment(names.mode, HandEyeMode.EYE_TO_HAND.value)}"
        )
    behind_mm = -float(t_flange_cam_mm[2])
    if behind_mm > MAX_CAMERA_BEHIND_FLANGE_MM:
        found["camera-in-front-of-flange"] = (
            f"the camera sits {behind_mm:.0f} mm behind the flange face, inside the wrist: the "
            f"calibration looks inverted ({_invert_hint(calibration)})"
        )
    angle_deg = math.degrees(math.acos(float(np.clip(axis[2], -1.0, 1.0))))
    if angle_deg > MAX_CAMERA_TO_TOOL_AXIS_DEG:
        found["camera-looks-along-tool"] = (
            f"the camera looks {angle_deg:.0f} deg away from the tool axis, back into the "
            "wrist: this looks like an eye-to-hand file (T_base_cam) "
            f"({names.assignment(names.mode, HandEyeMode.EYE_TO_HAND.value)}) or a camera frame "
            "that is not the optical one (z out of the lens)"
        )
    return found


def _eye_to_hand(
    calibration: HandEyeCalibration,
    t_base_cam_mm: NDArray[np.float64],
    axis: NDArray[np.float64],
    workspace: WorkspaceBox | None,
) -> dict[str, str]:
    names = calibration.settings
    found: dict[str, str] = {}
    distance_mm = float(np.linalg.norm(t_base_cam_mm))
    if distance_mm < MIN_CAMERA_FROM_BASE_MM:
        found["camera-away-from-base"] = (
            f"the camera is {distance_mm:.0f} mm from the robot base origin, inside the robot's "
            "base: this looks like an eye-in-hand file (T_flange_cam); for a camera on the arm "
            f"set {names.assignment(names.mode, HandEyeMode.EYE_IN_HAND.value)}"
        )
    floor_mm, floor_name = (
        (0.0, "the robot base plane")
        if workspace is None
        else (float(workspace.min_mm[2]), "the workspace floor")
    )
    below_mm = floor_mm - float(t_base_cam_mm[2])
    if below_mm > 0.0:
        found["camera-above-floor"] = (
            f"the camera is {below_mm:.0f} mm below {floor_name} (z = {floor_mm:.0f} mm): the "
            f"calibration looks inverted ({_invert_hint(calibration)}) or is an eye-in-hand "
            "file"
        )
    if workspace is not None:
        margin = WORKSPACE_VIEW_MARGIN_MM
        low = np.array(workspace.min_mm, dtype=np.float64) - margin
        high = np.array(workspace.max_mm, dtype=np.float64) + margin
        if not _ray_meets_box(t_base_cam_mm, axis, low, high):
            found["camera-looks-at-workspace"] = (
                f"the camera's optical axis misses the workspace box (grown by {margin:.0f} mm): "
                f"the calibration looks inverted ({_invert_hint(calibration)}), or the box or "
                "the file is wrong"
            )
    return found


def _measured_position(
    calibration: HandEyeCalibration, t_cal_mm: NDArray[np.float64], measured: MeasuredCamera
) -> dict[str, str]:
    names = calibration.settings
    position_mm = np.array(measured.position_mm, dtype=np.float64)
    off_mm = float(np.linalg.norm(t_cal_mm - position_mm))
    if off_mm <= measured.tolerance_mm:
        return {}
    frame = "flange" if calibration.mode is HandEyeMode.EYE_IN_HAND else "robot base"
    found = (
        f"the calibration puts the camera at {_mm(t_cal_mm)} mm in the {frame} frame, "
        f"{off_mm:.0f} mm from its measured position {_mm(position_mm)} mm "
        f"({names.camera_position}, tolerance {measured.tolerance_mm:g} mm)"
    )
    t_inverse_mm = invert(calibration.T_cal)[:3, 3] * 1000.0
    inverse_off_mm = float(np.linalg.norm(t_inverse_mm - position_mm))
    if inverse_off_mm <= measured.tolerance_mm:
        explanation = (
            f"; the inverse file puts it {inverse_off_mm:.0f} mm from there: the calibration "
            f"looks inverted ({_invert_hint(calibration)})"
        )
    else:
        explanation = (
            f": the file, its mode ({names.mode}) or the measured position is wrong (the "
            f"inverse file puts the camera at {_mm(t_inverse_mm)} mm, no nearer)"
        )
    return {"camera-at-measured-position": found + explanation}


def _inverse_alike(
    calibration: HandEyeCalibration, t_base_cam_mm: NDArray[np.float64], workspace: WorkspaceBox
) -> dict[str, str]:
    """``camera-position-measured``: whether the inverse of an eye-to-hand file that passed the
    eye-to-hand checks passes them as well, with its camera elsewhere."""
    inverse = replace(
        calibration, T_cal=invert(calibration.T_cal), inverted=not calibration.inverted
    )
    t_inverse_mm = inverse.T_cal[:3, 3] * 1000.0
    if _eye_to_hand(inverse, t_inverse_mm, inverse.T_cal[:3, 2], workspace):
        return {}
    # Equal camera positions make the file its own inverse (p = -R^T p makes R a half turn,
    # which is symmetric, so T == inv(T)): the positions' distance is the measure.
    apart_mm = float(np.linalg.norm(t_base_cam_mm - t_inverse_mm))
    if apart_mm <= CAMERA_POSITION_TOLERANCE_MM:
        return {}
    names = calibration.settings
    return {
        "camera-position-measured": (
            f"the file cannot be told from its inverse: it puts the camera at "
            f"{_mm(t_base_cam_mm)} mm, its inverse ({_invert_hint(calibration)}) at "
            f"{_mm(t_inverse_mm)} mm in the robot base frame, {apart_mm:.0f} mm apart, and both "
            f"look at the workspace; measure where the camera is and set {names.camera_position} "
            "(robot base frame, mm)"
        )
    }


def _object(
    calibration: HandEyeCalibration, T_base_flange: Transform | None, T_cam_obj: Transform
) -> dict[str, str]:
    names = calibration.settings
    found: dict[str, str] = {}
    from_camera_mm = float(np.linalg.norm(T_cam_obj[:3, 3])) * 1000.0
    low_mm, high_mm = CAMERA_RANGE_MM
    if not low_mm <= from_camera_mm <= high_mm:
        found["object-in-camera-range"] = (
            f"the object is {from_camera_mm:.0f} mm from the camera, outside the "
            f"{low_mm:.0f} to {high_mm:.0f} mm 3D cameras for picking measure: a point in cm or m "
            "given as mm, or a wrong detection"
        )
    if calibration.mode is HandEyeMode.EYE_IN_HAND and T_base_flange is None:
        return found
    T_base_obj = compose(calibration.T_base_cam(T_base_flange), T_cam_obj)
    from_base_mm = float(np.linalg.norm(T_base_obj[:3, 3])) * 1000.0
    if from_base_mm > MAX_REACH_MM:
        found["object-within-reach"] = (
            f"the object is {from_base_mm:.0f} mm from the robot base, beyond any UR arm's reach "
            f"(1750 mm): the calibration may be inverted ({_invert_hint(calibration)}), in the "
            f"wrong mode ({names.mode}) or the robot pose wrong"
        )
    return found


def _invert_hint(calibration: HandEyeCalibration) -> str:
    """What to change about inversion, in the user's own setting."""
    names = calibration.settings
    if names.on_command_line:
        return f"drop {names.invert}" if calibration.inverted else f"add {names.invert}"
    return names.assignment(names.invert, "false" if calibration.inverted else "true")


def _mm(values: NDArray[np.float64]) -> str:
    """A position in mm, rounded to the mm: ``[512, -39, 1245]``."""
    return "[" + ", ".join(f"{float(v):.0f}" for v in values) + "]"


def _ray_meets_box(
    origin: NDArray[np.float64],
    direction: NDArray[np.float64],
    low: NDArray[np.float64],
    high: NDArray[np.float64],
) -> bool:
    """Whether ``origin + s * direction`` for some s >= 0 lies in the box [low, high]."""
    s_in, s_out = 0.0, math.inf
    for o, d, lo, hi in zip(origin, direction, low, high, strict=True):
        if abs(d) < 1e-12:
            if not lo <= o <= hi:
                return False
            continue
        s1, s2 = (lo - o) / d, (hi - o) / d
        s_in, s_out = max(s_in, min(s1, s2)), min(s_out, max(s1, s2))
    return bool(s_in <= s_out)
