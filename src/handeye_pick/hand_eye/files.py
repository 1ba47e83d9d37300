"""Hand-eye results and robot pose files -> validated 4x4 transforms in metres.

Three file formats are read, all holding one 4x4 rigid transform:

1. Zivid's current format (SDK 2.8 and later)::

       __version__: {serializer: 1, data: 1}
       FloatMatrix: {Data: [[r, r, r, x], [r, r, r, y], [r, r, r, z], [0, 0, 0, 1]]}

2. Legacy OpenCV FileStorage YAML (first line ``%YAML:1.0``) with one node, e.g. ``PoseState``,
   tagged ``!!opencv-matrix`` (``rows: 4``, ``cols: 4``, ``dt: d`` or ``f``, 16 numbers
   row-major). Read with a SafeLoader subclass, never with OpenCV or ``yaml.full_load``.
3. Plain YAML or JSON: a 4x4 list, or a mapping ``{matrix: [[...]x4], units: mm|m}``.

Units are declared by the caller (millimetres by default, Zivid's unit) and never guessed; a
plain file's own ``units`` key must agree with the declared one. A magnitude check catches the
mm/m mix-up. Direction is explicit: an eye-in-hand file holds ``T_flange_cam`` (camera pose in
the flange frame), an eye-to-hand file holds ``T_base_cam`` (camera pose in the robot base
frame); ``invert=True`` is for files written the other way round and nothing is inverted by
guess. Everything returned is in metres.
"""

from __future__ import annotations

import functools
import hashlib
import math
import re
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import ArrayLike

from handeye_pick.errors import CalibrationError
from handeye_pick.geometry import (
    LengthUnit,
    Transform,
    checked_ur_pose,
    compose,
    metres_per,
    scale_translation,
    validate_transform,
)
from handeye_pick.geometry import invert as invert_transform
from handeye_pick.inputfiles import BoundedLoader, load_json, read_input_bytes, shown, yaml_problem


class HandEyeMode(str, Enum):
    """Where the camera is mounted, which fixes what the hand-eye file holds."""

    EYE_IN_HAND = "eye-in-hand"  # camera on the flange; the file holds T_flange_cam
    EYE_TO_HAND = "eye-to-hand"  # camera fixed in the cell; the file holds T_base_cam


@dataclass(frozen=True)
class SettingNames:
    """What the user sets each hand-eye choice with where they are, so a hint names a setting
    that exists there: a command-line flag (``--invert``) or a cell config key
    (``hand_eye.invert``)."""

    mode: str
    units: str
    invert: str
    acknowledge: str  # acknowledges one named plausibility check (see plausibility.py)
    camera_position: str  # the camera's rough measured position, mm (see plausibility.py)

    @property
    def on_command_line(self) -> bool:
        return self.mode.startswith("--")

    def assignment(self, setting: str, value: str) -> str:
        """``setting`` (one of the names above) given ``value``, written as the user writes it."""
        return f"{setting} {value}" if self.on_command_line else f"{setting}: {value}"


COMMAND_LINE = SettingNames(
    mode="--mode",
    units="--calibration-units",
    invert="--invert",
    acknowledge="--acknowledge",
    camera_position="--camera-position-mm",
)
CELL_CONFIG = SettingNames(
    mode="hand_eye.mode",
    units="hand_eye.units",
    invert="hand_eye.invert",
    acknowledge="hand_eye.acknowledge",
    camera_position="hand_eye.camera_position_mm",
)


@dataclass(frozen=True)
class _DistanceRange:
    """Plausible distance (m) between the two frames of a transform, for the unit check."""

    low_m: float
    high_m: float
    what: str

    def ur_pose(self, pose_m_rad: ArrayLike, source: str) -> Transform:
        """A UR pose vector (m, rad) from outside whose translation lies in this range, read with
        ``geometry.checked_ur_pose`` (``TransformError`` naming ``source``)."""
        return checked_ur_pose(
            pose_m_rad, source, min_m=self.low_m, max_m=self.high_m, distance=self.what
        )


