"""``robot.readout`` against peers that do not follow the protocol: every case ends, within its
bounded waits, in one ``RobotConnectionError`` naming the port; none hangs or raises anything
else. (The well-behaved controller is the simulated one, in tests/integration.)"""

from __future__ import annotations

import socket
import struct
import threading
from collections.abc import Callable, Iterator

import pytest

from handeye_pick.errors import RobotConnectionError
from handeye_pick.robot.ur.readout import RTDE_PORT, read_controller
from tests.conftest import next_loopback_host

Peer = Callable[[socket.socket], None]


def _text_messages_forever(conn: socket.socket) -> None:
    message = b"\x00" + b"chatter"
    package = struct.pack(">HB", 3 + len(message), ord("M")) + message
    while True:
        conn.sendall(package)


def _close_at_once(conn: socket.socket) -> None:
    conn.close()


def _short_size(conn: socket.socket) -> None:
    conn.recv(64)
    conn.sendall(struct.pack(">HB", 1, ord("V")))


def _silence(conn: socket.socket) -> None:
    conn.recv(64)
    threading.Event().wait(10.0)


def _handshake(conn: socket.socket) -> None:
    """Protocol version 2 accepted, version 5.15.0.1234, then the output setup request read."""
    conn.recv(64)
    conn.sendall(struct.pack(">HBB", 4, ord("V"), 1))
    conn.recv(64)
    conn.sendall(struct.pack(">HB4I", 19, ord("v"), 5, 15, 0, 1234))
    conn.recv(512)


def _answer_setup(conn: socket.socket, types: bytes) -> None:
    _handshake(conn)
    conn.sendall(struct.pack(">HB", 3 + len(types), ord("O")) + types)
    threading.Event().wait(10.0)  # the client must not wait for more


def _wrong_types(conn: socket.socket) -> None:
    _answer_setup(conn, b"\x01" + b"BOOL," * 6 + b"BOOL")


def _too_few_types(conn: socket.socket) -> None:
    _answer_setup(conn, b"\x01DOUBLE")


@pytest.fixture
def rtde_peer() -> Iterator[Callable[[Peer], str]]:
    """Serve one RTDE connection on a fresh loopback address with ``peer``; its address."""
    servers: list[socket.socket] = []

    def serve(peer: Peer) -> str:
        host = next_loopback_host()
        server = socket.create_server((host, RTDE_PORT))
        servers.append(server)

        def run() -> None:
            try:
                conn, _ = server.accept()
                with conn:
                    peer(conn)
            except OSError:
                pass  # the client gave up and closed: what the test expects

        threading.Thread(target=run, daemon=True).start()
        return host

    yield serve
    for server in servers:
        server.close()


@pytest.mark.parametrize(
    "peer",
    [_text_messages_forever, _close_at_once, _short_size, _silence, _wrong_types, _too_few_types],
)
def test_a_peer_off_protocol_is_one_connection_error(
    rtde_peer: Callable[[Peer], str], peer: Peer
) -> None:
    host = rtde_peer(peer)
    with pytest.raises(RobotConnectionError, match=f"RTDE port {RTDE_PORT}") as caught:
        read_controller(host)
    if peer in (_wrong_types, _too_few_types):  # refused for what it said, not for silence
        assert "output setup" in str(caught.value) or "recipe" in str(caught.value), caught.value
