"""The RTDE server's data stream follows the control loop: one package right after each due cycle.

The server runs in this process against a stub backend whose outputs carry the number of the
last published cycle in `timestamp`, so every package says which cycle it came from. Cycles are
published by hand (`cycle_done`), as the control loop does after each publish.
"""

from __future__ import annotations

import socket
import struct
import time
from collections.abc import Iterator, Mapping

import pytest

from mocks.ur_controller.net import recv_exactly
from mocks.ur_controller.rtde import RTDE_PORT, RtdeServer
from tests.conftest import next_loopback_host


class CycleCounter:
    """RtdeBackend stub: `timestamp` is the number of cycles published so far."""

    def __init__(self) -> None:
        self.cycles = 0

    def latest_outputs(self) -> Mapping[str, object]:
        return {"timestamp": float(self.cycles)}

    def write_inputs(self, values: Mapping[str, object]) -> None:
        pass

    def take_refused_start(self) -> bool:
        return False

    def stream_stalled(self) -> bool:
        return False


Served = tuple[RtdeServer, CycleCounter, str]


@pytest.fixture
def served() -> Iterator[Served]:
    backend = CycleCounter()
    for _ in range(20):  # another test session may hold an address: move on
        server = RtdeServer(next_loopback_host(), backend)
        try:
            server.listener.start()
        except OSError:
            continue
        yield server, backend, server.listener.host
        server.listener.close()
        return
    pytest.fail("RtdeServer: no free loopback address after 20 tries")


def publish(server: RtdeServer, backend: CycleCounter) -> None:
    """One control cycle: new outputs, then the senders are woken."""
    backend.cycles += 1
    server.cycle_done()


def _read(sock: socket.socket) -> tuple[int, bytes]:
    size, kind = struct.unpack(">HB", recv_exactly(sock, 3))
    return kind, recv_exactly(sock, size - 3)


def subscribe(host: str, frequency_hz: float) -> socket.socket:
    """A raw RTDE client streaming `timestamp` at `frequency_hz`."""
    sock = socket.create_connection((host, RTDE_PORT), timeout=5.0)  # timeout: hang guard only
    sock.sendall(struct.pack(">HBH", 5, ord("V"), 2))
    _read(sock)
    body = struct.pack(">d", frequency_hz) + b"timestamp"
    sock.sendall(struct.pack(">HB", 3 + len(body), ord("O")) + body)
    _read(sock)
    sock.sendall(struct.pack(">HB", 3, ord("S")))
    assert _read(sock) == (ord("S"), b"\x01")
    return sock


def next_cycle_number(sock: socket.socket) -> int:
    kind, body = _read(sock)
    assert kind == ord("U")
    recipe_id, timestamp = struct.unpack(">Bd", body)
    assert recipe_id == 1
    return int(timestamp)


def test_500_hz_client_gets_each_cycle_right_after_it(served: Served) -> None:
    server, backend, host = served
    with subscribe(host, 500.0) as sock:
        for cycle in range(1, 21):
            publish(server, backend)
            assert next_cycle_number(sock) == cycle
            time.sleep(0.01)  # a sender on its own timer would send a stale package meanwhile


def test_125_hz_client_gets_every_fourth_cycle(served: Served) -> None:
    server, backend, host = served
    with subscribe(host, 125.0) as sock:
        for due in (4, 8, 12):
            for _ in range(3):
                publish(server, backend)
                time.sleep(0.01)  # time for a wrongly woken sender to send: the test can fail
            publish(server, backend)
            assert next_cycle_number(sock) == due


def test_stream_goes_on_when_no_cycle_comes(served: Served) -> None:
    # A starved or blocked control loop slows the stream; it never pauses it (ur_rtde drops a
    # stream after 2.5 s).
    _, _, host = served
    with subscribe(host, 500.0) as sock:
        assert [next_cycle_number(sock) for _ in range(3)] == [0, 0, 0]
