"""The wired handshake: a line PLC on the control box's standard digital inputs and outputs.

A thread of its own looks every ``PERIOD_S``: it reads ``actual_digital_input_bits`` from the
latest RTDE sample the session's ur_rtde process holds (its cached state, no controller round
trip) and turns them into line commands: ``cycle_stop`` follows the input's level (rising: a
cycle stop, falling: a release), ``stop`` and ``resume`` act on a rising edge. It writes the
outputs (``ready``, ``executing``, ``held``, ``halted``, ``heartbeat``) through ur_rtde's IO
interface, each only when it changes; the heartbeat toggles every second. The session's pipe
to ur_rtde serves one call at a time, so this thread never interleaves with a move's.

When ``run`` ends, every output is switched off. While the robot session is closed (a lost
link, or a resume the controller refused) no output can be written: the heartbeat stops, which
is how a PLC sees it; the inputs are then read from outside, one RTDE package every
``OUTSIDE_PERIOD_S`` (``robot.ur.readout``: no program, nothing written), so a wired resume
still reaches the cell. Any error here is logged once and retried; it never reaches the cell.
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Protocol, runtime_checkable

from handeye_pick.config.line import LineIoConfig
from handeye_pick.errors import HandEyePickError
from handeye_pick.line.state import ItemState, Line, LineView
from handeye_pick.robot.ur.readout import read_digital_inputs

log = logging.getLogger(__name__)

PERIOD_S = 0.05
"""How often the inputs are read and the outputs brought up to date (20 Hz)."""
OUTSIDE_PERIOD_S = 0.5
"""How often the inputs are read from outside while the session has no link."""


@runtime_checkable
class LineIoArm(Protocol):
    """What the handshake needs of a robot session (``robot.ur.arm.URRtdeArm``)."""

    def digital_input_bits(self) -> int:
        """``actual_digital_input_bits`` of the latest RTDE sample."""

    def write_standard_output(self, index: int, value: bool) -> None:
        """Set one standard digital output."""


def outputs_for(view: LineView) -> dict[str, bool]:
    """What each output shows for ``view``: the heartbeat is high in even seconds."""
    return {
        "ready": view.ready,
        "executing": view.state is ItemState.EXECUTING,
        "held": view.held,
        "halted": view.state in (ItemState.OUT_OF_SERVICE, ItemState.NOT_AVAILABLE),
        "heartbeat": view.heartbeat_s % 2 == 0,
    }


class WiredHandshake:
    """The handshake of ``line`` over the inputs and outputs of ``io``; ``start``/``close``."""

    def __init__(self, line: Line, io: LineIoConfig) -> None:
        self.line = line
        self.io = io
        self._previous: dict[str, bool] = {}  # input meaning -> level last seen
        self._written: dict[int, bool] = {}  # output bit -> level last written
        self._arm: object = None  # the session the outputs were written through
        self._stopping = threading.Event()
        self._thread = threading.Thread(target=self._run, name="line io", daemon=True)
        self._last_problem: str | None = None
        self._next_outside = 0.0  # when the inputs are next read from outside (monotonic s)

    def start(self) -> WiredHandshake:
        self._thread.start()
        return self

    def close(self) -> None:
        """Stop looking and switch every output off (before the session closes), so no PLC
        sees ``ready`` from a cell that is gone."""
        self._stopping.set()
        if self._thread.is_alive():  # close() before start(): nothing to wait for
            self._thread.join(timeout=2.0)
        cell = self.line.cell
        try:
            arm = cell.arm if cell.connected else None
            if isinstance(arm, LineIoArm):
                for bit in self.io.outputs.values():
                    arm.write_standard_output(bit, False)
        except (HandEyePickError, OSError, ValueError) as exc:
            log.warning("line io: outputs left as they were at the end (%s)", exc)

    def _run(self) -> None:
        while not self._stopping.wait(PERIOD_S):
            try:
                self.step()
            except (HandEyePickError, OSError, ValueError) as exc:
                self._problem(f"{type(exc).__name__}: {exc}")

    def step(self) -> None:
        """One look: inputs to commands, state to outputs."""
        cell = self.line.cell
        if not cell.connected:
            self._arm = None
            if self.io.inputs and self._outside_due():
                self._inputs(read_digital_inputs(cell.config.robot.host))
            return
        arm = cell.arm
        if not isinstance(arm, LineIoArm):
            return
        if arm is not self._arm:  # a new session (a resume): write every output again
            self._arm, self._written = arm, {}
        if self.io.inputs:
            self._inputs(arm.digital_input_bits())
        for name, value in outputs_for(self.line.view()).items():
            bit = self.io.outputs.get(name)
            if bit is not None and self._written.get(bit) is not value:
                arm.write_standard_output(bit, value)
                self._written[bit] = value
        self._last_problem = None

    def _outside_due(self) -> bool:
        now = time.monotonic()
        if now < self._next_outside:
            return False
        self._next_outside = now + OUTSIDE_PERIOD_S
        return True

    def _inputs(self, bits: int) -> None:
        for name, bit in self.io.inputs.items():
            level = bool(bits >> bit & 1)
            before = self._previous.get(name, False)
            self._previous[name] = level
            if level == before:
                continue
            by = f"input DI{bit} ({name.replace('_', ' ')})"
            if name == "cycle_stop":
                if level:
                    self.line.cycle_stop(by)
                else:
                    self.line.release(by)
            elif name == "stop" and level:
                self.line.stop(by)
            elif name == "resume" and level:
                self.line.resume(by, wait_s=0)

    def _problem(self, text: str) -> None:
        if text != self._last_problem:
            log.warning("line io: %s (looking again every %g s)", text, PERIOD_S)
            self._last_problem = text
