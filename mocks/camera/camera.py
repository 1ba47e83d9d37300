"""The simulated 3D camera: pinhole intrinsics, a true mount, organized point clouds, board poses.

Frames and units:

- ``cam`` is the optical frame as Zivid defines it: z out of the lens, x to the right and y down
  in the image. Pixel ``(col, row)`` looks along ``((col - cx) / fx, (row - cy) / fy, 1)``;
  integer pixel coordinates are pixel centres.
- Robot-side poses (mount, flange, scene) are ``T_a_b`` float64 4x4 in metres. Camera-side
  outputs are Zivid's: clouds and ``T_cam_obj`` translations in millimetres.
- Eye-in-hand: the camera is mounted on the flange at ``T_flange_cam``; every capture needs the
  flange pose ``T_base_flange``. Eye-to-hand: the camera stands in the cell at ``T_base_cam``.

Never imports ``handeye_pick``: the simulator must not share pose maths with the code under test.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mocks.camera.board import BoardNotVisible, CalibrationBoard, PoseNoise
from mocks.camera.frames import Matrix, checked_transform, invert
from mocks.camera.scene import Box, Scene
from mocks.ur_controller.kinematics import pose_to_matrix

if TYPE_CHECKING:  # the capture command's process never starts a controller
    from mocks.ur_controller import SimulatedController

Mode = Literal["eye-in-hand", "eye-to-hand"]

MAX_BOARD_VIEW_ANGLE_DEG = 70.0
"""A board seen more obliquely than this (board normal against the line of sight) is not found."""


@dataclass(frozen=True)
class Intrinsics:
    """A pinhole camera without distortion: image size and focal lengths / centre in pixels."""

    width_px: int
    height_px: int
    fx_px: float
    fy_px: float
    cx_px: float
    cy_px: float

    def __post_init__(self) -> None:
        if self.width_px < 1 or self.height_px < 1:
            raise ValueError(f"image size must be positive, got {self.width_px} x "
                             f"{self.height_px}")
        if not (self.fx_px > 0.0 and self.fy_px > 0.0):
            raise ValueError(f"focal lengths must be positive, got {self.fx_px}, {self.fy_px}")

    @classmethod
    def from_fov(cls, width_px: int = 160, height_px: int = 120,
                 hfov_deg: float = 60.0) -> Intrinsics:
        """Square pixels, centred principal point, ``hfov_deg`` across the image's full width."""
        if not 0.0 < hfov_deg < 180.0:
            raise ValueError(f"hfov_deg must be in (0, 180), got {hfov_deg}")
        f_px = (width_px / 2.0) / math.tan(math.radians(hfov_deg) / 2.0)
        return cls(width_px, height_px, f_px, f_px, (width_px - 1) / 2.0, (height_px - 1) / 2.0)

    def rays(self) -> Matrix:
        """Each pixel's viewing direction in the camera frame with z = 1, shape (3, H * W): one
        column per pixel, row-major (column ``row * W + col``)."""
        rows, cols = np.mgrid[0:self.height_px, 0:self.width_px].astype(np.float64)
        return np.stack(
            [(cols.ravel() - self.cx_px) / self.fx_px,
             (rows.ravel() - self.cy_px) / self.fy_px,
             np.ones(rows.size)],
        )

    def project(self, p_cam: ArrayLike) -> tuple[float, float]:
        """Pixel coordinates ``(col, row)`` of a camera-frame point (any length unit, z > 0)."""
        x, y, z = np.asarray(p_cam, dtype=np.float64)
        return self.cx_px + self.fx_px * x / z, self.cy_px + self.fy_px * y / z

    def in_image(self, col: float, row: float) -> bool:
        """True when pixel coordinates fall on the sensor (pixel edges at -0.5 and W - 0.5)."""
        return -0.5 <= col < self.width_px - 0.5 and -0.5 <= row < self.height_px - 0.5


