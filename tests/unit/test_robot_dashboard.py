"""robot/ur/dashboard.py: the one Remote Control rule, PolyScope version text, and the socket
client against peers that answer, refuse, fall silent or answer late (the simulated controller
is in tests/integration)."""

from __future__ import annotations

import socket
import threading
from collections.abc import Callable, Iterator

import pytest

from handeye_pick.robot.ur.dashboard import (
    DASHBOARD_PORT,
    Dashboard,
    parse_version,
    stop_program,
)
from tests.conftest import next_loopback_host

BANNER = b"Connected: Universal Robots Dashboard Server\n"


@pytest.mark.parametrize(
    ("text", "version"),
    [
        ("5.4.3.77771", (5, 4, 3, 77771)),
        ("URSoftware 5.15.0.1234 (Jul 12 2023)", (5, 15, 0, 1234)),  # the dashboard's own
        ("3.15.8.106339", (3, 15, 8, 106339)),
        ("Could not understand: 'PolyscopeVersion'", None),
        ("", None),
    ],
)
def test_polyscope_version_from_either_text(text: str, version: tuple[int, ...] | None) -> None:
    assert parse_version(text) == version


@pytest.fixture
def dashboard_peer() -> Iterator[Callable[..., str]]:
    """Serve one dashboard connection on a fresh loopback address: send each scripted chunk,
    reading one request line before every chunk after the first (into ``requests``, when
    given), then wait ``then_wait_s`` and close; its address."""
    servers: list[socket.socket] = []

    def serve(
        script: list[bytes], then_wait_s: float = 0.2, requests: list[bytes] | None = None
    ) -> str:
        server, host = _listen()
        servers.append(server)

        def run() -> None:
            try:
                conn, _ = server.accept()
                with conn, conn.makefile("rb") as lines:
                    for index, chunk in enumerate(script):
                        if index:
                            line = lines.readline()
                            if requests is not None and line:
                                requests.append(line)
                        conn.sendall(chunk)
                    threading.Event().wait(then_wait_s)
            except OSError:
                pass  # the client gave up and closed

        threading.Thread(target=run, daemon=True).start()
        return host

    yield serve
    for server in servers:
        server.close()


def _listen() -> tuple[socket.socket, str]:
    """A listening dashboard port on a free loopback address (another test session on this
    machine may hold one: move on, as tests/conftest.py's start_sim_controller does)."""
    for _ in range(20):
        host = next_loopback_host()
        try:
            return socket.create_server((host, DASHBOARD_PORT)), host
        except OSError:
            continue
    raise RuntimeError("no free 127.0.0.N address for a dashboard peer after 20 tries")


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


@pytest.mark.parametrize(
    "version",
    [(3, 15, 8, 106339), (5, 4, 3, 77771), (5, 5, 1, 0)],
    ids=["cb3", "e-series-5.4", "e-series-5.5.1"],
)
def test_a_controller_older_than_5_6_is_in_remote_control_unasked(
    dashboard_peer: Callable[..., str], version: tuple[int, ...]
) -> None:
    # No Local mode before PolyScope 5.6: any client may command it. Its answer to the question,
    # Could not understand, must not read as "local".
    requests: list[bytes] = []
    host = dashboard_peer(
        [BANNER, b"Could not understand: 'is in remote control'\n"], 0.2, requests
    )
    with Dashboard(host, 2.0) as dashboard:
        assert dashboard.in_remote_control(version) is True
    assert requests == []


@pytest.mark.parametrize(
    ("version", "answer", "remote"),
    [
        ((5, 6, 0, 0), b"true\n", True),  # PolyScope 5.6 introduced Remote Control
        ((5, 15, 0, 1234), b"false\n", False),
        ((10, 7, 0, 1234), b"true\n", True),
        # An unreadable version keeps the question: without the command it reads as local,
        # the safe side.
        (None, b"Could not understand: 'is in remote control'\n", False),
    ],
)
def test_remote_control_is_asked_from_polyscope_5_6(
    dashboard_peer: Callable[..., str],
    version: tuple[int, ...] | None,
    answer: bytes,
    remote: bool,
) -> None:
    requests: list[bytes] = []
    host = dashboard_peer([BANNER, answer], 0.2, requests)
    with Dashboard(host, 2.0) as dashboard:
        assert dashboard.in_remote_control(version) is remote
    assert requests == [b"is in remote control\n"]


def test_the_version_is_asked_once(dashboard_peer: Callable[..., str]) -> None:
    requests: list[bytes] = []
    host = dashboard_peer([BANNER, b"URSoftware 5.15.0.1234 (Jul 12 2023)\n"], 0.2, requests)
    with Dashboard(host, 2.0) as dashboard:
        assert dashboard.polyscope_version() == (5, 15, 0, 1234)
    assert requests == [b"PolyscopeVersion\n"]


def test_an_ask_cut_short_by_ctrl_c_does_not_shift_later_answers(
    dashboard_peer: Callable[..., str], monkeypatch: pytest.MonkeyPatch
) -> None:
    # Ctrl-C after a request left and before its answer was read: that answer is still on its
    # way, and the next ask must read past it, not take it for its own.
    host = dashboard_peer([BANNER, b"true\n", b"STOPPED pick.urp\n"])
    with Dashboard(host, 2.0) as dashboard:
        with monkeypatch.context() as patch:
            patch.setattr(dashboard, "_answer", _interrupt)
            with pytest.raises(KeyboardInterrupt):
                dashboard.ask("is in remote control")
        assert dashboard.ask("programState") == "STOPPED pick.urp"


def _interrupt(command: str) -> str:
    raise KeyboardInterrupt