# A camera bolted to the flange sits a few cm to a few dozen cm from it: beyond 2 m or within
# 1 mm the file is in the other unit.
EYE_IN_HAND_RANGE = _DistanceRange(0.001, 2.0, "camera distance from the flange")
# A fixed camera looks at the robot's work space from outside the robot base (whose casing is
# more than 5 cm in radius) and from within a cell (10 m is beyond any UR reach plus camera range).
EYE_TO_HAND_RANGE = _DistanceRange(0.05, 10.0, "camera distance from the robot base")
# The flange of any UR arm is outside the base casing (> 1 cm from the base origin) and within
# reach (UR20: 1.75 m); 3 m leaves room for a larger arm and still catches mm read as m.
ROBOT_POSE_RANGE = _DistanceRange(0.01, 3.0, "flange distance from the robot base")
# A calibration board or marker is detected a few cm to a few metres from a 3D camera; 10 m is
# beyond any industrial 3D camera's range and still catches mm read as m (and m read as mm).
OBJECT_POSE_RANGE = _DistanceRange(0.02, 10.0, "calibration object distance from the camera")

_RANGES = {HandEyeMode.EYE_IN_HAND: EYE_IN_HAND_RANGE, HandEyeMode.EYE_TO_HAND: EYE_TO_HAND_RANGE}

# No entry of a camera or robot transform comes near this, even in mm (1 km); a larger one is a
# broken or hostile file, refused before any arithmetic on it can overflow.
MAX_ENTRY = 1e6


@dataclass(frozen=True, eq=False)
class HandEyeCalibration:
    """A validated hand-eye result.

    ``T_cal`` is in metres and read-only: ``T_flange_cam`` for eye-in-hand, ``T_base_cam`` for
    eye-to-hand, already inverted if ``inverted`` is true. ``units`` is the unit the file was
    declared in; ``sha256`` identifies the file's bytes for the audit trail; ``settings`` names
    how the user chose mode, units and inversion, for hints in later messages.
    """

    mode: HandEyeMode
    T_cal: Transform
    path: Path
    sha256: str
    units: LengthUnit
    inverted: bool
    settings: SettingNames = COMMAND_LINE

    def T_base_cam(self, T_base_flange: Transform | None) -> Transform:
        """Camera pose in the robot base frame (metres).

        Eye-in-hand: ``T_base_flange @ T_flange_cam``, where ``T_base_flange`` (metres) is the
        flange pose at capture time and is required. Eye-to-hand: ``T_cal``; ``T_base_flange``
        is ignored.
        """
        if self.mode is HandEyeMode.EYE_TO_HAND:
            T_base_cam: Transform = self.T_cal.copy()
            return T_base_cam
        if T_base_flange is None:
            raise CalibrationError(
                f"eye-in-hand calibration {self.path}: the camera-to-base chain needs the flange "
                "pose at capture time (T_base_flange), none was given"
            )
        return compose(T_base_flange, self.T_cal)


def file_sha256(path: Path) -> str:
    """Hex SHA-256 of the file's bytes."""
    try:
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except OSError as exc:
        raise CalibrationError(f"cannot read {path}: {exc.strerror}") from None


def load_hand_eye(
    path: Path,
    mode: HandEyeMode,
    units: LengthUnit = "mm",
    invert: bool = False,
    *,
    settings: SettingNames = COMMAND_LINE,
) -> HandEyeCalibration:
    """Read, validate and unit-check a hand-eye result (Zivid, OpenCV or plain file).

    ``units`` is the file's translation unit; ``invert=True`` means the file holds the inverse
    of what ``mode`` expects (``T_cam_flange`` or ``T_cam_base``). ``settings`` says where these
    were chosen (``CELL_CONFIG`` for a cell config), so hints name ``hand_eye.units`` there and
    ``--calibration-units`` on the command line. Raises ``CalibrationError`` or
    ``TransformError`` (both exit status 2) naming the file and the defect.
    """
    try:
        mode = HandEyeMode(mode)
    except ValueError:
        raise CalibrationError(
            f"unknown hand-eye mode {mode!r}: expected 'eye-in-hand' or 'eye-to-hand'"
        ) from None
    data = _read_bytes(Path(path))
    declare = functools.partial(settings.assignment, settings.units)
    T_file = _parse_transform(data, Path(path), units, declare)
    # |t| of T and of its inverse are equal, so the check holds whichever way the file is written.
    _check_distance(T_file, units, _RANGES[mode], path, declare)
    T_cal = invert_transform(T_file) if invert else T_file
    T_cal.flags.writeable = False
    return HandEyeCalibration(
        mode=mode,
        T_cal=T_cal,
        path=Path(path),
        sha256=hashlib.sha256(data).hexdigest(),
        units=units,
        inverted=invert,
        settings=settings,
    )


