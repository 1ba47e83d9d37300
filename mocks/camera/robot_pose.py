"""The robot's flange pose for a capture process of its own: a minimal RTDE reader.

The capture command (``python -m mocks.camera object-pose``) runs as a separate program, as an
integrator's capture program would, so it cannot ask ``SimulatedController.snapshot()`` (only the
process that started the controller can). It reads ``actual_q`` from the controller's RTDE port
instead, with the few bytes of RTDE v2 it needs, and turns the joints into ``T_base_flange`` with
the simulator's own forward kinematics: the same model the controller moves the arm with, so the
camera sits exactly where the simulated arm carries it, whatever TCP offset is active.

Why not ur_rtde's ``rtde_receive``: it is a heavier client that can reconnect and loop in 1.6.5,
and the reading needs only one output recipe and one data package. An extra RTDE output
connection does not disturb handeye-pick's own connections (outputs are not claimed).
"""

from __future__ import annotations

import socket
import struct

import numpy as np

from mocks.camera.frames import Matrix
from mocks.ur_controller.kinematics import MODELS, forward

RTDE_PORT = 30004
_PROTOCOL_VERSION = 2
_FREQUENCY_HZ = 125.0


def _send(sock: socket.socket, kind: bytes, payload: bytes) -> None:
    sock.sendall(struct.pack(">HB", len(payload) + 3, kind[0]) + payload)


def _receive_exactly(sock: socket.socket, size: int) -> bytes:
    data = b""
    while len(data) < size:
        chunk = sock.recv(size - len(data))
        if not chunk:
            raise ConnectionError("the controller closed the RTDE connection")
        data += chunk
    return data


def _receive(sock: socket.socket) -> tuple[bytes, bytes]:
    """One RTDE package: (type byte, payload)."""
    size, kind = struct.unpack(">HB", _receive_exactly(sock, 3))
    return bytes([kind]), _receive_exactly(sock, size - 3)


def _reply(sock: socket.socket, kind: bytes) -> bytes:
    """The payload of the next package of ``kind`` (a text message may come first)."""
    while True:
        got, payload = _receive(sock)
        if got == kind:
            return payload


def read_actual_q(host: str, timeout_s: float = 5.0) -> tuple[float, ...]:
    """The joint angles (rad) in one RTDE data package from ``host``:30004.

    Raises OSError (ConnectionError, timeout) when the controller cannot be read.
    """
    with socket.create_connection((host, RTDE_PORT), timeout=timeout_s) as sock:
        _send(sock, b"V", struct.pack(">H", _PROTOCOL_VERSION))
        if _reply(sock, b"V")[:1] != b"\x01":
            raise ConnectionError(f"{host}: the controller refused RTDE protocol version 2")
        _send(sock, b"O", struct.pack(">d", _FREQUENCY_HZ) + b"actual_q")
        types = _reply(sock, b"O")[1:].decode("ascii")
        if types != "VECTOR6D":
            raise ConnectionError(f"{host}: RTDE output actual_q answered {types!r}")
        _send(sock, b"S", b"")
        if _reply(sock, b"S")[:1] != b"\x01":
            raise ConnectionError(f"{host}: the controller refused to start the RTDE stream")
        payload = _reply(sock, b"U")
    return struct.unpack_from(">6d", payload, 1)  # after the recipe id byte


def read_flange_pose(host: str, model: str = "ur5e", timeout_s: float = 5.0) -> Matrix:
    """``T_base_flange`` (float64 4x4, m) of the simulated arm on ``host`` (model as the
    controller's ``--model``), from its joints and the simulator's forward kinematics."""
    if model not in MODELS:
        raise ValueError(f"unknown robot model {model!r} (known: {sorted(MODELS)})")
    T_base_flange: Matrix = forward(MODELS[model], np.array(read_actual_q(host, timeout_s)))
    return T_base_flange
