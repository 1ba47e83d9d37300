"""Simulated 3D camera for tests and examples: a scene in the robot base frame, organized point
clouds in Zivid's layout (mm, NaN where nothing is hit) and a calibration board's measured pose.

See README.md in this folder. Never imports handeye_pick: the simulator must not share pose
maths with the code under test.
"""

from mocks.camera.board import BoardNotVisible, CalibrationBoard, PoseNoise
from mocks.camera.camera import DEFAULT_INTRINSICS, Intrinsics, SimulatedCamera
from mocks.camera.robot_pose import read_flange_pose
from mocks.camera.scene import Box, Scene
from mocks.camera.zivid_yaml import read_zivid_matrix, write_zivid_matrix

__all__ = [
    "DEFAULT_INTRINSICS",
    "BoardNotVisible",
    "Box",
    "CalibrationBoard",
    "Intrinsics",
    "PoseNoise",
    "Scene",
    "SimulatedCamera",
    "read_flange_pose",
    "read_zivid_matrix",
    "write_zivid_matrix",
]
