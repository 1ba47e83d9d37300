"""robot/ur/dashboard.py: the one Remote Control rule, PolyScope version text, and the socket
client against peers that answer, refuse or fall silent (the simulated controller is in
tests/integration)."""

from __future__ import annotations

import socket
import threading
from collections.abc import Callable, Iterator

import pytest

from handeye_pick.robot.ur.dashboard import (
    DASHBOARD_PORT,
    Dashboard,
    has_remote_control_command,
    polyscope_version,
    stop_program,
)
from tests.conftest import next_loopback_host

BANNER = b"Connected: Universal Robots Dashboard Server\n"


@pytest.mark.parametrize(
    ("version", "has_it"),
    [
        ((3, 15, 8, 106339), False),  # CB3: no local mode
        ((5, 4, 3, 77771), False),
        ((5, 5, 1, 0), False),
        ((5, 6, 0, 0), True),  # PolyScope 5.6 introduced Remote Control
        ((5, 15, 0, 1234), True),
        ((10, 7, 0, 1234), True),
        (None, True),  # an unreadable version keeps the check: the safe side
    ],
)
def test_remote_control_exists_from_polyscope_5_6(
    version: tuple[int, ...] | None, has_it: bool
) -> None:
    assert has_remote_control_command(version) is has_it


@pytest.mark.parametrize(
    ("text", "version"),
    [
        ("5.4.3.77771", (5, 4, 3, 77771)),  # ur_rtde's polyscopeVersion()
        ("URSoftware 5.15.0.1234 (Jul 12 2023)", (5, 15, 0, 1234)),  # the dashboard's own
        ("3.15.8.106339", (3, 15, 8, 106339)),
        ("Could not understand: 'PolyscopeVersion'", None),
        ("", None),
    ],
)
def test_polyscope_version_from_either_text(text: str, version: tuple[int, ...] | None) -> None:
    assert polyscope_version(text) == version


@pytest.fixture
def dashboard_peer() -> Iterator[Callable[..., str]]:
    """Serve one dashboard connection on a fresh loopback address: send each scripted chunk,
    reading one request line before every chunk after the first, then wait ``then_wait_s`` and
    close; its address."""
    servers: list[socket.socket] = []

    def serve(script: list[bytes], then_wait_s: float = 0.2) -> str:
        host = next_loopback_host()
        server = socket.create_server((host, DASHBOARD_PORT))
        servers.append(server)

        def run() -> None:
            try:
                conn, _ = server.accept()
                with conn, conn.makefile("rb") as requests:
                    for index, chunk in enumerate(script):
                        if index:
                            requests.readline()
                        conn.sendall(chunk)
                    threading.Event().wait(then_wait_s)
            except OSError:
                pass  # the client gave up and closed

        threading.Thread(target=run, daemon=True).start()
        return host

    yield serve
    for server in servers:
        server.close()


def test_stop_confirmed_by_its_answer(dashboard_peer: Callable[..., str]) -> None:
    host = dashboard_peer([BANNER, b"Stopped\n"])
    assert stop_program(host) == (True, "Stopped")


def test_a_refused_stop_is_confirmed_by_program_state(
    dashboard_peer: Callable[..., str],
) -> None:
    host = dashboard_peer([BANNER, b"Failed to execute: stop\n", b"STOPPED pick.urp\n"])
    assert stop_program(host) == (
        True,
        "Failed to execute: stop; programState: STOPPED pick.urp",
    )


def test_a_program_still_playing_is_not_confirmed(
    dashboard_peer: Callable[..., str],
) -> None:
    host = dashboard_peer([BANNER, b"Failed to execute: stop\n", b"PLAYING rtde_control\n"])
    confirmed, reply = stop_program(host)
    assert not confirmed
    assert "PLAYING" in reply


@pytest.mark.parametrize(
    ("script", "message"),
    [([], "no banner"), ([BANNER, b""], "no answer to 'programState'")],
    ids=["closed-before-the-banner", "closed-before-the-answer"],
)
def test_a_peer_that_closes_is_a_connection_error(
    dashboard_peer: Callable[..., str], script: list[bytes], message: str
) -> None:
    host = dashboard_peer(script)
    with pytest.raises(ConnectionError, match=message), Dashboard(host, 2.0) as dashboard:
        dashboard.ask("programState")


def test_a_silent_peer_times_out(dashboard_peer: Callable[..., str]) -> None:
    host = dashboard_peer([BANNER], then_wait_s=10.0)
    with pytest.raises(TimeoutError), Dashboard(host, 0.2) as dashboard:
        dashboard.ask("programState")
