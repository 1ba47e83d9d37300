"""Dashboard server (29999): one `\n`-terminated reply line per request line.

Commands and reply texts follow UR's dashboard server as UR's own client library encodes it
(Universal_Robots_Client_Library, src/ur/dashboard_client_implementation_g5.cpp: every command
with its reply pattern and the first CB3 and e-Series versions that have it), checked against
what ur_rtde 1.6.5 parses (docs/ur-rtde.md, "Dashboard server"). A command the controller's version
does not have is answered like an unknown one: `Could not understand: '<request>'`.

Every connection and its request lines are recorded, so a test can see who asked what on which
connection (admin request `dashboard`); fault `dashboard-down` makes the server go away.
"""

from __future__ import annotations

import socket
import threading
from typing import Any, Protocol

from mocks.ur_controller.net import Listener
from mocks.ur_controller.profiles import Profile
from mocks.ur_controller.snapshot import ControllerSnapshot

DASHBOARD_PORT = 29999
BANNER = "Connected: Universal Robots Dashboard Server"
SERIAL_NUMBER = "20235500001"
ROBOT_MODES = {3: "POWER_OFF", 4: "POWER_ON", 5: "IDLE", 7: "RUNNING"}
SAFETY_MODES = {1: "NORMAL", 3: "PROTECTIVE_STOP", 5: "SAFEGUARD_STOP",
                7: "ROBOT_EMERGENCY_STOP"}
RUNTIME_STATES = {1: "STOPPED", 2: "PLAYING", 4: "PAUSED"}
USER_ROLES = ("PROGRAMMER", "OPERATOR", "NONE", "LOCKED", "RESTRICTED")
OPERATIONAL_MODES = ("MANUAL", "AUTOMATIC")

Version = tuple[int, int]
# First version (major, minor) on CB3 and on e-Series; None: that line does not have it. A
# command that takes an argument is matched by its first words.
_COMMANDS: dict[str, tuple[Version | None, Version | None]] = {
    "load": ((1, 4), (5, 0)), "play": ((1, 4), (5, 0)), "stop": ((1, 4), (5, 0)),
    "pause": ((1, 4), (5, 0)), "quit": ((1, 4), (5, 0)), "shutdown": ((1, 4), (5, 0)),
    "running": ((1, 6), (5, 0)), "robotmode": ((1, 6), (5, 0)),
    "get loaded program": ((1, 6), (5, 0)), "popup": ((1, 6), (5, 0)),
    "close popup": ((1, 6), (5, 0)), "addToLog": ((1, 8), (5, 0)),
    "isProgramSaved": ((1, 8), (5, 0)), "programState": ((1, 8), (5, 0)),
    "PolyscopeVersion": ((1, 8), (5, 0)), "version": (None, (5, 0)),
    "setUserRole": ((3, 1), None), "getUserRole": ((3, 1), None),
    "set operational mode": (None, (5, 0)), "get operational mode": (None, (5, 6)),
    "clear operational mode": (None, (5, 0)),
    "power on": ((3, 0), (5, 0)), "power off": ((3, 0), (5, 0)),
    "brake release": ((3, 0), (5, 0)), "safetymode": ((3, 0), (5, 0)),
    "safetystatus": (None, (5, 4)), "unlock protective stop": ((3, 1), (5, 0)),
    "close safety popup": ((3, 1), (5, 0)), "load installation": ((3, 2), (5, 0)),
    "restart safety": ((3, 7), (5, 1)), "is in remote control": (None, (5, 6)),
    "get serial number": ((3, 12), (5, 6)), "get robot model": ((3, 12), (5, 6)),
    "saveLog": ((3, 13), (5, 8)),
}
# Commands a controller in local control mode refuses.
_REMOTE_ONLY = ("play", "stop", "pause", "power on", "power off", "brake release", "load",
                "unlock protective stop", "close safety popup", "restart safety", "shutdown",
                "load installation")
