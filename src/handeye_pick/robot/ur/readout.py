"""Read a UR controller without taking it over: what ``status`` shows.

ur_rtde's control interface uploads its own program when it connects, which stops whatever the
controller was running (a pendant program, or another handeye-pick session mid-pick) and leaves
``rtde_control`` as the controller's program. A status check must leave the controller as it
found it, so this module sends no program and writes nothing: one RTDE output package and a few
dashboard queries (robot/ur/dashboard.py), both plain sockets with bounded waits.

It speaks RTDE itself rather than through ``rtde_receive``: ur_rtde 1.6.5's receive interface
cannot read ``tcp_offset`` (its type map lacks the field), and only the control interface can
ask for the TCP offset. The subset used is UR's RTDE guide, protocol version 2: request the
protocol version, set up one output recipe, start, read one data package, close. An RTDE output
connection claims no inputs, so it is allowed next to a running session.

While ur_rtde's control script runs, one more short connection asks whether a live client still
drives it: it sets up ur_rtde's command register as an input (``I``) and closes. ``IN_USE``: a
client holds it (a pick would be refused at connect); otherwise the register was free and the
script is left over, and the claim lasted only until the close (nothing is ever written to it).

Frames and units as in robot/port.py: ``T_base_tcp`` is ``actual_TCP_pose`` (includes the active
TCP offset), ``T_flange_tcp`` is ``tcp_offset``, both from the same controller cycle, so
``T_base_flange = T_base_tcp @ inv(T_flange_tcp)`` is consistent.
"""

from __future__ import annotations

import contextlib
import math
import socket
import struct
import time
from collections.abc import Iterator
from dataclasses import dataclass, replace

from handeye_pick.errors import RobotConnectionError
from handeye_pick.geometry import Transform, invert, ur_pose_to_matrix
from handeye_pick.robot.port import RobotStatus, RuntimeState
from handeye_pick.robot.ur.dashboard import DASHBOARD_PORT, Dashboard

RTDE_PORT = 30004
TIMEOUT_S = 2.0
"""Every connect, request and reply gets this long; a controller that answers nothing in 2 s is
not one to judge (RTDE streams at 125 or 500 Hz, the dashboard answers in milliseconds)."""
FREQUENCY_HZ = 25.0
"""Output rate asked for: one package is read, so the first one arrives within 40 ms. Valid on
CB3 (at most 125 Hz) and e-Series (500 Hz)."""

CONTROL_SCRIPT = "rtde_control"
"""The program name ``programState`` gives ur_rtde's control script while it runs (``PLAYING
rtde_control``): the name of the script's top-level ``def``, as the simulator names a program
received on the script port (docs/field-experience.md, "A control script left playing", says
what is not known of a real controller's answer)."""
COMMAND_REGISTER = "input_int_register_0"
"""ur_rtde's command register (handeye-pick never uses the upper range): its control interface
claims it, with the other input registers, for as long as it is connected."""

_PROTOCOL_VERSION = 2
_REQUEST_PROTOCOL_VERSION = ord("V")
_GET_URCONTROL_VERSION = ord("v")
_SETUP_OUTPUTS = ord("O")
_SETUP_INPUTS = ord("I")
_START = ord("S")
_DATA_PACKAGE = ord("U")
_HEADER = struct.Struct(">HB")  # package size including the header, package type

# The fields read and their RTDE types (UR's RTDE guide).
_FIELDS: tuple[tuple[str, str], ...] = (
    ("timestamp", "DOUBLE"),
    ("actual_TCP_pose", "VECTOR6D"),
    ("robot_mode", "INT32"),
    ("safety_mode", "INT32"),
    ("safety_status_bits", "UINT32"),
    ("runtime_state", "UINT32"),
    ("tcp_offset", "VECTOR6D"),
    ("actual_digital_input_bits", "UINT64"),
)
_OPTIONAL = ("tcp_offset",)
"""Served from PolyScope 3.12.3 / 5.5.1 only; an older controller answers NOT_FOUND."""
_FORMATS = {"DOUBLE": "d", "VECTOR6D": "6d", "INT32": "i", "UINT32": "I", "UINT64": "Q"}
_PROTECTIVE_STOPPED_BIT = 2
_EMERGENCY_STOPPED_BIT = 7
"""``safety_status_bits``: bit 2 is protective stopped, bit 7 emergency stopped (either kind)."""