DEFAULT_INTRINSICS = Intrinsics.from_fov(160, 120, 60.0)
BOARD_POSE_NOISE = PoseNoise()  # 0.1 mm, 0.3 mm along the optical axis, 0.02 deg


class SimulatedCamera:
    """A 3D camera looking at ``scene``; give exactly one of ``T_flange_cam`` (eye-in-hand) and
    ``T_base_cam`` (eye-to-hand), metres.

    ``pose_noise`` and ``seed`` set the calibration-board measurements of ``object_pose_mm``: each
    call draws fresh noise from one generator seeded with ``seed``, so a sequence of calls is
    reproducible. Clouds are exact (no noise).
    """

    def __init__(
        self,
        scene: Scene,
        intrinsics: Intrinsics = DEFAULT_INTRINSICS,
        *,
        T_flange_cam: ArrayLike | None = None,
        T_base_cam: ArrayLike | None = None,
        pose_noise: PoseNoise = BOARD_POSE_NOISE,
        seed: int | tuple[int, ...] = 0,
    ):
        self.mode: Mode
        self.T_mount_cam: Matrix  # T_flange_cam (eye-in-hand) or T_base_cam (eye-to-hand), m
        if T_flange_cam is not None and T_base_cam is None:
            self.mode, self.T_mount_cam = "eye-in-hand", checked_transform(T_flange_cam,
                                                                           "T_flange_cam")
        elif T_base_cam is not None and T_flange_cam is None:
            self.mode, self.T_mount_cam = "eye-to-hand", checked_transform(T_base_cam,
                                                                           "T_base_cam")
        else:
            raise ValueError("SimulatedCamera: give exactly one of T_flange_cam (eye-in-hand) "
                             "and T_base_cam (eye-to-hand)")
        self.scene = scene
        self.intrinsics = intrinsics
        self.pose_noise = pose_noise
        self._rng = np.random.default_rng(seed)
        self._rays = intrinsics.rays()

    def T_base_cam(self, T_base_flange: ArrayLike | None = None) -> Matrix:
        """The camera's pose in the base frame (m). Eye-in-hand needs the flange pose
        ``T_base_flange`` (m); eye-to-hand refuses one (its camera does not move with the arm)."""
        if self.mode == "eye-to-hand":
            if T_base_flange is not None:
                raise ValueError("an eye-to-hand camera does not move with the flange: "
                                 "capture without T_base_flange")
            return self.T_mount_cam
        if T_base_flange is None:
            raise ValueError("an eye-in-hand camera needs the flange pose T_base_flange")
        T_base_cam: Matrix = checked_transform(T_base_flange, "T_base_flange") @ self.T_mount_cam
        return T_base_cam

    def capture(self, T_base_flange: ArrayLike | None = None) -> NDArray[np.float32]:
        """An organized cloud: float32 (H, W, 3), ``xyz[row, col]`` in mm in the camera frame,
        NaN where the pixel's ray hits nothing. ``T_base_flange`` as for ``T_base_cam``."""
        T = self.T_base_cam(T_base_flange)
        height, width = self.intrinsics.height_px, self.intrinsics.width_px
        origin = T[:3, 3]
        directions = (T[:3, :3] @ self._rays).reshape(3, height, width)
        t = self.scene.table_distances(origin, directions.reshape(3, -1)).reshape(height, width)
        for box in self.scene.boxes.values():
            window = self._pixel_window(T, box)
            if window is not None:
                rows, cols = window
                rays = directions[:, rows, cols]
                hits = box.hit_distances(origin, rays.reshape(3, -1)).reshape(rays.shape[1:])
                np.minimum(t[rows, cols], hits, out=t[rows, cols])
        # The rays have z = 1 in the camera frame, so t is the depth and t * ray the point (m).
        depth_mm = np.where(np.isfinite(t), t * 1000.0, np.nan).ravel()
        cloud = np.empty((height, width, 3), np.float32)
        for axis in range(3):
            cloud[:, :, axis] = (self._rays[axis] * depth_mm).reshape(height, width)
        return cloud

    def _pixel_window(self, T_base_cam: Matrix, box: Box) -> tuple[slice, slice] | None:
        """Rows and columns of the pixels whose rays can meet ``box``, None when none can.

        With every corner in front of the camera, the box's image lies inside the rectangle
        around its corners' images, so only those pixels need a ray test (most of a capture's
        time otherwise); a box reaching behind the camera gets every pixel.
        """
        corners = (box.corners_m() - T_base_cam[:3, 3]) @ T_base_cam[:3, :3]  # camera frame
        i = self.intrinsics
        if (corners[:, 2] <= 0.0).any():
            return slice(0, i.height_px), slice(0, i.width_px)
        cols = i.cx_px + i.fx_px * corners[:, 0] / corners[:, 2]
        rows = i.cy_px + i.fy_px * corners[:, 1] / corners[:, 2]
        col_lo, col_hi = max(0, math.floor(cols.min())), min(i.width_px, math.ceil(cols.max()) + 1)
        row_lo, row_hi = max(0, math.floor(rows.min())), min(i.height_px, math.ceil(rows.max()) + 1)
        if col_lo >= col_hi or row_lo >= row_hi:
            return None
        return slice(row_lo, row_hi), slice(col_lo, col_hi)

    def capture_from(self, controller: SimulatedController) -> NDArray[np.float32]:
        """``capture`` with the arm where the simulated controller says it is now."""
        if self.mode == "eye-to-hand":
            return self.capture()
        return self.capture(pose_to_matrix(controller.snapshot().flange_pose))

    def object_pose_mm(self, board: CalibrationBoard, T_base_flange: ArrayLike) -> Matrix:
        """The board's pose ``T_cam_obj`` as a detector measures it: float64 4x4, translation in
        mm (as Zivid writes it), with one fresh draw of ``pose_noise``.

        Both modes need the flange pose (m): eye-in-hand for the camera, eye-to-hand for the board
        it carries. Raises ``BoardNotVisible`` when the board's centre is behind the camera, off
        the image, or seen more obliquely than ``MAX_BOARD_VIEW_ANGLE_DEG``; ValueError when the
        board is fixed to the same thing as the camera (nothing to calibrate).
        """
        T_base_flange = checked_transform(T_base_flange, "T_base_flange")
        expected = "base" if self.mode == "eye-in-hand" else "flange"
        if board.parent != expected:
            raise ValueError(f"an {self.mode} camera calibrates against a board fixed to the "
                             f"{expected}, not to the {board.parent}")
        T_base_cam = T_base_flange @ self.T_mount_cam if self.mode == "eye-in-hand" \
            else self.T_mount_cam
        T_cam_obj = invert(T_base_cam) @ board.in_base(T_base_flange)
        self._check_visible(T_cam_obj)
        measured = self.pose_noise.apply(T_cam_obj, self._rng)
        measured[:3, 3] *= 1000.0
        return measured

    def _check_visible(self, T_cam_obj: Matrix) -> None:
        centre = T_cam_obj[:3, 3]
        if centre[2] <= 0.0:
            raise BoardNotVisible(f"the board is behind the camera (z = {centre[2] * 1000:.1f} mm)")
        col, row = self.intrinsics.project(centre)
        if not self.intrinsics.in_image(col, row):
            raise BoardNotVisible(f"the board's centre is off the image (pixel {col:.1f}, "
                                  f"{row:.1f})")
        cos_view = float(T_cam_obj[:3, 2] @ centre) / float(np.linalg.norm(centre))
        angle_deg = math.degrees(math.acos(max(-1.0, min(1.0, cos_view))))
        if angle_deg > MAX_BOARD_VIEW_ANGLE_DEG:
            raise BoardNotVisible(f"the board is seen at {angle_deg:.0f} deg from its normal "
                                  f"(at most {MAX_BOARD_VIEW_ANGLE_DEG:.0f})")
