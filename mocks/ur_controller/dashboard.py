"""Dashboard server (29999): one `\n`-terminated reply line per request line.

Texts follow PolyScope 5 where ur_rtde checks them (protocol spec section 8): the banner on
accept, `Stopped`, `Starting program`, `Pausing program`, `Protective stop releasing`, a
version with four numbers, a serial number of digits only.
"""

from __future__ import annotations

import socket
from typing import TYPE_CHECKING

from mocks.ur_controller.net import Listener
from mocks.ur_controller.rtde import POLYSCOPE_VERSION

if TYPE_CHECKING:
    from mocks.ur_controller.controller import Controller

DASHBOARD_PORT = 29999
BANNER = "Connected: Universal Robots Dashboard Server"
SERIAL_NUMBER = "20235500001"
ROBOT_MODES = {3: "POWER_OFF", 4: "POWER_ON", 5: "IDLE", 7: "RUNNING"}
SAFETY_MODES = {1: "NORMAL", 3: "PROTECTIVE_STOP", 5: "SAFEGUARD_STOP",
                7: "ROBOT_EMERGENCY_STOP"}
RUNTIME_STATES = {1: "STOPPED", 2: "PLAYING", 4: "PAUSED"}
# Commands a real controller in local control mode refuses.
_REMOTE_ONLY = ("play", "stop", "pause", "power on", "power off", "brake release", "load ",
                "unlock protective stop", "close safety popup", "restart safety", "shutdown")
_LOCAL_MODE_REPLY = "Command is not allowed due to safety reasons. Robot is in local control"


class DashboardServer:
    """Serves the dashboard protocol on (host, 29999) for the controller."""

    def __init__(self, host: str, controller: Controller):
        self._ctl = controller
        self.listener = Listener(host, DASHBOARD_PORT, "dashboard", self._serve)

    def _serve(self, sock: socket.socket) -> None:
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
                sock.sendall((self.answer(request) + "\n").encode())
                if request == "quit":
                    return

    def answer(self, request: str) -> str:
        """The reply line (without newline) to one request line."""
        ctl = self._ctl
        version = ".".join(str(n) for n in POLYSCOPE_VERSION)
        if request.startswith(_REMOTE_ONLY) and not ctl.snapshot().remote_control:
            return _LOCAL_MODE_REPLY
        if request == "PolyscopeVersion":
            return f"URSoftware {version} (Jul 12 2023)"
        if request == "get serial number":
            return SERIAL_NUMBER
        if request == "get robot model":
            return ctl.model_name.upper().removesuffix("E")
        if request == "is in remote control":
            return "true" if ctl.snapshot().remote_control else "false"
        if request == "robotmode":
            return f"Robotmode: {ROBOT_MODES.get(ctl.snapshot().robot_mode, 'UNKNOWN')}"
        if request in ("safetystatus", "safetymode"):
            label = "Safetystatus" if request == "safetystatus" else "Safetymode"
            return f"{label}: {SAFETY_MODES.get(ctl.snapshot().safety_mode, 'UNKNOWN')}"
        if request == "programState":
            state = RUNTIME_STATES.get(ctl.snapshot().runtime_state, "STOPPED")
            return f"{state} {ctl.program_name()}"
        if request == "running":
            return f"Program running: {'true' if ctl.snapshot().program_running else 'false'}"
        if request == "get loaded program":
            return f"Loaded program: {ctl.program_name()}"
        if request == "isProgramSaved":
            return f"True {ctl.program_name()}"
        if request.startswith("load "):
            return f"Loading program: {request[5:]}"
        return self._act(request)

    def _act(self, request: str) -> str:
        ctl = self._ctl
        if request == "stop":
            ctl.stop_program("dashboard stop")
            return "Stopped"
        if request == "pause":
            return "Pausing program" if ctl.pause_program() else "Failed to execute: pause"
        if request == "play":
            return "Starting program" if ctl.resume_program() else "Failed to execute: play"
        if request == "power on":
            return "Powering on" if ctl.power_on() else "Failed to power on"
        if request == "power off":
            ctl.power_off()
            return "Powering off"
        if request == "brake release":
            return "Brake releasing" if ctl.release_brakes() else "Failed to release brakes"
        if request == "unlock protective stop":
            if ctl.unlock_protective_stop():
                return "Protective stop releasing"
            return "Cannot unlock protective stop: the robot is not protective stopped"
        if request == "close safety popup":
            ctl.close_safety_popup()
            return "closing safety popup"
        if request == "restart safety":
            ctl.restart_safety()
            return "Restarting safety"
        if request.startswith("popup "):
            return "showing popup"
        if request == "close popup":
            return "closing popup"
        if request.startswith("addToLog "):
            return "Added log message"
        if request.startswith("setUserRole "):
            return f"Setting user role: {request[12:]}"
        if request == "quit":
            return "Disconnected"
        if request == "shutdown":
            return "Shutting down"
        return f"Could not understand: '{request}'"
