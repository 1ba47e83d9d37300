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

import hashlib
import json
import re
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from handeye_pick.errors import CalibrationError
from handeye_pick.geometry import (
    LengthUnit,
    Transform,
    compose,
    metres_per,
    scale_translation,
    validate_transform,
)
from handeye_pick.geometry import invert as invert_transform


class HandEyeMode(str, Enum):
    """Where the camera is mounted, which fixes what the hand-eye file holds."""

    EYE_IN_HAND = "eye-in-hand"  # camera on the flange; the file holds T_flange_cam
    EYE_TO_HAND = "eye-to-hand"  # camera fixed in the cell; the file holds T_base_cam


@dataclass(frozen=True)
class _DistanceRange:
    """Plausible distance (m) between the two frames of a transform, for the unit check."""

    low_m: float
    high_m: float
    what: str


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


@dataclass(frozen=True, eq=False)
class HandEyeCalibration:
    """A validated hand-eye result.

    ``T_cal`` is in metres and read-only: ``T_flange_cam`` for eye-in-hand, ``T_base_cam`` for
    eye-to-hand, already inverted if ``inverted`` is true. ``units`` is the unit the file was
    declared in; ``sha256`` identifies the file's bytes for the audit trail.
    """

    mode: HandEyeMode
    T_cal: Transform
    path: Path
    sha256: str
    units: LengthUnit
    inverted: bool

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
    path: Path, mode: HandEyeMode, units: LengthUnit = "mm", invert: bool = False
) -> HandEyeCalibration:
    """Read, validate and unit-check a hand-eye result (Zivid, OpenCV or plain file).

    ``units`` is the file's translation unit; ``invert=True`` means the file holds the inverse
    of what ``mode`` expects (``T_cam_flange`` or ``T_cam_base``). Raises ``CalibrationError``
    or ``TransformError`` (both exit status 2) naming the file and the defect.
    """
    try:
        mode = HandEyeMode(mode)
    except ValueError:
        raise CalibrationError(
            f"unknown hand-eye mode {mode!r}: expected 'eye-in-hand' or 'eye-to-hand'"
        ) from None
    data = _read_bytes(Path(path))
    T_file = _parse_transform(data, Path(path), units, "--calibration-units")
    # |t| of T and of its inverse are equal, so the check holds whichever way the file is written.
    _check_distance(T_file, units, _RANGES[mode], path, "--calibration-units")
    T_cal = invert_transform(T_file) if invert else T_file
    T_cal.flags.writeable = False
    return HandEyeCalibration(
        mode=mode,
        T_cal=T_cal,
        path=Path(path),
        sha256=hashlib.sha256(data).hexdigest(),
        units=units,
        inverted=invert,
    )


def read_robot_pose_file(
    path: Path, units: LengthUnit = "mm", flag: str = "--robot-pose-units"
) -> Transform:
    """Read ``T_base_flange`` (flange pose in the robot base frame, e.g. Zivid's
    RobotTransform.yaml, mm by default) and return it in metres, unit-checked.

    ``flag`` names the option that declares ``units``, for the unit hint in error messages."""
    T_base_flange = _parse_transform(_read_bytes(Path(path)), Path(path), units, flag)
    _check_distance(T_base_flange, units, ROBOT_POSE_RANGE, path, flag)
    return T_base_flange


def read_object_pose_file(path: Path, units: LengthUnit, flag: str) -> Transform:
    """Read ``T_cam_obj`` (a calibration object's pose in the camera frame, as a detector
    measured it) and return it in metres, unit-checked; ``flag`` as for read_robot_pose_file."""
    T_cam_obj = _parse_transform(_read_bytes(Path(path)), Path(path), units, flag)
    _check_distance(T_cam_obj, units, OBJECT_POSE_RANGE, path, flag)
    return T_cam_obj


def read_transform_file(path: Path, units: LengthUnit) -> Transform:
    """Read any supported 4x4 file whose translation is in ``units``; return it in metres.

    Validates the rigid transform (see ``geometry.validate_transform``); no magnitude check.
    """
    return _parse_transform(_read_bytes(Path(path)), Path(path), units, "units")


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


class _OpenCVLoader(yaml.SafeLoader):
    """SafeLoader that also builds ``!!opencv-matrix`` nodes (nothing else is added)."""


def _construct_opencv_matrix(loader: yaml.SafeLoader, node: yaml.Node) -> _OpenCVMatrix:
    if not isinstance(node, yaml.MappingNode):
        raise yaml.constructor.ConstructorError(
            None, None, "!!opencv-matrix must be a mapping (rows, cols, dt, data)", node.start_mark
        )
    return _OpenCVMatrix(loader.construct_mapping(node, deep=True))


_OpenCVLoader.add_constructor("tag:yaml.org,2002:opencv-matrix", _construct_opencv_matrix)


def _read_bytes(path: Path) -> bytes:
    try:
        return path.read_bytes()
    except OSError as exc:
        raise CalibrationError(f"cannot read transform file {path}: {exc.strerror}") from None


def _parse_transform(data: bytes, path: Path, units: LengthUnit, flag: str) -> Transform:
    """The validated transform in ``data`` (the bytes of ``path``), translation in metres.

    ``flag`` names the setting that declares ``units``, for the error messages.
    """
    scale = metres_per(units)
    matrix, file_units = _parse_matrix(data, path)
    if file_units is not None and file_units != units:
        raise CalibrationError(
            f"{path}: the file says units: {file_units} but the translation was declared as "
            f"{units}; declare {file_units} ({flag} {file_units}) or fix the file"
        )
    return scale_translation(validate_transform(matrix, str(path)), scale)


