"""The simulated dashboard's connection record (admin request ``dashboard``) and its going away
(fault ``dashboard-down``), from plain sockets."""

from __future__ import annotations

import socket
from collections.abc import Callable
from typing import Any

from mocks.ur_controller import SimulatedController, admin
from tests.mock_controller.helpers import wait_for

SimFactory = Callable[..., SimulatedController]
BANNER = b"Connected: Universal Robots Dashboard Server\n"


def _connections(ctl: SimulatedController) -> list[dict[str, Any]]:
    result: list[dict[str, Any]] = admin.request(ctl.host, {"op": "dashboard"})
    return result


def _ask(reader: Any, sock: socket.socket, request: str) -> str:
    sock.sendall(request.encode() + b"\n")
    return str(reader.readline()).strip()


def test_every_connection_and_its_requests_are_recorded_in_order(
    sim_controller: SimFactory,
) -> None:
    ctl = sim_controller(instant=True)
    with (
        socket.create_connection((ctl.host, 29999), timeout=5.0) as first,
        first.makefile("r") as first_reader,
    ):
        assert first_reader.readline() == BANNER.decode()
        assert _ask(first_reader, first, "is in remote control") == "true"
        with (
            socket.create_connection((ctl.host, 29999), timeout=5.0) as second,
            second.makefile("r") as second_reader,
        ):
            second_reader.readline()
            _ask(second_reader, second, "PolyscopeVersion")
        _ask(first_reader, first, "no such command")
        wait_for(lambda: not _connections(ctl)[1]["open"])
        assert _connections(ctl) == [
            {
                "connection": 1,
                "requests": ["is in remote control", "no such command"],
                "open": True,
            },
            {"connection": 2, "requests": ["PolyscopeVersion"], "open": False},
        ]


def test_a_dashboard_that_goes_away_closes_every_connection_for_good(
    sim_controller: SimFactory,
) -> None:
    ctl = sim_controller(instant=True)
    with (
        socket.create_connection((ctl.host, 29999), timeout=5.0) as before,
        before.makefile("r") as reader,
    ):
        reader.readline()
        ctl.inject("dashboard-down")
        assert reader.readline() == ""  # closed by the server
    with (
        socket.create_connection((ctl.host, 29999), timeout=5.0) as after,
        after.makefile("r") as reader,
    ):
        assert reader.readline() == ""  # closed before the banner
    assert [c["requests"] for c in _connections(ctl)] == [[]]  # the one before it, closed
