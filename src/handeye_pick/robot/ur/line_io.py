"""A ur_rtde session that also serves the line's wired handshake (handeye_pick.line.io).

Two calls beside the session's own, both safe from the handshake's thread (the pipe to the
ur_rtde process serves one call at a time): the inputs from the latest RTDE sample the process
holds (its cached state, no controller round trip, no sample listener told), and a standard
output written through ur_rtde's IO interface without waiting to see it in the RTDE data.
"""

from __future__ import annotations

from handeye_pick.errors import RobotConnectionError, RobotFault
from handeye_pick.robot.ur.arm import URRtdeArm


class LineIoArm(URRtdeArm):
    """``URRtdeArm`` with the line's input and output calls (docs/line.md)."""

    def digital_input_bits(self) -> int:
        """``actual_digital_input_bits``: standard inputs bits 0-7, configurable 8-15, tool
        16-17."""
        fields = self._child.call("sample")
        if not isinstance(fields, dict):
            raise RobotConnectionError(f"sample on {self.host}: unexpected reply {fields!r}")
        return int(fields["digital_input_bits"])

    def write_standard_output(self, index: int, value: bool) -> None:
        """``setStandardDigitalOut(index, value)``; RobotFault when the controller refuses."""
        if not self._child.call("set_standard_digital_out", index, value):
            raise RobotFault(f"cell {self.host}: set standard digital output {index} refused")
