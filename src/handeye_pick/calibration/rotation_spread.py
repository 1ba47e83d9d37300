"""Is there enough rotation in a set of robot poses to solve a hand-eye calibration?

Hand-eye calibration recovers the camera's rotation from the rotation axes of the relative
motions between captures, and its translation from how those rotations move the camera. Two
things make it fail (Tsai and Lenz 1989; OpenCV's calibrateHandEye notes; Zivid's guidance):

- every relative rotation about nearly the same axis: the rotation about that axis, and the
  translation along it, are not determined;
- only small rotations: the translation is found by dividing by the rotation, so noise is
  amplified by about 1 / sin(angle).

``motion_spread`` measures both over every pair of captures, from the robot side of the chain
(``A_N`` of ``solver``: ``T_base_flange`` eye-in-hand, its inverse eye-to-hand), whose
relative rotations ``R_i^T R_j`` have their axes in the frame the hand-eye equation uses.
``check_motion`` refuses degenerate data and warns about weak data.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from handeye_pick.errors import CalibrationError

MIN_ROTATION_DEG = 10.0
"""Refuse when no two captures differ by this much rotation (noise amplified ~6x at 10 deg)."""
MIN_AXIS_SPREAD_DEG = 10.0
"""Refuse when every relative rotation's axis lies within this angle of one line."""
GOOD_ROTATION_DEG = 30.0
"""Warn below this: OpenCV's and Zivid's guidance is 30 degrees or more between poses."""
GOOD_AXIS_SPREAD_DEG = 30.0
"""Warn when every axis lies within this angle of one line: well-spread axes are the guidance."""


@dataclass(frozen=True)
class MotionSpread:
    """How much the robot rotated between captures (degrees)."""

    largest_rotation_deg: float  # the largest relative rotation between two captures
    largest_rotation_between: tuple[int, int]  # the pair numbers of those two captures
    # Largest angle between the axis of a relative rotation of MIN_ROTATION_DEG or more and the
    # line that fits all such axes best; 0 when fewer than two rotations are that large.
    axis_spread_deg: float


def motion_spread(R_robot: NDArray[np.float64], numbers: Sequence[int]) -> MotionSpread:
    """Measure the relative rotations among ``R_robot`` (N x 3 x 3, one per pair ``numbers``)."""
    count = len(numbers)
    if R_robot.shape != (count, 3, 3) or count < 2:
        raise ValueError(f"need N >= 2 rotations of shape (N, 3, 3), got {R_robot.shape}")
    first, second = np.triu_indices(count, k=1)
    relative = np.einsum("nji,njk->nik", R_robot[first], R_robot[second])  # R_i^T R_j
    from scipy.spatial.transform import Rotation  # here: the CLI must start without scipy

    rotvecs = Rotation.from_matrix(relative).as_rotvec()
    angles = np.linalg.norm(rotvecs, axis=1)
    best = int(np.argmax(angles))
    large = angles >= math.radians(MIN_ROTATION_DEG)
    return MotionSpread(
        largest_rotation_deg=math.degrees(float(angles[best])),
        largest_rotation_between=(numbers[first[best]], numbers[second[best]]),
        axis_spread_deg=_axis_spread_deg(rotvecs[large] / angles[large, None]),
    )


def _axis_spread_deg(axes: NDArray[np.float64]) -> float:
    """Largest angle (0-90 deg) between a unit axis and the line that fits all of them best."""
    if len(axes) < 2:
        return 0.0
    # The best line through the origin is the principal eigenvector of the scatter matrix; an
    # axis and its negative are the same line, which the outer products ignore.
    _, vectors = np.linalg.eigh(axes.T @ axes)
    cosines = np.clip(np.abs(axes @ vectors[:, -1]), 0.0, 1.0)
    return math.degrees(float(np.arccos(np.min(cosines))))


def check_motion(spread: MotionSpread) -> list[str]:
    """Raise ``CalibrationError`` for degenerate motion; return warnings for weak motion."""
    first, second = spread.largest_rotation_between
    if spread.largest_rotation_deg < MIN_ROTATION_DEG:
        raise CalibrationError(
            f"rotations too small to separate the camera's rotation from its translation: the "
            f"largest, between pairs {first} and {second}, is {spread.largest_rotation_deg:.1f} "
            f"deg (at least {MIN_ROTATION_DEG:.0f} deg needed, {GOOD_ROTATION_DEG:.0f} or more "
            "recommended); tilt the tool between poses"
        )
    if spread.axis_spread_deg < MIN_AXIS_SPREAD_DEG:
        raise CalibrationError(
            "all rotations are about nearly parallel axes: every relative rotation of "
            f"{MIN_ROTATION_DEG:.0f} deg or more has its axis within "
            f"{spread.axis_spread_deg:.1f} deg of one line (at least {MIN_AXIS_SPREAD_DEG:.0f} deg "
            "needed); rotate about different axes, not only the last wrist joint or the base"
        )
    warnings = []
    if spread.largest_rotation_deg < GOOD_ROTATION_DEG:
        warnings.append(
            f"weak data: the largest rotation between two poses is "
            f"{spread.largest_rotation_deg:.1f} deg; {GOOD_ROTATION_DEG:.0f} deg or more gives "
            "a better translation"
        )
    if spread.axis_spread_deg < GOOD_AXIS_SPREAD_DEG:
        warnings.append(
            f"weak data: the rotation axes lie within {spread.axis_spread_deg:.1f} deg of one "
            f"line; axes spread by {GOOD_AXIS_SPREAD_DEG:.0f} deg or more give a better result"
        )
    return warnings
