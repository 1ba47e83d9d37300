"""The dashboard server's replies against the reply patterns UR's own client library expects
(Universal_Robots_Client_Library, dashboard_client_implementation_g5.cpp), per controller
version, over a plain socket."""

from __future__ import annotations

import re
import socket
from collections.abc import Callable, Iterator

import pytest

from mocks.ur_controller import SimulatedController
from tests.conftest import start_sim_controller

DASHBOARD_PORT = 29999
NOT_UNDERSTOOD = re.compile(r"Could not understand: '.*'")
# Request -> the reply pattern UR's client library checks (a full match).
E_SERIES_5_15 = {
    "PolyscopeVersion": r"URSoftware 5\.15\.\d+\.\d+ \(.*\)",
    "version": r"5\.15\.\d+\.\d+",
    "get operational mode": r"(NONE|MANUAL|AUTOMATIC)",
    "is in remote control": r"(true|false)",
    "get serial number": r"20\d+",
    "get robot model": r"UR.*",
    "robotmode": r"Robotmode: RUNNING",
    "safetymode": r"Safetymode: NORMAL",
    "safetystatus": r"Safetystatus: NORMAL",
    "programState": r"(STOPPED|PLAYING|PAUSED) .+",
    "running": r"Program running: (true|false)",
    "isProgramSaved": r"(true|false) .*",
    "addToLog hello": r"Added log message",
    "popup hello": r"showing popup",
    "close popup": r"closing popup",
    "close safety popup": r"closing safety popup",
    "load /programs/pick.urp": r"Loading program: .*/programs/pick\.urp.*",
    "get loaded program": r"Loaded program: .*pick\.urp",
    "stop": r"Stopped",
    "set operational mode automatic": r"Operational mode AUTOMATIC is set",
    "clear operational mode": r"No longer controlling the operational mode\..*",
    "saveLog": r"Log saved to disk",
    "getUserRole": NOT_UNDERSTOOD.pattern,  # CB3 only, as UR's client library has it
    "no such command": NOT_UNDERSTOOD.pattern,
}
CB3_3_15 = {
    "PolyscopeVersion": r"URSoftware 3\.15\.\d+\.\d+ \(.*\)",
    "getUserRole": r"(PROGRAMMER|OPERATOR|NONE|LOCKED|RESTRICTED)",
    "setUserRole operator": r"Setting user role: operator",
    "get serial number": r"20\d+",
    "get robot model": r"UR5",
    "safetymode": r"Safetymode: NORMAL",
    "version": NOT_UNDERSTOOD.pattern,  # e-Series commands
    "get operational mode": NOT_UNDERSTOOD.pattern,
    "is in remote control": NOT_UNDERSTOOD.pattern,
    "safetystatus": NOT_UNDERSTOOD.pattern,
}


def ask(host: str, requests: list[str]) -> list[str]:
    """Send each request line on one dashboard connection; the reply lines after the banner."""
    with socket.create_connection((host, DASHBOARD_PORT), timeout=5.0) as sock:
        reader = sock.makefile("r", encoding="utf-8", newline="\n")
        assert reader.readline() == "Connected: Universal Robots Dashboard Server\n"
        replies = []
        for request in requests:
            sock.sendall((request + "\n").encode())
            replies.append(reader.readline().removesuffix("\n"))
    return replies


@pytest.fixture(scope="module")
def e_series() -> Iterator[SimulatedController]:
    controller = start_sim_controller(instant=True)
    yield controller
    controller.stop()


def test_every_e_series_reply_matches_the_documented_pattern(
    e_series: SimulatedController,
) -> None:
    replies = dict(zip(E_SERIES_5_15, ask(e_series.host, list(E_SERIES_5_15)), strict=True))
    wrong = {request: reply for request, reply in replies.items()
             if not re.fullmatch(E_SERIES_5_15[request], reply)}
    assert wrong == {}


def test_operational_mode_is_kept(e_series: SimulatedController) -> None:
    assert ask(e_series.host, ["set operational mode manual", "get operational mode",
                               "clear operational mode", "get operational mode"])[1::2] == [
        "MANUAL", "NONE"]


def test_every_cb3_reply_matches_the_documented_pattern(
    sim_controller: Callable[..., SimulatedController],
) -> None:
    ctl = sim_controller(instant=True, profile="cb3")
    replies = dict(zip(CB3_3_15, ask(ctl.host, list(CB3_3_15)), strict=True))
    wrong = {request: reply for request, reply in replies.items()
             if not re.fullmatch(CB3_3_15[request], reply)}
    assert wrong == {}


def test_polyscope_x_has_no_dashboard_server(
    sim_controller: Callable[..., SimulatedController],
) -> None:
    ctl = sim_controller(instant=True, profile="polyscope-x")
    with pytest.raises(ConnectionRefusedError):
        socket.create_connection((ctl.host, DASHBOARD_PORT), timeout=5.0)
