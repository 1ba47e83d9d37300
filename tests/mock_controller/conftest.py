"""ur_rtde clients shared by a module's tests: each test module defines its own module-scoped
``ctl`` fixture (the simulated controller it needs), and these connect to it once per module."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
import rtde_control
import rtde_receive

from mocks.ur_controller import SimulatedController


@pytest.fixture(scope="module")
def receive(ctl: SimulatedController) -> Iterator[rtde_receive.RTDEReceiveInterface]:
    r = rtde_receive.RTDEReceiveInterface(ctl.host)
    yield r
    r.disconnect()


@pytest.fixture(scope="module")
def control(ctl: SimulatedController) -> Iterator[rtde_control.RTDEControlInterface]:
    c = rtde_control.RTDEControlInterface(ctl.host)
    yield c
    c.disconnect()
