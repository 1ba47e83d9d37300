"""``type: robotiq-2f``: a Robotiq 2F-85/140 through the Robotiq URCap's ASCII socket on the
robot's host (port 63352).

The protocol: one request per line, ``SET VAR value [VAR value ...]`` answered ``ack``, ``GET
VAR`` answered ``VAR value``. Registers (Robotiq 2F-85/140 manual): ACT activate, GTO go to the
requested position, POS requested (written) / actual (read) position 0 open .. 255 closed, SPE
speed and FOR force 0..255, read-only STA (3: activation complete), PRE (echo of the requested
position), OBJ (0 moving, 1 stopped by contact while opening, 2 stopped by contact while closing,
3 at the requested position) and FLT (fault code, 0 none).

Widths are between the fingers (mm), mapped linearly from ``stroke_mm`` at position 0 to 0 mm at
255. Every socket call is bounded by ``timeout_s``: a gripper that does not answer is a
``GripperFault``, never a hang, and the connection is not used again.
"""

from __future__ import annotations

import socket
import time
from collections.abc import Callable

from handeye_pick.config.gripper import Robotiq2FConfig
from handeye_pick.errors import GripperFault
from handeye_pick.gripper.port import GraspState

OPEN, CLOSED = 0, 255
STA_ACTIVE = 3
OBJ_MOVING, OBJ_CONTACT_OPENING, OBJ_CONTACT_CLOSING, OBJ_AT_POSITION = 0, 1, 2, 3
ACTIVATION_TIMEOUT_S = 10.0
"""A 2F activation opens and closes the fingers fully: a few seconds."""
MIN_FINGER_SPEED_MMPS = 20.0
"""The slowest finger speed of the 2F family (2F-85 at SPE 0): bounds the wait for a stroke."""
POLL_S = 0.01

FAULTS: dict[int, str] = {
    0x05: "action delayed: the activation must complete first",
    0x07: "the gripper is not activated (ACT must be set before any action)",
    0x08: "maximum operating temperature exceeded: let the gripper cool down",
    0x09: "no communication with the gripper for at least 1 s",
    0x0A: "supply voltage under the minimum",
    0x0B: "automatic release in progress",
    0x0C: "internal fault: contact Robotiq support",
    0x0D: "activation fault: check that nothing blocks the fingers",
    0x0E: "overcurrent triggered",
    0x0F: "automatic release completed",
}


def fault_text(code: int) -> str:
    """What a Robotiq FLT code means, e.g. ``0x08 (maximum operating temperature ...)``."""
    return f"0x{code:02X} ({FAULTS.get(code, 'a fault code the 2F manual does not list')})"


