"""Synthetic hand-eye captures with a known truth: what a robot and a camera would report.

A scene is a true hand-eye transform ``T_cal`` (``T_flange_cam`` eye-in-hand, ``T_base_cam``
eye-to-hand), a true pose of the calibration object where it is fixed ``T_fixed_obj``
(``T_base_obj`` on the table, or ``T_flange_obj`` on the flange), and the true views: the
object's pose in the camera frame at each capture, 0.35 to 0.8 m in front of the camera, its
face turned toward the camera by up to 40 degrees, rolled anywhere. The robot poses follow from
the chain, exactly:

- eye-in-hand: ``T_base_flange = T_base_obj @ inv(T_cam_obj) @ inv(T_flange_cam)``
- eye-to-hand: ``T_base_flange = T_base_cam @ T_cam_obj @ inv(T_flange_obj)``

``measure`` adds noise as a real cell shows it: the camera's translation error larger along its
optical axis, the robot's pose error in the flange frame. Metres and radians throughout, float64
4x4 matrices, ``T_a_b`` = pose of b in a. Used by the solver's tests and the accuracy benchmark;
it imports nothing from handeye_pick.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

Matrix = NDArray[np.float64]


@dataclass(frozen=True)
class Noise:
    """Standard deviations per axis (mm, deg) of what the camera and the robot report."""

    camera_translation_mm: tuple[float, float, float] = (0.1, 0.1, 0.3)  # x, y, optical axis z
    camera_rotation_deg: float = 0.02
    robot_translation_mm: float = 0.1
    robot_rotation_deg: float = 0.01


NO_NOISE = Noise((0.0, 0.0, 0.0), 0.0, 0.0, 0.0)
_Z = np.array([0.0, 0.0, 1.0])
_FLIP_X = np.array([math.pi, 0.0, 0.0])  # rotation vector: half a turn about x, z pointing down


@dataclass(frozen=True, eq=False)
class Scene:
    """The truth of one calibration: hand-eye transform, fixed object pose, true views (m)."""

    mode: str  # "eye-in-hand" or "eye-to-hand"
    T_cal: Matrix
    T_fixed_obj: Matrix
    T_cam_obj: list[Matrix]  # the true views, one per capture

    def T_base_flange(self, T_cam_obj: Matrix) -> Matrix:
        """The true flange pose at which the camera sees the object at ``T_cam_obj``."""
        if self.mode == "eye-in-hand":
            return self.T_fixed_obj @ _inv(T_cam_obj) @ _inv(self.T_cal)
        return self.T_cal @ T_cam_obj @ _inv(self.T_fixed_obj)


def make_scene(rng: np.random.Generator, mode: str, count: int) -> Scene:
    """A random plausible cell and ``count`` varied views of the object."""
    if mode == "eye-in-hand":
        # Camera a few cm off the flange, looking roughly along the tool axis.
        T_cal = _pose(rng.uniform(-0.08, 0.08, 3) + _Z * 0.08, _random_rotvec(rng, 0.4))
        # Board on the table in front of the robot, face up with its z into the table.
        T_fixed_obj = _pose(
            [rng.uniform(0.3, 0.6), rng.uniform(-0.3, 0.3), rng.uniform(-0.05, 0.1)],
            _FLIP_X + _random_rotvec(rng, 0.2),
        )
    elif mode == "eye-to-hand":
        # Camera 1 to 1.5 m above the work area, looking down.
        T_cal = _pose(
            [rng.uniform(0.3, 0.7), rng.uniform(-0.4, 0.4), rng.uniform(1.0, 1.5)],
            _FLIP_X + _random_rotvec(rng, 0.3),
        )
        # Board on a bracket a few cm from the flange.
        T_fixed_obj = _pose(rng.uniform(-0.05, 0.05, 3) + _Z * 0.12, _random_rotvec(rng, 0.5))
    else:
        raise ValueError(f"unknown mode {mode!r}")
    return Scene(mode, T_cal, T_fixed_obj, [_view(rng) for _ in range(count)])


def measure(
    scene: Scene, rng: np.random.Generator, noise: Noise, views: list[Matrix] | None = None
) -> list[tuple[Matrix, Matrix]]:
    """``(T_base_flange, T_cam_obj)`` as robot and camera report them, one per view.

    ``views`` defaults to the scene's; noise is drawn independently for each capture.
    """
    captures = []
    for T_cam_obj in scene.T_cam_obj if views is None else views:
        T_base_flange = scene.T_base_flange(T_cam_obj) @ _pose(
            rng.normal(0.0, noise.robot_translation_mm * 1e-3, 3),
            rng.normal(0.0, math.radians(noise.robot_rotation_deg), 3),
        )
        # Position error in the camera frame (larger along z); rotation about the object.
        t_error = rng.normal(0.0, 1.0, 3) * np.array(noise.camera_translation_mm) * 1e-3
        T_measured = T_cam_obj @ _pose(
            [0, 0, 0], rng.normal(0.0, math.radians(noise.camera_rotation_deg), 3)
        )
        T_measured[:3, 3] += t_error
        captures.append((T_base_flange, T_measured))
    return captures


def wrong_pair(
    scene: Scene, rng: np.random.Generator, noise: Noise, index: int
) -> list[tuple[Matrix, Matrix]]:
    """``measure``, except that capture ``index`` gets the object pose of another view: the robot
    pose and the camera's measurement no longer belong together, as when a capture is skipped
    and the numbering slips."""
    captures = measure(scene, rng, noise)
    other = measure(scene, rng, noise, [_view(rng)])[0][1]
    captures[index] = (captures[index][0], other)
    return captures


def _view(rng: np.random.Generator) -> Matrix:
    """``T_cam_obj``: the object 0.35-0.8 m ahead, its z axis within 40 deg of the camera's."""
    direction = _random_direction_within(rng, math.radians(15))  # where in the field of view
    position = direction * rng.uniform(0.35, 0.8)
    tilt = _random_direction_within(rng, math.radians(40))
    roll = Rotation.from_rotvec([0, 0, rng.uniform(-math.pi, math.pi)])
    align = Rotation.align_vectors([tilt], [[0.0, 0.0, 1.0]])[0]
    return _pose(position, (align * roll).as_rotvec())


def _random_direction_within(rng: np.random.Generator, half_angle: float) -> Matrix:
    """A unit vector within ``half_angle`` of +z, uniform over that cap of the sphere."""
    cos_theta = rng.uniform(math.cos(half_angle), 1.0)
    phi = rng.uniform(0, 2 * math.pi)
    sin_theta = math.sqrt(1.0 - cos_theta**2)
    return np.array([sin_theta * math.cos(phi), sin_theta * math.sin(phi), cos_theta])


def _random_rotvec(rng: np.random.Generator, max_angle: float) -> Matrix:
    axis = rng.normal(size=3)
    return np.asarray(axis / np.linalg.norm(axis) * rng.uniform(0, max_angle))


def _pose(t: Matrix | list[float], rotvec: Matrix | list[float]) -> Matrix:
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(rotvec).as_matrix()
    T[:3, 3] = t
    return T


def _inv(T: Matrix) -> Matrix:
    out = np.eye(4)
    out[:3, :3] = T[:3, :3].T
    out[:3, 3] = -T[:3, :3].T @ T[:3, 3]
    return out