def read_robot_pose_file(
    path: Path, units: LengthUnit = "mm", flag: str = "--robot-pose-units"
) -> Transform:
    """Read ``T_base_flange`` (flange pose in the robot base frame, e.g. Zivid's
    RobotTransform.yaml, mm by default) and return it in metres, unit-checked.

    ``flag`` names the option that declares ``units``, for the unit hint in error messages."""
    T_base_flange = _parse_transform(_read_bytes(Path(path)), Path(path), units, _flag(flag))
    _check_distance(T_base_flange, units, ROBOT_POSE_RANGE, path, _flag(flag))
    return T_base_flange


def read_object_pose_file(path: Path, units: LengthUnit, flag: str) -> Transform:
    """Read ``T_cam_obj`` (a calibration object's pose in the camera frame, as a detector
    measured it) and return it in metres, unit-checked; ``flag`` as for read_robot_pose_file."""
    T_cam_obj = _parse_transform(_read_bytes(Path(path)), Path(path), units, _flag(flag))
    _check_distance(T_cam_obj, units, OBJECT_POSE_RANGE, path, _flag(flag))
    return T_cam_obj


def robot_pose_from_ur_vector(pose_m_rad: ArrayLike, source: str) -> Transform:
    """``T_base_flange`` (metres) from a UR pose vector ``[x, y, z, rx, ry, rz]`` (m, rad) given
    from outside (``source`` names where, e.g. ``--robot-pose-ur``), with the range check of a
    pose file: the flange 1 cm to 3 m from the base, a rotation vector at most 2*pi long."""
    return ROBOT_POSE_RANGE.ur_pose(pose_m_rad, source)


def read_transform_file(path: Path, units: LengthUnit) -> Transform:
    """Read any supported 4x4 file whose translation is in ``units``; return it in metres.

    Validates the rigid transform (see ``geometry.validate_transform``); no magnitude check.
    """
    return _parse_transform(_read_bytes(Path(path)), Path(path), units, _flag("units"))


def write_zivid_transform(path: Path, T_m: Transform, units: LengthUnit = "mm") -> None:
    """Write ``T_m`` (metres) in Zivid's current YAML format with its translation in ``units``."""
    T = scale_translation(validate_transform(T_m, "transform to write"), 1.0 / metres_per(units))
    rows = ",\n".join("    [" + ", ".join(repr(float(v)) for v in row) + "]" for row in T)
    text = f"__version__:\n  serializer: 1\n  data: 1\nFloatMatrix:\n  Data: [\n{rows}]\n"
    try:
        Path(path).write_text(text, encoding="utf-8")
    except OSError as exc:
        raise CalibrationError(f"cannot write {path}: {exc.strerror}") from None


# --- reading --------------------------------------------------------------------------------------

# OpenCV FileStorage starts with "%YAML:1.0"; some writers use the standard "%YAML 1.0".
_OPENCV_DIRECTIVE = re.compile(r"%YAML[: ]1\.\d+\s*$")


@dataclass(frozen=True)
class _OpenCVMatrix:
    """The mapping under an ``!!opencv-matrix`` tag, kept as read."""

    fields: dict[Any, Any]


class _OpenCVLoader(BoundedLoader):
    """The bounded safe loader that also builds ``!!opencv-matrix`` nodes (nothing else)."""


def _construct_opencv_matrix(loader: yaml.SafeLoader, node: yaml.Node) -> _OpenCVMatrix:
    if not isinstance(node, yaml.MappingNode):
        raise yaml.constructor.ConstructorError(
            None, None, "!!opencv-matrix must be a mapping (rows, cols, dt, data)", node.start_mark
        )
    return _OpenCVMatrix(loader.construct_mapping(node, deep=True))


