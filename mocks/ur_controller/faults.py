"""Fault specs: `FAULT@WHEN` as `--inject` and `SimulatedController.inject` take them.

FAULT is one of protective-stop, emergency-stop, safeguard-stop, drop-connection, stall:SECONDS,
stop-program, remote-control-off, dashboard-down, refuse-start, refuse-move, slow:SECONDS,
jitter:SECONDS (the measured joints shake, arm.py's `Arm.jitter`), and for the simulated
Robotiq gripper gripper-fault:CODE (FLT 1..255), gripper-silent, gripper-drop. WHEN is `now`
(the default when `@WHEN` is left out) or `move:K:FRACTION`: during the K-th motion command
(counted from 1), once FRACTION (0..1) of that motion's duration has elapsed.
"""

from __future__ import annotations

from dataclasses import dataclass

PLAIN_FAULTS = (
    "protective-stop",
    "emergency-stop",
    "safeguard-stop",
    "drop-connection",
    "stop-program",
    "remote-control-off",
    "dashboard-down",
    "refuse-start",
    "refuse-move",
    "gripper-silent",
    "gripper-drop",
)
TIMED_FAULTS = ("stall", "slow", "jitter")  # take `:SECONDS`
CODE_FAULTS = ("gripper-fault",)  # take `:CODE`, 1..255


@dataclass(frozen=True)
class FaultSpec:
    """One parsed fault. `seconds` only for stall/slow/jitter, `code` only for gripper-fault;
    `move_index` None means now."""

    name: str
    seconds: float | None = None
    move_index: int | None = None
    fraction: float = 0.0
    code: int | None = None


def parse_fault(spec: str) -> FaultSpec:
    """Parse `FAULT@WHEN`; raises ValueError naming what was expected and what was found."""
    fault, _, when = spec.strip().partition("@")
    name, _, argument = fault.partition(":")
    seconds: float | None = None
    code: int | None = None
    if name in CODE_FAULTS:
        if not (argument.isdigit() and 1 <= int(argument) <= 255):
            raise ValueError(f"fault {spec!r}: {name} needs `:CODE` with CODE 1..255, "
                             f"got {argument!r}")
        code = int(argument)
    elif name in TIMED_FAULTS:
        try:
            seconds = float(argument)
        except ValueError:
            raise ValueError(f"fault {spec!r}: {name} needs `:SECONDS`, got {argument!r}") from None
        if not seconds >= 0.0:
            raise ValueError(f"fault {spec!r}: SECONDS must be >= 0, got {argument!r}")
    elif name not in PLAIN_FAULTS or argument:
        raise ValueError(
            f"fault {spec!r}: expected one of {', '.join(PLAIN_FAULTS)}, stall:SECONDS, "
            f"slow:SECONDS, jitter:SECONDS or gripper-fault:CODE, got {fault!r}"
        )
    if when in ("", "now"):
        return FaultSpec(name, seconds, code=code)
    parts = when.split(":")
    try:
        if len(parts) != 3 or parts[0] != "move":
            raise ValueError
        move_index = int(parts[1])
        fraction = float(parts[2])
    except ValueError:
        raise ValueError(f"fault {spec!r}: WHEN must be `now` or `move:K:FRACTION`, "
                         f"got {when!r}") from None
    if move_index < 1 or not 0.0 <= fraction <= 1.0:
        raise ValueError(f"fault {spec!r}: need K >= 1 and 0 <= FRACTION <= 1, got {when!r}")
    return FaultSpec(name, seconds, move_index, fraction, code)