class Robotiq2F:
    """A connected Robotiq 2F (implements ``Gripper``); activates it at connect when needed and
    tells ``say`` so (the fingers move)."""

    kind = Robotiq2FConfig.kind

    def __init__(self, host: str, config: Robotiq2FConfig, say: Callable[[str], None]) -> None:
        self._config = config
        self._where = f"Robotiq gripper on {host}:{config.port}"
        self._broken: str | None = None
        self._missed = "the fingers have not closed yet"  # why_missed(), set by close()
        try:
            self._sock = socket.create_connection((host, config.port), timeout=config.timeout_s)
        except OSError as exc:
            raise GripperFault(
                f"{self._where}: cannot connect ({exc}): is the Robotiq URCap installed and "
                "the gripper plugged in?"
            ) from None
        self._reader = self._sock.makefile("r", encoding="ascii", newline="\n")
        try:
            self._activate(say)
        except BaseException:
            self.close_connection()
            raise

    # --- Gripper -------------------------------------------------------------------------------

    def close(self) -> GraspState:
        """Close at the configured speed and force. ``CONFIRMED`` when the fingers stopped on a
        part (OBJ 2) at a width inside ``expected_width_mm``; ``MISSED`` when they closed on
        nothing (OBJ 3) or stopped at another width (a wrong part, or one caught at an edge)."""
        obj, width_mm = self._go_to(CLOSED)
        low, high = self._config.expected_width_mm
        if obj == OBJ_CONTACT_CLOSING and low <= width_mm <= high:
            return GraspState.CONFIRMED
        if obj == OBJ_CONTACT_CLOSING:
            self._missed = (
                f"the fingers of the {self._where} stopped on something {width_mm:.1f} mm wide, "
                f"not {low:g}..{high:g} mm (expected_width_mm): check the part and where it "
                "was gripped"
            )
            return GraspState.MISSED
        if obj == OBJ_AT_POSITION:
            self._missed = (
                f"the fingers of the {self._where} closed to {width_mm:.1f} mm without "
                "touching anything (OBJ 3): check that a part was between them"
            )
            return GraspState.MISSED
        raise GripperFault(f"{self._where}: closing ended with OBJ {obj} at {width_mm:.1f} mm")

    def why_missed(self) -> str:
        """What the fingers did at the last missed close: their width and why it is no grasp."""
        return self._missed

    def open(self) -> bool:
        """Open fully; the release is confirmed when the fingers reach the open position."""
        obj, width_mm = self._go_to(OPEN)
        if obj != OBJ_AT_POSITION:
            raise GripperFault(
                f"{self._where}: the fingers stopped at {width_mm:.1f} mm while opening (OBJ "
                f"{obj}): something blocks them"
            )
        return True

    def ready_to_grasp(self) -> str | None:
        """The fingers must be wider apart than the widest part expected: fingers left closed
        (a part slipped out of them, or they were closed by hand) would come down on the
        part."""
        self._check_fault()
        width_mm = self._width_mm(self._get("POS"))
        widest_mm = self._config.expected_width_mm[1]
        if width_mm > widest_mm:
            return None
        return (
            f"{self._where}: the fingers are {width_mm:.1f} mm apart, not wider than the "
            f"{widest_mm:g} mm part, so the grasp would come down on it: open the gripper "
            "(pendant), then pick again"
        )

    def state(self) -> GraspState:
        """``CONFIRMED`` while the fingers hold a part (OBJ 2), else ``MISSED``; a fault raises."""
        self._check_fault()
        held = self._get("OBJ") == OBJ_CONTACT_CLOSING
        return GraspState.CONFIRMED if held else GraspState.MISSED

    def close_connection(self) -> None:
        self._reader.close()
        self._sock.close()

    # --- protocol ------------------------------------------------------------------------------

    def _activate(self, say: Callable[[str], None]) -> None:
        status = self._get("STA")
        if status != STA_ACTIVE:
            say(f"activating the {self._where} (STA {status}): its fingers will move")
            if self._get("ACT") != 1:
                self._set(ACT=1)
            deadline = time.monotonic() + ACTIVATION_TIMEOUT_S
            while self._get("STA") != STA_ACTIVE:
                self._check_fault()
                if time.monotonic() > deadline:
                    raise GripperFault(
                        f"{self._where}: not activated after {ACTIVATION_TIMEOUT_S:g} s"
                    )
                time.sleep(POLL_S)
        self._check_fault()

    def _go_to(self, position: int) -> tuple[int, float]:
        """Move the fingers to ``position`` and wait until they stop; OBJ and the width (mm)."""
        speed = round(self._config.speed_pct * 2.55)
        force = round(self._config.force_pct * 2.55)
        self._set(POS=position, SPE=speed, FOR=force, GTO=1)
        timeout_s = self._config.stroke_mm / MIN_FINGER_SPEED_MMPS + 1.0
        deadline = time.monotonic() + timeout_s
        while True:
            self._check_fault()
            # OBJ describes the latest request only once PRE echoes it (the manual).
            if self._get("PRE") == position:
                obj = self._get("OBJ")
                if obj != OBJ_MOVING:
                    return obj, self._width_mm(self._get("POS"))
            if time.monotonic() > deadline:
                raise GripperFault(
                    f"{self._where}: the fingers did not stop within {timeout_s:.1f} s of "
                    f"moving to position {position}"
                )
            time.sleep(POLL_S)

    def _width_mm(self, position: int) -> float:
        return self._config.stroke_mm * (1.0 - position / CLOSED)

    def _check_fault(self) -> None:
        code = self._get("FLT")
        if code != 0:
            raise GripperFault(
                f"{self._where} reports fault {fault_text(code)}; clear the cause, then "
                "reset and reactivate the gripper"
            )

    def _get(self, name: str) -> int:
        reply = self._ask(f"GET {name}")
        words = reply.split()
        if len(words) != 2 or words[0] != name or not words[1].isdigit():
            raise GripperFault(f"{self._where}: GET {name} answered {reply!r}")
        return int(words[1])

    def _set(self, **values: int) -> None:
        request = "SET " + " ".join(f"{name} {value}" for name, value in values.items())
        reply = self._ask(request)
        if reply != "ack":
            raise GripperFault(f"{self._where}: {request} answered {reply!r}, not ack")

    def _ask(self, request: str) -> str:
        """One request and its reply line, within ``timeout_s``; after a failure the connection
        is out of step and refuses every later request."""
        if self._broken is not None:
            raise GripperFault(
                f"{self._where}: {request}: the connection is unusable "
                f"({self._broken}); reconnect the cell"
            )
        try:
            self._sock.sendall((request + "\n").encode("ascii"))
            reply = self._reader.readline()
        except OSError as exc:  # a timeout included
            self._broken = f"no answer to {request!r} within {self._config.timeout_s:g} s ({exc})"
            raise GripperFault(f"{self._where}: {self._broken}: the gripper is silent") from None
        if not reply.endswith("\n"):
            self._broken = "it closed the connection"
            raise GripperFault(f"{self._where}: {request}: {self._broken}")
        return reply.strip()
