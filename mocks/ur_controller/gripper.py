"""A simulated Robotiq 2F-85 behind the Robotiq URCap's ASCII socket (port 63352), and the part
model a test scripts: present with a width, absent, slipping out.

Protocol (as the Robotiq URCap serves it and as drivers use it): one request per line.
`SET VAR value [VAR value ...]` answers `ack`; `GET VAR` answers `VAR value`. Writable: ACT
(activate), GTO (go to the requested position), POS (requested position), SPE (speed), FOR
(force), all 0..255. Read-only: STA (0 reset, 1 activating, 3 active), PRE (echo of the requested
position), OBJ (0 fingers moving, 1 stopped by contact while opening, 2 stopped by contact while
closing, 3 at the requested position: no object, or the object was lost), FLT (fault code, 0 none),
and POS reads the actual finger position. A request the simulator does not know is answered `?`
(what the URCap answers then is not documented).

Register meanings are those of the Robotiq 2F-85/140 instruction manual (gripper status gACT,
gGTO, gSTA, gOBJ, fault status gFLT, position request echo, position). Model choices (assumed,
not from the manual): position 0 is 85 mm between the fingers and 255 is 0 mm, linearly (a real
2F-85 stops at about 3 and 230 after calibration); SPE 0..255 is 20..150 mm/s, the 2F-85's
speed range; activation takes ACTIVATION_S and leaves the fingers open. Times are controller
time, scaled like the arm's (`speed_factor`; `instant` finishes within two cycles).
"""

from __future__ import annotations

import logging
import socket
from collections.abc import Callable
from dataclasses import dataclass

from mocks.ur_controller.net import Listener

log = logging.getLogger("mocks.ur_controller")

ROBOTIQ_PORT = 63352
STROKE_MM = 85.0
MIN_SPEED_MMPS = 20.0
MAX_SPEED_MMPS = 150.0
ACTIVATION_S = 1.0
STA_RESET, STA_ACTIVATING, STA_ACTIVE = 0, 1, 3
OBJ_MOVING, OBJ_CONTACT_OPENING, OBJ_CONTACT_CLOSING, OBJ_AT_POSITION = 0, 1, 2, 3
FLT_ACTIVATION_PENDING = 0x05  # action delayed: the activation must be completed first
FLT_NOT_ACTIVATED = 0x07  # the activation bit must be set prior to action
_WRITABLE = ("ACT", "GTO", "POS", "SPE", "FOR", "ATR", "ADR")
_READABLE = (*_WRITABLE, "STA", "PRE", "OBJ", "FLT")


def position_for_width(width_mm: float) -> float:
    """Finger position (0..255) at which the fingers are `width_mm` apart."""
    return 255.0 * (1.0 - width_mm / STROKE_MM)


