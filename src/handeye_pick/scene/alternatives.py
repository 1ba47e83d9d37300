"""Grasp alternatives of one detection, in the order they are tried (docs/scene.md): tiers of
increasing tilt (0 first, then ``TILT_STEP_DEG`` steps up to ``grasp.tilt_max_deg``), each
holding every rotation of the part about its symmetry axis. A tier is tried only when no
alternative of the one before passed; within a tier, the one that turns the wrist least wins.

A rotation turns the grasp about the object frame's symmetry axis through the object's origin
(the part looks the same, so the grasp holds it the same way). A tilt turns the grasp about its
TCP, so that the tool above it leans towards the centre of the bin the part lies in; a part in no
bin, or at the bin's centre, gets no tilt.

Frames and units: ``T_base_*`` float64 4x4 in metres; angles in the names (deg).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from handeye_pick.config.schema import BinConfig, SceneConfig
from handeye_pick.detection import Symmetry
from handeye_pick.geometry import Transform, compose, invert, make_transform, rotation_from_rotvec

TILT_STEP_DEG = 5.0
"""The tilt added from one tier to the next (the last tier tilts ``grasp.tilt_max_deg``)."""
MIN_OFF_CENTRE_M = 0.001  # a part closer than this to its bin's centre has no side to lean from
_AXES = {"x": 0, "y": 1, "z": 2}


@dataclass(frozen=True)
class Alternative:
    """One grasp of a detection: turned ``yaw_deg`` about the symmetry axis, then tilted
    ``tilt_deg`` towards the bin's centre; ``T_base_tcp`` is the grasp target (m)."""

    yaw_deg: float
    tilt_deg: float
    T_base_tcp: Transform

    def label(self) -> str:
        return f"yaw {self.yaw_deg:g} deg, tilt {self.tilt_deg:g} deg"


def yaw_angles_deg(symmetry: Symmetry | None, step_deg: float) -> list[float]:
    """The rotations a part's symmetry allows: every 360/order deg, or every ``step_deg`` for
    a part symmetric by any angle (order 0); only 0 without a symmetry."""
    if symmetry is None:
        return [0.0]
    step = 360.0 / symmetry.order if symmetry.order > 0 else step_deg
    return [k * step for k in range(math.ceil(360.0 / step - 1e-9))]


def tilt_angles_deg(tilt_max_deg: float) -> list[float]:
    """0, then ``TILT_STEP_DEG`` steps, ending exactly at ``tilt_max_deg``."""
    tilts = [0.0]
    while tilts[-1] + 1e-9 < tilt_max_deg:
        tilts.append(min(tilts[-1] + TILT_STEP_DEG, tilt_max_deg))
    return tilts


def bin_holding(scene: SceneConfig, p_base_m: NDArray[np.float64]) -> BinConfig | None:
    """The bin whose inside (its inner footprint, floor to wall top) holds the point, if any."""
    for bin_ in scene.bins:
        local = invert(bin_.T_base_bin) @ np.append(p_base_m, 1.0)
        x, y, z = (v / 1000.0 for v in bin_.inner_mm)
        if abs(local[0]) <= x / 2.0 and abs(local[1]) <= y / 2.0 and -0.01 <= local[2] <= z:
            return bin_
    return None


def _turn(axis: NDArray[np.float64], angle_rad: float) -> Transform:
    """A pure rotation by ``angle_rad`` about the unit ``axis``."""
    return make_transform(rotation_from_rotvec(axis * angle_rad), np.zeros(3))


def _tilted(T_base_tcp: Transform, towards_m: NDArray[np.float64], tilt_deg: float) -> Transform:
    """``T_base_tcp`` turned about its TCP so the tool leans ``tilt_deg`` towards the
    horizontal unit direction ``towards_m``."""
    axis = np.cross([0.0, 0.0, 1.0], towards_m)
    R = _turn(axis, math.radians(tilt_deg))[:3, :3] @ T_base_tcp[:3, :3]
    return make_transform(R, T_base_tcp[:3, 3])


def tiers(
    T_base_obj: Transform,
    T_base_tcp_grasp: Transform,
    symmetry: Symmetry | None,
    scene: SceneConfig,
    tilt_max_deg: float,
    symmetry_step_deg: float,
) -> list[list[Alternative]]:
    """Every alternative of a grasp ``T_base_tcp_grasp`` of the object at ``T_base_obj``, in
    tiers by tilt (module docstring)."""
    T_obj_tcp = invert(T_base_obj) @ T_base_tcp_grasp
    axis = np.zeros(3)
    axis[_AXES[symmetry.axis] if symmetry is not None else 2] = 1.0
    turned = [
        (yaw, compose(T_base_obj, _turn(axis, math.radians(yaw)), T_obj_tcp))
        for yaw in yaw_angles_deg(symmetry, symmetry_step_deg)
    ]
    out = [[Alternative(yaw, 0.0, T) for yaw, T in turned]]
    bin_ = bin_holding(scene, T_base_tcp_grasp[:3, 3])
    if bin_ is None:
        return out
    towards = bin_.T_base_bin[:3, 3] - T_base_tcp_grasp[:3, 3]
    towards[2] = 0.0
    off_centre = float(np.linalg.norm(towards))
    if off_centre < MIN_OFF_CENTRE_M:
        return out
    towards /= off_centre
    for tilt in tilt_angles_deg(tilt_max_deg)[1:]:
        out.append([Alternative(yaw, tilt, _tilted(T, towards, tilt)) for yaw, T in turned])
    return out
