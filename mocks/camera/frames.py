"""Rigid transforms for the simulated camera: a checked 4x4 and its closed-form inverse.

``T_a_b`` is the pose of frame b in frame a (``p_a = T_a_b @ p_b``), float64 4x4, metres.
Never imports ``handeye_pick``: the simulator must not share pose maths with the code under test.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

Matrix = NDArray[np.float64]
"""A float64 array: a 4x4 transform, a point or a stack of vectors, as each signature says."""

_ROTATION_TOLERANCE = 1e-6


def checked_transform(T: ArrayLike, what: str) -> Matrix:
    """``T`` as a float64 4x4 copy after checking it is rigid; ValueError naming ``what``."""
    arr = np.array(T, dtype=np.float64)
    if arr.shape != (4, 4) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{what} must be a finite 4x4 transform, got {arr.tolist()}")
    R = arr[:3, :3]
    if (
        not np.array_equal(arr[3], [0.0, 0.0, 0.0, 1.0])
        or float(np.max(np.abs(R.T @ R - np.eye(3)))) > _ROTATION_TOLERANCE
        or np.linalg.det(R) < 0.0
    ):
        raise ValueError(f"{what} is not a rigid transform: {arr.tolist()}")
    return arr


def invert(T: Matrix) -> Matrix:
    """Closed-form inverse of a rigid transform: ``T_b_a`` from ``T_a_b``."""
    inverse = np.eye(4)
    inverse[:3, :3] = T[:3, :3].T
    inverse[:3, 3] = -T[:3, :3].T @ T[:3, 3]
    return inverse
