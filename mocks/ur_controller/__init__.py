"""Simulated UR controller (e-Series, CB3 and PolyScope X profiles) for tests and the demo: the
real ur_rtde client talks to it.

See README.md in this folder. Never imports handeye_pick: the simulator must not share pose
maths with the code under test.
"""

from mocks.ur_controller.simulated import SimulatedController
from mocks.ur_controller.snapshot import ControllerSnapshot

__all__ = ["ControllerSnapshot", "SimulatedController"]