@dataclass(frozen=True)
class ControllerReadout:
    """One look at the controller from outside.

    ``program_state`` is the dashboard's ``programState`` answer (``STOPPED pick.urp``,
    ``PLAYING rtde_control``), ``loaded_program`` its ``get loaded program`` path or None.
    ``T_flange_tcp`` is None when the controller does not serve ``tcp_offset`` over RTDE.
    ``dashboard_problem`` says why the dashboard could not be asked (PolyScope X has no dashboard
    server); the RTDE part is then all there is, with ``remote_control`` not applicable (True).
    ``command_register_held``: whether a live RTDE client holds ``COMMAND_REGISTER``, asked only
    while ur_rtde's control script runs (None otherwise).
    """

    status: RobotStatus
    T_base_tcp: Transform
    T_flange_tcp: Transform | None
    program_state: str | None
    loaded_program: str | None
    dashboard_problem: str | None
    command_register_held: bool | None = None
    digital_input_bits: int = 0  # standard inputs bits 0-7, configurable 8-15, tool 16-17

    @property
    def T_base_flange(self) -> Transform | None:
        """``T_base_tcp @ inv(T_flange_tcp)`` (m), both from the same cycle; None without
        ``tcp_offset``."""
        if self.T_flange_tcp is None:
            return None
        return self.T_base_tcp @ invert(self.T_flange_tcp)

    @property
    def program_running(self) -> bool:
        """Whether a program runs or is paused: a pick would stop it to start its own."""
        return self.status.runtime_state != RuntimeState.STOPPED

    @property
    def control_script_running(self) -> bool:
        """Whether the running program is ur_rtde's control script (``CONTROL_SCRIPT``), not an
        operator's: False when the dashboard did not say."""
        words = (self.program_state or "").split(maxsplit=1)
        return self.program_running and words[1:] == [CONTROL_SCRIPT]


def read_controller(host: str) -> ControllerReadout:
    """Read ``host`` once over RTDE and the dashboard; sends no program and no command.

    Raises ``RobotConnectionError`` naming the port when the RTDE socket fails or a reply does
    not follow the protocol; a dashboard that does not answer is a ``dashboard_problem``.
    """
    values, version = _read_rtde(host)
    remote, program_state, loaded, dashboard_problem = True, None, None, None
    try:
        remote, program_state, loaded = _ask_dashboard(host, version)
    except RobotConnectionError as exc:
        dashboard_problem = str(exc)
    bits = int(values["safety_status_bits"][0])
    status = RobotStatus(
        controller_version=".".join(str(part) for part in version),
        robot_mode=int(values["robot_mode"][0]),
        safety_mode=int(values["safety_mode"][0]),
        runtime_state=int(values["runtime_state"][0]),
        remote_control=remote,
        protective_stopped=bool(bits >> _PROTECTIVE_STOPPED_BIT & 1),
        emergency_stopped=bool(bits >> _EMERGENCY_STOPPED_BIT & 1),
    )
    offset = values.get("tcp_offset")
    readout = ControllerReadout(
        status=status,
        T_base_tcp=ur_pose_to_matrix(list(values["actual_TCP_pose"])),
        T_flange_tcp=None if offset is None else ur_pose_to_matrix(list(offset)),
        program_state=program_state,
        loaded_program=loaded,
        dashboard_problem=dashboard_problem,
        digital_input_bits=int(values["actual_digital_input_bits"][0]),
    )
    if not readout.control_script_running:
        return readout
    return replace(readout, command_register_held=_command_register_held(host))


def read_digital_inputs(host: str) -> int:
    """``actual_digital_input_bits`` of one RTDE package read from outside (no dashboard, no
    program): the line's handshake while the session has no link (``handeye_pick.line.io``)."""
    values, _ = _read_rtde(host)
    return int(values["actual_digital_input_bits"][0])


@contextlib.contextmanager
def _rtde(host: str) -> Iterator[socket.socket]:
    """An RTDE connection that speaks protocol version 2, closed on leaving; a socket failure or
    a reply off the protocol is a ``RobotConnectionError`` naming the port."""
    try:
        with socket.create_connection((host, RTDE_PORT), timeout=TIMEOUT_S) as sock:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            _request(sock, _REQUEST_PROTOCOL_VERSION, struct.pack(">H", _PROTOCOL_VERSION))
            if _reply(sock, _REQUEST_PROTOCOL_VERSION)[:1] != b"\x01":
                raise _Protocol(f"the controller refused RTDE protocol {_PROTOCOL_VERSION}")
            yield sock
    except (OSError, _Protocol, struct.error) as exc:
        raise RobotConnectionError(
            f"cell {host}: could not read RTDE port {RTDE_PORT} ({exc or type(exc).__name__}): "
            "check the address, the network cable and that the controller is booted"
        ) from exc


def _command_register_held(host: str) -> bool:
    """Whether another RTDE client holds ``COMMAND_REGISTER``: asked as an input recipe on a
    connection of its own, closed at once (no start, nothing sent to the register)."""
    with _rtde(host) as sock:
        _request(sock, _SETUP_INPUTS, COMMAND_REGISTER.encode("ascii"))
        return _reply(sock, _SETUP_INPUTS)[1:] == b"IN_USE"