_LOCAL_MODE_REPLY = "Command is not allowed due to safety reasons. Robot is in local control"


def command_of(request: str) -> str | None:
    """The command a request line names (the longest one that fits), or None."""
    fitting = [c for c in _COMMANDS if request == c or request.startswith(c + " ")]
    return max(fitting, key=len) if fitting else None


class DashboardBackend(Protocol):
    """What the dashboard server reads from and does to the controller."""

    def snapshot(self) -> ControllerSnapshot:
        """The modes, program state and remote control flag now."""

    def program_name(self) -> str:
        """The running program's name, `<unnamed>` when none runs."""

    def stop_program(self, reason: str) -> None:
        """Stop the running program, if any."""

    def pause_program(self) -> bool:
        """False when no program is playing."""

    def play_program(self, loaded: str) -> bool:
        """Resume a paused program (safety NORMAL), or start `loaded` when none runs."""

    def power_on(self) -> bool:
        """False unless powered off with safety NORMAL."""

    def power_off(self) -> None:
        """Stop the program and power off."""

    def release_brakes(self) -> bool:
        """False unless IDLE."""

    def unlock_protective_stop(self) -> bool:
        """False unless in a protective stop."""

    def close_safety_popup(self) -> None:
        """Acknowledge a safeguard stop."""

    def restart_safety(self) -> None:
        """Clear any safety stop into power off."""


