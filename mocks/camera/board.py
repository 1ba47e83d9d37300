"""The calibration object of a hand-eye calibration, and the noise of measuring its pose.

Frames and units: ``T_a_b`` float64 4x4, metres. The board's own frame has its origin at the
board's centre, x and y in the board's plane and z pointing into the board, away from its printed
face (the frame OpenCV's ``solvePnP`` gives for a chessboard), so a camera sees the board when it
looks along the board's +z.

Eye-in-hand calibration: the board lies still in the cell (``T_base_board``) and the camera moves
with the flange. Eye-to-hand: the board rides on the flange (``T_flange_board``) in front of a
fixed camera.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from mocks.camera.frames import Matrix, checked_transform


class BoardNotVisible(ValueError):
    """The camera cannot see the board at this pose (no measurement, as a detector would fail)."""


@dataclass(frozen=True)
class PoseNoise:
    """Gaussian noise of a measured ``T_cam_obj``, in the camera frame.

    Defaults: 0.1 mm across the optical axis, three times that along it (a 3D camera measures
    depth worse than position in the image), 0.02 degrees about each axis. All zero: exact poses.
    """

    translation_mm: float = 0.1  # standard deviation along camera x and y (mm)
    rotation_deg: float = 0.02  # standard deviation of each rotation-vector component (deg)
    axial_factor: float = 3.0  # standard deviation along camera z = axial_factor * translation_mm

    def __post_init__(self) -> None:
        for name in ("translation_mm", "rotation_deg", "axial_factor"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"PoseNoise.{name} must be finite and >= 0, got {value}")

    def apply(self, T_cam_obj: Matrix, rng: np.random.Generator) -> Matrix:
        """``T_cam_obj`` (m) moved by one draw of the noise: rotation first, then translation."""
        sigma_m = self.translation_mm / 1000.0
        offset_m = rng.normal(0.0, 1.0, 3) * [sigma_m, sigma_m, sigma_m * self.axial_factor]
        rotvec_rad = rng.normal(0.0, math.radians(self.rotation_deg), 3)
        noisy: Matrix = T_cam_obj.copy()
        noisy[:3, :3] = Rotation.from_rotvec(rotvec_rad).as_matrix() @ T_cam_obj[:3, :3]
        noisy[:3, 3] += offset_m
        return noisy


@dataclass(frozen=True, eq=False)
class CalibrationBoard:
    """A calibration board fixed to the cell (eye-in-hand) or to the flange (eye-to-hand).

    Make one with ``CalibrationBoard.in_cell(T_base_board)`` or
    ``CalibrationBoard.on_flange(T_flange_board)`` (metres).
    """

    parent: Literal["base", "flange"]  # the frame the board is fixed to
    T_parent_board: Matrix  # the board's pose in that frame (m)

    def __post_init__(self) -> None:
        if self.parent not in ("base", "flange"):
            raise ValueError(f"CalibrationBoard.parent must be base or flange, not {self.parent!r}")
        object.__setattr__(self, "T_parent_board",
                           checked_transform(self.T_parent_board, f"T_{self.parent}_board"))

    @classmethod
    def in_cell(cls, T_base_board: ArrayLike) -> CalibrationBoard:
        """A board lying still in the cell, for an eye-in-hand camera."""
        return cls("base", np.asarray(T_base_board, dtype=np.float64))

    @classmethod
    def on_flange(cls, T_flange_board: ArrayLike) -> CalibrationBoard:
        """A board carried by the robot, for an eye-to-hand camera."""
        return cls("flange", np.asarray(T_flange_board, dtype=np.float64))

    def in_base(self, T_base_flange: ArrayLike) -> Matrix:
        """``T_base_board`` (m) with the robot's flange at ``T_base_flange`` (m)."""
        if self.parent == "base":
            return self.T_parent_board
        T_base_flange = checked_transform(T_base_flange, "T_base_flange")
        T_base_board: Matrix = T_base_flange @ self.T_parent_board
        return T_base_board