def _read_rtde(host: str) -> tuple[dict[str, tuple[float, ...]], tuple[int, ...]]:
    """The fields of one RTDE data package, by name (a scalar as a 1-tuple), and the controller
    version (major, minor, bugfix, build)."""
    with _rtde(host) as sock:
        _request(sock, _GET_URCONTROL_VERSION, b"")
        version = struct.unpack(">4I", _reply(sock, _GET_URCONTROL_VERSION))
        names = [name for name, _ in _FIELDS]
        recipe_id, types = _setup_outputs(sock, names)
        missing = [name for name, kind in zip(names, types, strict=True) if kind == "NOT_FOUND"]
        if missing and set(missing) <= set(_OPTIONAL):
            names = [name for name in names if name not in missing]
            recipe_id, types = _setup_outputs(sock, names)
        expected = dict(_FIELDS)
        if recipe_id == 0 or types != [expected[name] for name in names]:
            raise _Protocol(f"output recipe for {names} answered with types {types}")
        _request(sock, _START, b"")
        if _reply(sock, _START)[:1] != b"\x01":
            raise _Protocol("the controller refused to start the RTDE output")
        return _unpack(_reply(sock, _DATA_PACKAGE), recipe_id, names, types), version


def _setup_outputs(sock: socket.socket, names: list[str]) -> tuple[int, list[str]]:
    payload = struct.pack(">d", FREQUENCY_HZ) + ",".join(names).encode("ascii")
    _request(sock, _SETUP_OUTPUTS, payload)
    reply = _reply(sock, _SETUP_OUTPUTS)
    types = reply[1:].decode("ascii", errors="replace").split(",")
    if not reply or len(types) != len(names):
        raise _Protocol(f"output setup for {len(names)} fields answered {reply[1:80]!r}")
    return reply[0], types


def _unpack(
    payload: bytes, recipe_id: int, names: list[str], types: list[str]
) -> dict[str, tuple[float, ...]]:
    layout = struct.Struct(">B" + "".join(_FORMATS[kind] for kind in types))
    if len(payload) != layout.size or payload[0] != recipe_id:
        raise _Protocol(f"data package of {len(payload)} bytes, expected {layout.size}")
    flat = layout.unpack(payload)[1:]
    values: dict[str, tuple[float, ...]] = {}
    at = 0
    for name, kind in zip(names, types, strict=True):
        width = 6 if kind == "VECTOR6D" else 1
        values[name] = tuple(float(v) for v in flat[at : at + width])
        if not all(math.isfinite(v) for v in values[name]):
            raise _Protocol(f"{name} is not finite: {values[name]}")
        at += width
    return values


def _request(sock: socket.socket, package_type: int, payload: bytes) -> None:
    sock.sendall(_HEADER.pack(_HEADER.size + len(payload), package_type) + payload)


def _reply(sock: socket.socket, package_type: int) -> bytes:
    """The payload of the next package of ``package_type``; packages of other types (text
    messages the controller may send at any time) are skipped, for at most ``TIMEOUT_S``."""
    deadline = time.monotonic() + TIMEOUT_S
    while time.monotonic() < deadline:
        size, kind = _HEADER.unpack(_receive(sock, _HEADER.size))
        if size < _HEADER.size:
            raise _Protocol(f"package size {size} is shorter than its header")
        payload = _receive(sock, size - _HEADER.size)
        if kind == package_type:
            return payload
    raise _Protocol(f"no {chr(package_type)!r} package within {TIMEOUT_S} s")


def _receive(sock: socket.socket, count: int) -> bytes:
    data = bytearray()
    while len(data) < count:
        chunk = sock.recv(count - len(data))
        if not chunk:
            raise _Protocol("the controller closed the connection")
        data += chunk
    return bytes(data)


def _ask_dashboard(host: str, version: tuple[int, ...]) -> tuple[bool, str, str | None]:
    """Remote control (True where there is none to be in; ``version`` is the one RTDE reported),
    ``programState`` and the loaded program's path."""
    try:
        with Dashboard(host, TIMEOUT_S) as dashboard:
            remote = dashboard.in_remote_control(version)
            program_state = dashboard.ask("programState")
            loaded = dashboard.ask("get loaded program")
    except OSError as exc:
        raise RobotConnectionError(
            f"cell {host}: the dashboard server (port {DASHBOARD_PORT}) does not answer "
            f"({exc or type(exc).__name__}); PolyScope X has none"
        ) from exc
    prefix = "loaded program:"
    return (
        remote,
        program_state,
        loaded[len(prefix) :].strip() if loaded.lower().startswith(prefix) else None,
    )


class _Protocol(Exception):
    """A reply that does not follow the protocol."""