_OpenCVLoader.add_constructor("tag:yaml.org,2002:opencv-matrix", _construct_opencv_matrix)


def _read_bytes(path: Path) -> bytes:
    return read_input_bytes(path, "transform file", CalibrationError)


def _flag(flag: str) -> Callable[[str], str]:
    """How a command-line option (``flag``) declares a unit, for the unit hints."""
    return lambda unit: f"{flag} {unit}"


def _parse_transform(
    data: bytes, path: Path, units: LengthUnit, declare: Callable[[str], str]
) -> Transform:
    """The validated transform in ``data`` (the bytes of ``path``), translation in metres.

    ``declare(unit)`` is how the user declares a unit where they are, for the error messages.
    """
    scale = metres_per(units)
    matrix, file_units = _parse_matrix(data, path)
    if file_units is not None and file_units != units:
        raise CalibrationError(
            f"{path}: the file says units: {file_units} but the translation was declared as "
            f"{units}; declare {file_units} ({declare(file_units)}) or fix the file"
        )
    return scale_translation(validate_transform(matrix, str(path)), scale)


def _parse_matrix(data: bytes, path: Path) -> tuple[list[Any], str | None]:
    """The 4x4 as written in the file (not yet validated) and the file's own unit, if any."""
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise CalibrationError(f"transform file {path} is not UTF-8 text") from None
    first_line, _, rest = text.partition("\n")
    opencv = bool(_OPENCV_DIRECTIVE.match(first_line.strip()))
    try:
        if opencv:
            # PyYAML refuses OpenCV's directive; the line carries no data. Blank it, so the line
            # numbers in YAML errors stay right.
            doc = yaml.load("\n" + rest, Loader=_OpenCVLoader)  # a SafeLoader subclass
        elif path.suffix.lower() == ".json":
            doc = load_json(text)
        else:
            doc = yaml.load(text, Loader=BoundedLoader)
    except yaml.YAMLError as exc:
        raise CalibrationError(
            f"transform file {path} is not valid YAML/JSON: {yaml_problem(exc)}"
        ) from None
    except ValueError as exc:  # load_json's one-line problems
        raise CalibrationError(f"transform file {path} is not valid YAML/JSON: {exc}") from None
    if opencv:
        return _opencv_matrix(doc, path), None
    return _plain_or_zivid_matrix(doc, path)


def _opencv_matrix(doc: Any, path: Path) -> list[Any]:
    if not isinstance(doc, dict):
        raise CalibrationError(f"{path}: OpenCV file must hold a mapping of named nodes")
    nodes = {key: value for key, value in doc.items() if isinstance(value, _OpenCVMatrix)}
    if len(nodes) != 1:
        raise CalibrationError(
            f"{path}: expected exactly one !!opencv-matrix node (Zivid wrote 'PoseState'), "
            f"found {len(nodes)}: {shown(sorted(map(str, nodes)))}"
        )
    name, node = next(iter(nodes.items()))
    fields = node.fields
    where = f"{path}: node {name}"
    if fields.get("rows") != 4 or fields.get("cols") != 4:
        raise CalibrationError(
            f"{where}: expected rows: 4 and cols: 4, found rows: {shown(fields.get('rows'))}, "
            f"cols: {shown(fields.get('cols'))}"
        )
    if fields.get("dt") not in ("d", "f"):
        raise CalibrationError(f"{where}: expected dt: d or f, found {shown(fields.get('dt'))}")
    data = fields.get("data")
    if not isinstance(data, list) or len(data) != 16:
        count = len(data) if isinstance(data, list) else type(data).__name__
        raise CalibrationError(f"{where}: expected data with 16 numbers, found {count}")
    numbers = [_number(v, f"{where} data[{k}]") for k, v in enumerate(data)]
    return [numbers[4 * r : 4 * r + 4] for r in range(4)]