def _parse_matrix(data: bytes, path: Path) -> tuple[list[Any], str | None]:
    """The 4x4 as written in the file (not yet validated) and the file's own unit, if any."""
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise CalibrationError(f"transform file {path} is not UTF-8 text") from None
    first_line, _, rest = text.partition("\n")
    try:
        if _OPENCV_DIRECTIVE.match(first_line.strip()):
            # PyYAML refuses OpenCV's directive; the line carries no data. Blank it, so the line
            # numbers in YAML errors stay right.
            doc = yaml.load("\n" + rest, Loader=_OpenCVLoader)  # a SafeLoader subclass
            return _opencv_matrix(doc, path), None
        if path.suffix.lower() == ".json":
            return _plain_or_zivid_matrix(json.loads(text), path)
        return _plain_or_zivid_matrix(yaml.safe_load(text), path)
    except (yaml.YAMLError, json.JSONDecodeError) as exc:
        raise CalibrationError(
            f"transform file {path} is not valid YAML/JSON: {_parse_problem(exc)}"
        ) from None


def _parse_problem(exc: Exception) -> str:
    """One line: what the parser objected to and where."""
    if isinstance(exc, yaml.MarkedYAMLError) and exc.problem_mark is not None:
        mark = exc.problem_mark
        return f"{exc.problem} at line {mark.line + 1}, column {mark.column + 1}"
    return " ".join(str(exc).split())


def _opencv_matrix(doc: Any, path: Path) -> list[Any]:
    if not isinstance(doc, dict):
        raise CalibrationError(f"{path}: OpenCV file must hold a mapping of named nodes")
    nodes = {key: value for key, value in doc.items() if isinstance(value, _OpenCVMatrix)}
    if len(nodes) != 1:
        raise CalibrationError(
            f"{path}: expected exactly one !!opencv-matrix node (Zivid wrote 'PoseState'), "
            f"found {len(nodes)}: {sorted(map(str, nodes))}"
        )
    name, node = next(iter(nodes.items()))
    fields = node.fields
    where = f"{path}: node {name}"
    if fields.get("rows") != 4 or fields.get("cols") != 4:
        raise CalibrationError(
            f"{where}: expected rows: 4 and cols: 4, found rows: {fields.get('rows')}, "
            f"cols: {fields.get('cols')}"
        )
    if fields.get("dt") not in ("d", "f"):
        raise CalibrationError(f"{where}: expected dt: d or f, found {fields.get('dt')!r}")
    data = fields.get("data")
    if not isinstance(data, list) or len(data) != 16:
        count = len(data) if isinstance(data, list) else type(data).__name__
        raise CalibrationError(f"{where}: expected data with 16 numbers, found {count}")
    numbers = [_number(v, where) for v in data]
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
            f"found {sorted(map(str, doc))}"
        )
    file_units = doc.get("units")
    if file_units is not None and file_units not in ("mm", "m"):
        raise CalibrationError(f"{path}: units must be 'mm' or 'm', found {file_units!r}")
    return _matrix_rows(doc["matrix"], f"{path}: matrix"), file_units


def _zivid_matrix(doc: dict[Any, Any], path: Path) -> list[Any]:
    if set(doc) != {"__version__", "FloatMatrix"}:
        raise CalibrationError(
            f"{path}: a Zivid transform has exactly the keys __version__ and FloatMatrix, "
            f"found {sorted(map(str, doc))}"
        )
    version = doc["__version__"]
    if version != {"serializer": 1, "data": 1}:
        raise CalibrationError(
            f"{path}: unsupported Zivid __version__ {version!r}, expected serializer 1, data 1"
        )
    body = doc["FloatMatrix"]
    if not isinstance(body, dict) or set(body) != {"Data"}:
        raise CalibrationError(f"{path}: FloatMatrix must be a mapping with the one key Data")
    return _matrix_rows(body["Data"], f"{path}: FloatMatrix.Data")


def _matrix_rows(value: Any, where: str) -> list[Any]:
    if not isinstance(value, list) or len(value) != 4:
        raise CalibrationError(f"{where}: expected a list of 4 rows, found {value!r:.80}")
    rows = []
    for i, row in enumerate(value):
        if not isinstance(row, list) or len(row) != 4:
            raise CalibrationError(f"{where}: row {i} must have 4 numbers, found {row!r:.80}")
        rows.append([_number(v, f"{where} row {i}") for v in row])
    return rows


def _number(value: Any, where: str) -> float:
    # PyYAML reads "1e-5" (no dot) as a string; accept numeric strings, refuse anything else.
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise CalibrationError(f"{where}: expected a number, found {value!r}")
    try:
        return float(value)
    except ValueError:
        raise CalibrationError(f"{where}: expected a number, found {value!r}") from None


# --- checks ---------------------------------------------------------------------------------------


def _check_distance(
    T_m: Transform, units: LengthUnit, limits: _DistanceRange, path: Path, flag: str
) -> None:
    """Refuse a translation whose length (m) is outside ``limits``, naming the unit to declare."""
    distance_m = float(np.linalg.norm(T_m[:3, 3]))
    if limits.low_m <= distance_m <= limits.high_m:
        return
    other: LengthUnit = "mm" if units == "m" else "m"
    distance_if_other_m = distance_m / metres_per(units) * metres_per(other)
    hint = (
        f"the file is probably in {other}: declare {other} ({flag} {other})"
        if limits.low_m <= distance_if_other_m <= limits.high_m
        else "no unit makes it plausible: check the file"
    )
    raise CalibrationError(
        f"{path}: {limits.what} is {distance_m:.6g} m with the translation read as {units}, "
        f"expected {limits.low_m:g} to {limits.high_m:g} m; {hint}"
    )
