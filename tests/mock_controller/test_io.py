"""RTDEIOInterface against the simulated controller: setters land in the IO state."""

from __future__ import annotations

from collections.abc import Callable

import pytest
import rtde_io
import rtde_receive

from mocks.ur_controller import SimulatedController
from tests.mock_controller.helpers import wait_for


@pytest.mark.timeout(60)
def test_io_setters_land_in_the_io_state(
    sim_controller: Callable[..., SimulatedController],
) -> None:
    ctl = sim_controller(instant=True)
    io = rtde_io.RTDEIOInterface(ctl.host)
    receive = rtde_receive.RTDEReceiveInterface(ctl.host)
    try:
        assert io.setStandardDigitalOut(3, True)
        assert io.setStandardDigitalOut(5, True)
        assert io.setStandardDigitalOut(3, False)
        assert io.setToolDigitalOut(1, True)
        assert io.setConfigurableDigitalOut(2, True)
        assert io.setSpeedSlider(0.4)
        assert io.setAnalogOutputVoltage(1, 0.25)
        wait_for(lambda: ctl.snapshot().standard_digital_out == 1 << 5)
        snap = ctl.snapshot()
        assert snap.tool_digital_out == 1 << 1
        assert snap.configurable_digital_out == 1 << 2
        # The receive stream shows them a sample or more later, each setter's in its own
        # sample: wait for the last one's (the analog output), then read them all together.
        wait_for(lambda: receive.getStandardAnalogOutput1() == pytest.approx(0.25))
        assert receive.getDigitalOutState(5)
        assert not receive.getDigitalOutState(3)
        assert receive.getDigitalOutState(8 + 2)  # configurable outputs are bits 8-15
        assert receive.getDigitalOutState(16 + 1)  # tool outputs are bits 16-17
        assert receive.getTargetSpeedFraction() == pytest.approx(0.4)
    finally:
        receive.disconnect()
        io.disconnect()  # sends P and blocks until it is answered