def _plain_or_zivid_matrix(doc: Any, path: Path) -> tuple[list[Any], str | None]:
    if isinstance(doc, list):
        return _matrix_rows(doc, f"{path}"), None
    if not isinstance(doc, dict):
        raise CalibrationError(
            f"{path}: expected a Zivid transform (__version__ + FloatMatrix), an OpenCV file "
            f"(%YAML:1.0 + !!opencv-matrix) or a plain 4x4 list / {{matrix, units}} mapping, "
            f"found {type(doc).__name__}"
        )
    if "FloatMatrix" in doc or "__version__" in doc:
        return _zivid_matrix(doc, path), None
    unknown = set(doc) - {"matrix", "units"}
    if unknown or "matrix" not in doc:
        raise CalibrationError(
            f"{path}: a plain transform mapping has keys 'matrix' and optionally 'units', "
            f"found {shown(sorted(map(str, doc)))}"
        )
    file_units = doc.get("units")
    if file_units is not None and file_units not in ("mm", "m"):
        raise CalibrationError(f"{path}: units must be 'mm' or 'm', found {shown(file_units)}")
    return _matrix_rows(doc["matrix"], f"{path}: matrix"), file_units


def _zivid_matrix(doc: dict[Any, Any], path: Path) -> list[Any]:
    if set(doc) != {"__version__", "FloatMatrix"}:
        raise CalibrationError(
            f"{path}: a Zivid transform has exactly the keys __version__ and FloatMatrix, "
            f"found {shown(sorted(map(str, doc)))}"
        )
    version = doc["__version__"]
    if version != {"serializer": 1, "data": 1}:
        raise CalibrationError(
            f"{path}: unsupported Zivid __version__ {shown(version)}, expected serializer 1, data 1"
        )
    body = doc["FloatMatrix"]
    if not isinstance(body, dict) or set(body) != {"Data"}:
        raise CalibrationError(f"{path}: FloatMatrix must be a mapping with the one key Data")
    return _matrix_rows(body["Data"], f"{path}: FloatMatrix.Data")


def _matrix_rows(value: Any, where: str) -> list[Any]:
    if not isinstance(value, list) or len(value) != 4:
        raise CalibrationError(f"{where}: expected a list of 4 rows, found {shown(value)}")
    rows = []
    for i, row in enumerate(value):
        if not isinstance(row, list) or len(row) != 4:
            raise CalibrationError(f"{where}: row {i} must have 4 numbers, found {shown(row)}")
        rows.append([_number(v, f"{where} row {i} column {j}") for j, v in enumerate(row)])
    return rows


def _number(value: Any, where: str) -> float:
    # PyYAML reads "1e-5" (no dot) as a string; accept numeric strings, refuse anything else.
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise CalibrationError(f"{where}: expected a number, found {shown(value)}")
    try:
        number = float(value)
    except ValueError:
        raise CalibrationError(f"{where}: expected a number, found {shown(value)}") from None
    # Refused here, before any arithmetic can overflow; NaN and inf are left to
    # validate_transform, which names them.
    if math.isfinite(number) and abs(number) > MAX_ENTRY:
        raise CalibrationError(
            f"{where}: {number:g} is not a transform entry (rotation entries lie within +-1, "
            f"translations within a cell; at most {MAX_ENTRY:g} in mm)"
        )
    return number


# --- checks ---------------------------------------------------------------------------------------


def _check_distance(
    T_m: Transform,
    units: LengthUnit,
    limits: _DistanceRange,
    path: Path,
    declare: Callable[[str], str],
) -> None:
    """Refuse a translation whose length (m) is outside ``limits``, naming the unit to declare."""
    distance_m = float(np.linalg.norm(T_m[:3, 3]))
    if limits.low_m <= distance_m <= limits.high_m:
        return
    other: LengthUnit = "mm" if units == "m" else "m"
    distance_if_other_m = distance_m / metres_per(units) * metres_per(other)
    hint = (
        f"the file is probably in {other}: declare {other} ({declare(other)})"
        if limits.low_m <= distance_if_other_m <= limits.high_m
        else "no unit makes it plausible: check the file"
    )
    raise CalibrationError(
        f"{path}: {limits.what} is {distance_m:.6g} m with the translation read as {units}, "
        f"expected {limits.low_m:g} to {limits.high_m:g} m; {hint}"
    )