class DashboardServer:
    """Serves the dashboard protocol on (host, 29999) for the controller, as `profile` has it,
    for an arm of `model_name`."""

    def __init__(self, host: str, controller: DashboardBackend, profile: Profile,
                 model_name: str):
        self._ctl = controller
        self._profile = profile
        self._model_name = model_name
        self._version: Version = (profile.version[0], profile.version[1])
        self._loaded_program = ""
        self._user_role = "PROGRAMMER"
        self._operational_mode = "NONE"
        self._record_lock = threading.Lock()
        self._connections: list[dict[str, Any]] = []
        self._gone = False
        self.listener = Listener(host, DASHBOARD_PORT, "dashboard", self._serve)

    def connections(self) -> list[dict[str, Any]]:
        """A copy of the connection record, in the order accepted: `{"connection": N,
        "requests": [request lines in order], "open": bool}`."""
        with self._record_lock:
            return [{**c, "requests": list(c["requests"])} for c in self._connections]

    def go_away(self) -> None:
        """The server goes away (fault `dashboard-down`): every connection is closed, and a new
        one is closed before the banner, for good."""
        with self._record_lock:
            self._gone = True
        self.listener.drop_clients()

    def _serve(self, sock: socket.socket) -> None:
        with self._record_lock:
            if self._gone:
                return
            connection: dict[str, Any] = {
                "connection": len(self._connections) + 1, "requests": [], "open": True}
            self._connections.append(connection)
        try:
            self._converse(sock, connection["requests"])
        finally:
            with self._record_lock:
                connection["open"] = False

    def _converse(self, sock: socket.socket, requests: list[str]) -> None:
        sock.sendall((BANNER + "\n").encode())
        buffer = b""
        while True:
            chunk = sock.recv(4096)
            if not chunk:
                return
            buffer += chunk
            while b"\n" in buffer:
                raw, buffer = buffer.split(b"\n", 1)
                request = raw.decode("utf-8", errors="replace").strip()
                with self._record_lock:
                    requests.append(request)
                sock.sendall((self.answer(request) + "\n").encode())
                if request == "quit":
                    return

    def _has(self, command: str) -> bool:
        cb3, e_series = _COMMANDS[command]
        first = cb3 if self._version[0] < 5 else e_series
        return first is not None and self._version >= first

    def answer(self, request: str) -> str:
        """The reply line (without newline) to one request line."""
        command = command_of(request)
        if command is None or not self._has(command):
            return f"Could not understand: '{request}'"
        ctl = self._ctl
        snap = ctl.snapshot()
        argument = request[len(command):].strip()
        if (command in _REMOTE_ONLY and self._profile.remote_control_mode
                and not snap.remote_control):
            return _LOCAL_MODE_REPLY
        if command == "PolyscopeVersion":
            return f"URSoftware {self._profile.version_text} (Jul 12 2023)"
        if command == "version":
            return self._profile.version_text
        if command == "get serial number":
            return SERIAL_NUMBER
        if command == "get robot model":
            return self._model_name.upper().removesuffix("E")
        if command == "is in remote control":
            return "true" if snap.remote_control else "false"
        if command == "robotmode":
            return f"Robotmode: {ROBOT_MODES.get(snap.robot_mode, 'UNKNOWN')}"
        if command in ("safetystatus", "safetymode"):
            label = "Safetystatus" if command == "safetystatus" else "Safetymode"
            return f"{label}: {SAFETY_MODES.get(snap.safety_mode, 'UNKNOWN')}"
        if command == "programState":
            return f"{RUNTIME_STATES.get(snap.runtime_state, 'STOPPED')} {self._program_name()}"
        if command == "running":
            return f"Program running: {'true' if snap.program_running else 'false'}"
        if command == "get loaded program":
            if not self._loaded_program:
                return "No program loaded"
            return f"Loaded program: {self._loaded_program}"
        if command == "isProgramSaved":
            return f"true {self._program_name()}"
        return self._act(command, argument)

    def _program_name(self) -> str:
        running = self._ctl.program_name()
        return running if running != "<unnamed>" or not self._loaded_program else (
            self._loaded_program.rsplit("/", 1)[-1])

    def _act(self, command: str, argument: str) -> str:
        ctl = self._ctl
        if command == "load":
            self._loaded_program = argument
            return f"Loading program: {argument}"
        if command == "load installation":
            return f"Loading installation: {argument}"
        if command == "stop":
            ctl.stop_program("dashboard stop")
            return "Stopped"
        if command == "pause":
            return "Pausing program" if ctl.pause_program() else "Failed to execute: pause"
        if command == "play":
            if ctl.play_program(self._loaded_program):
                return "Starting program"
            return "Failed to execute: play"
        if command == "power on":
            return "Powering on" if ctl.power_on() else "Failed to power on"
        if command == "power off":
            ctl.power_off()
            return "Powering off"
        if command == "brake release":
            return "Brake releasing" if ctl.release_brakes() else "Failed to release brakes"
        if command == "unlock protective stop":
            if ctl.unlock_protective_stop():
                return "Protective stop releasing"
            return "Cannot unlock protective stop: the robot is not protective stopped"
        if command == "close safety popup":
            ctl.close_safety_popup()
            return "closing safety popup"
        if command == "restart safety":
            ctl.restart_safety()
            return "Restarting safety"
        return self._settings(command, argument)

    def _settings(self, command: str, argument: str) -> str:
        if command == "setUserRole":
            if argument.upper() not in USER_ROLES:
                return f"Failed setting user role: {argument}"
            self._user_role = argument.upper()
            return f"Setting user role: {argument}"
        if command == "getUserRole":
            return self._user_role
        if command == "set operational mode":
            if argument.upper() not in OPERATIONAL_MODES:
                return f"Failed to set operational mode: {argument}"
            self._operational_mode = argument.upper()
            return f"Operational mode {self._operational_mode} is set"
        if command == "get operational mode":
            return self._operational_mode
        if command == "clear operational mode":
            self._operational_mode = "NONE"
            return "No longer controlling the operational mode. Current operational mode: NONE"
        return _MESSAGES[command]


_MESSAGES = {"popup": "showing popup", "close popup": "closing popup",
             "addToLog": "Added log message", "saveLog": "Log saved to disk",
             "quit": "Disconnected", "shutdown": "Shutting down"}
