"""Ground-truth helpers for the simulated camera's tests, written apart from the camera's code."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

Matrix = NDArray[np.float64]


def looking_down(x_m: float, y_m: float, z_m: float, yaw_rad: float = 0.0) -> Matrix:
    """T_base_cam of a camera at (x, y, z) looking straight down (camera z = base -z), its image
    x axis turned yaw_rad from the base x axis."""
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    T = np.eye(4)
    T[:3, 0] = [c, s, 0.0]
    T[:3, 1] = [s, -c, 0.0]
    T[:3, 2] = [0.0, 0.0, -1.0]
    T[:3, 3] = [x_m, y_m, z_m]
    return T


def pose(x: float, y: float, z: float, rx: float, ry: float, rz: float) -> Matrix:
    """UR vector (m, rad) -> 4x4 with scipy."""
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec([rx, ry, rz]).as_matrix()
    T[:3, 3] = [x, y, z]
    return T


def to_base_m(T_base_cam: Matrix, cloud_mm: NDArray[np.float32]) -> Matrix:
    """An organized cloud (mm, camera frame) as base-frame points (m), shape (H, W, 3)."""
    points = cloud_mm.astype(np.float64) / 1000.0
    result: Matrix = points @ T_base_cam[:3, :3].T + T_base_cam[:3, 3]
    return result


def rotation_angle_deg(R1: Matrix, R2: Matrix) -> float:
    """Angle of the rotation between two rotation matrices (degrees)."""
    cos = (np.trace(R1.T @ R2) - 1.0) / 2.0
    return math.degrees(math.acos(max(-1.0, min(1.0, cos))))