@dataclass
class Robotiq2F:
    """State of the simulated gripper; `advance` runs it one control cycle."""

    time_scale: float = 1.0  # the controller's speed factor
    instant: bool = False
    act: int = 0
    gto: int = 0
    requested: int = 0  # POS as written (PRE echoes it)
    speed: int = 255
    force: int = 150
    atr: int = 0
    adr: int = 0
    sta: int = STA_RESET
    position: float = 0.0
    obj: int = OBJ_AT_POSITION
    flt: int = 0
    part_width_mm: float | None = None  # a part between the fingers, or None
    silent: bool = False  # fault gripper-silent: requests get no answer
    _activation_left_s: float = 0.0

    # --- the socket's requests -----------------------------------------------------------------

    def set(self, name: str, value: int) -> None:
        """One `SET name value` (ValueError for an unknown name or a value outside 0..255)."""
        if name not in _WRITABLE or not 0 <= value <= 255:
            raise ValueError(f"SET {name} {value}")
        if name == "ACT":
            self._set_act(value)
        elif name == "GTO":
            self.gto = value  # 0 stops the fingers where they are
            if value:
                self._go()
        else:
            setattr(self, {"POS": "requested", "SPE": "speed", "FOR": "force", "ATR": "atr",
                           "ADR": "adr"}[name], value)
            if name in ("POS", "SPE", "FOR") and self.gto:
                self._go()  # a new request while GTO is set takes effect at once

    def get(self, name: str) -> int:
        if name not in _READABLE:
            raise ValueError(f"GET {name}")
        return {"ACT": self.act, "GTO": self.gto, "POS": round(self.position),
                "SPE": self.speed, "FOR": self.force, "ATR": self.atr, "ADR": self.adr,
                "STA": self.sta, "PRE": self.requested, "OBJ": self.obj,
                "FLT": self.flt}[name]

    def _set_act(self, value: int) -> None:
        self.act = value
        if value == 0:
            self.sta, self.gto, self.obj = STA_RESET, 0, OBJ_AT_POSITION
            self.flt = 0
        elif self.sta == STA_RESET:
            self.sta = STA_ACTIVATING
            self._activation_left_s = ACTIVATION_S

    def _go(self) -> None:
        if self.sta == STA_RESET:
            self.flt = FLT_NOT_ACTIVATED
        elif self.sta == STA_ACTIVATING:
            self.flt = FLT_ACTIVATION_PENDING
        elif self.flt == 0:
            self.obj = OBJ_MOVING

    # --- the part ------------------------------------------------------------------------------

    def drop_part(self) -> None:
        """The part slips out: fingers holding it close on to the requested position."""
        self.part_width_mm = None
        if self.obj == OBJ_CONTACT_CLOSING and self.gto:
            self.obj = OBJ_MOVING

    # --- one control cycle ---------------------------------------------------------------------

    def advance(self, dt_s: float) -> None:
        if self.sta == STA_ACTIVATING:
            self._activation_left_s -= ACTIVATION_S / 2 if self.instant else dt_s * self.time_scale
            if self._activation_left_s <= 0.0:
                self.sta, self.position, self.obj = STA_ACTIVE, 0.0, OBJ_AT_POSITION
                if self.flt == FLT_ACTIVATION_PENDING:
                    self.flt = 0
            return
        if self.obj != OBJ_MOVING or not self.gto or self.flt:
            return
        target = float(self.requested)
        contact = None if self.part_width_mm is None else position_for_width(self.part_width_mm)
        closing = target > self.position
        if closing and contact is not None and self.position <= contact < target:
            target = contact
        counts_per_s = (MIN_SPEED_MMPS + (MAX_SPEED_MMPS - MIN_SPEED_MMPS) * self.speed / 255.0
                        ) * 255.0 / STROKE_MM
        step = 255.0 if self.instant else counts_per_s * dt_s * self.time_scale
        if abs(target - self.position) <= step:
            self.position = target
            if target == float(self.requested):
                self.obj = OBJ_AT_POSITION
            else:
                self.obj = OBJ_CONTACT_CLOSING
        else:
            self.position += step if target > self.position else -step

    def holding(self) -> bool:
        """Fingers closed on the part."""
        return self.part_width_mm is not None and self.obj == OBJ_CONTACT_CLOSING


class RobotiqServer:
    """Serves the URCap's ASCII protocol on (host, 63352): each request line goes to
    `gripper_request` (the controller's, which holds its lock around `answer`), whose reply,
    unless None, goes back."""

    def __init__(self, host: str, gripper_request: Callable[[str], str | None]):
        self._gripper_request = gripper_request
        self.listener = Listener(host, ROBOTIQ_PORT, "robotiq", self._serve)

    def _serve(self, sock: socket.socket) -> None:
        with sock.makefile("r", encoding="ascii", errors="replace", newline="\n") as reader:
            for line in reader:
                reply = self._gripper_request(line.strip())
                if reply is not None:
                    sock.sendall((reply + "\n").encode("ascii"))


def answer(gripper: Robotiq2F, request: str) -> str | None:
    """The reply line to one request, or None when the gripper is silent (fault)."""
    if gripper.silent:
        return None
    words = request.split()
    try:
        if len(words) == 2 and words[0] == "GET":
            return f"{words[1]} {gripper.get(words[1])}"
        if len(words) >= 3 and words[0] == "SET" and len(words) % 2 == 1:
            pairs = [(words[i], int(words[i + 1])) for i in range(1, len(words), 2)]
            for name, value in pairs:
                gripper.set(name, value)
            return "ack"
    except ValueError as exc:
        log.warning("robotiq: refusing %r (%s)", request, exc)
    return "?"
