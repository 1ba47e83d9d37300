"""The ``line`` section of the cell config: the wired handshake with a line PLC (``line.io``).

The PLC is wired to the control box's standard digital inputs and outputs (0-7). Inputs are
commands from the line: ``cycle_stop`` is a level (the cell holds while it is high),
``stop`` and ``resume`` act on a rising edge. Outputs show the line state: ``ready``,
``executing``, ``held``, ``halted`` and a ``heartbeat`` that toggles every second. Every key is
optional; a bit the gripper uses, or one given twice, is refused (docs/line.md).
"""

from __future__ import annotations

from dataclasses import dataclass

from handeye_pick.config.gripper import STANDARD_OUTPUTS, AnyGripperConfig, GripperConfig
from handeye_pick.config.reader import Fields
from handeye_pick.robot.port import OutputBank

LINE_INPUTS = ("cycle_stop", "stop", "resume")
"""The commands a PLC gives on standard digital inputs, in the order docs/line.md lists them."""
LINE_OUTPUTS = ("ready", "executing", "held", "halted", "heartbeat")
"""What the cell shows the PLC on standard digital outputs."""


@dataclass(frozen=True)
class LineIoConfig:
    """``line.io``: standard digital input and output numbers (0-7) by meaning; None: unwired.

    Inputs: ``cycle_stop`` (level: held while high), ``stop`` (rising edge: an immediate stop),
    ``resume`` (rising edge). Outputs: ``ready`` (no motion, may start one), ``executing`` (a
    motion request runs), ``held`` (a cycle stop is in force), ``halted`` (out of service until
    resume), ``heartbeat`` (toggles every second while the cell serves)."""

    inputs: dict[str, int]  # meaning -> standard digital input
    outputs: dict[str, int]  # meaning -> standard digital output


@dataclass(frozen=True)
class LineConfig:
    """``line``: the line's interfaces configured in the cell (the OPC UA server is a ``run``
    option, not a cell property)."""

    io: LineIoConfig | None = None


def read_line(top: Fields, gripper: AnyGripperConfig | None) -> LineConfig:
    """``line``: ``io`` with ``inputs`` and ``outputs`` mappings; bits ``gripper`` uses refused."""
    line = top.section("line", ("io",))
    if not line.has("io"):
        return LineConfig()
    io = line.section("io", ("inputs", "outputs"))
    inputs = _bits(io, "inputs", LINE_INPUTS)
    outputs = _bits(io, "outputs", LINE_OUTPUTS)
    if not inputs and not outputs:
        io.fail("", "give inputs, outputs or both (standard digital numbers 0-7)")
    if isinstance(gripper, GripperConfig):
        _refuse_gripper_bits(io, gripper, inputs, outputs)
    return LineConfig(LineIoConfig(inputs, outputs))


def _bits(io: Fields, key: str, meanings: tuple[str, ...]) -> dict[str, int]:
    if not io.has(key):
        return {}
    fields = io.section(key, meanings)
    bits = {
        name: fields.integer(name, minimum=0, maximum=STANDARD_OUTPUTS - 1)
        for name in meanings
        if fields.has(name)
    }
    seen: dict[int, str] = {}
    for name, bit in bits.items():
        if bit in seen:
            fields.fail(name, f"standard digital {bit} is {seen[bit]} already")
        seen[bit] = name
    return bits


def _refuse_gripper_bits(
    io: Fields, gripper: GripperConfig, inputs: dict[str, int], outputs: dict[str, int]
) -> None:
    if gripper.bank is OutputBank.STANDARD:
        for name, bit in outputs.items():
            if bit == gripper.index:
                io.fail(
                    f"outputs.{name}",
                    f"standard digital output {bit} is the gripper's (robot.gripper.index)",
                )
    feedback = gripper.confirm_input
    if feedback is not None and feedback.bank is OutputBank.STANDARD:
        for name, bit in inputs.items():
            if bit == feedback.index:
                io.fail(
                    f"inputs.{name}",
                    f"standard digital input {bit} is the gripper's feedback "
                    "(robot.gripper.confirm_input)",
                )
