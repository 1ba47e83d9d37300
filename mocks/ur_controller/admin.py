"""The simulator's admin channel: run-time requests (faults, state) to a running controller.

One JSON object per line each way, on TCP port ADMIN_PORT of the controller's own loopback
address (the controller never opens it on any other address). Requests:
`{"op": "inject", "spec": "protective-stop"}`, `{"op": "snapshot"}`, `{"op": "commands"}`,
`{"op": "motions"}`, `{"op": "dashboard"}` (every dashboard connection and its requests),
`{"op": "set_remote_control", "enabled": false}`,
`{"op": "set_part", "width_mm": 40.0}` (null: no part),
`{"op": "set_inputs", "inputs": {"4": true}}` (standard digital inputs 0-7, as a PLC drives
them; the outputs it reads are the snapshot's `standard_digital_out`). Replies:
`{"ok": true, "result": ...}` or `{"ok": false, "error": "one line"}`. SimulatedController sends
the same requests on the child's stdin.
"""

from __future__ import annotations

import json
import socket
from dataclasses import asdict
from typing import Any, Protocol

from mocks.ur_controller.net import Listener
from mocks.ur_controller.snapshot import ControllerSnapshot

ADMIN_PORT = 30999


class AdminBackend(Protocol):
    """What the admin requests read from and do to the controller."""

    @property
    def commands(self) -> list[dict[str, Any]]:
        """A copy of the command record."""

    @property
    def motions(self) -> list[dict[str, Any]]:
        """A copy of the motion record."""

    @property
    def dashboard_connections(self) -> list[dict[str, Any]]:
        """A copy of the dashboard's connection record (dashboard.py)."""

    def snapshot(self) -> ControllerSnapshot:
        """The controller's state now."""

    def inject(self, spec: str) -> None:
        """ValueError for a bad spec."""

    def set_remote_control(self, enabled: bool) -> None:
        """ValueError on a profile without remote control."""

    def set_part(self, width_mm: float | None) -> None:
        """ValueError for a width outside 0..85 mm."""

    def set_inputs(self, inputs: dict[int, bool]) -> None:
        """ValueError for an input outside 0-7."""


def answer(ctl: AdminBackend, request: Any) -> dict[str, Any]:
    """The reply to one decoded request: ok with a result, or not ok with a one-line error."""
    try:
        return {"ok": True, "result": _result(ctl, request)}
    except (ValueError, KeyError, TypeError) as exc:
        return {"ok": False, "error": str(exc) or type(exc).__name__}


def _result(ctl: AdminBackend, request: Any) -> Any:
    if not isinstance(request, dict):
        raise ValueError(f"a request is a JSON object, got {request!r}")
    op = request.get("op")
    if op == "snapshot":
        return asdict(ctl.snapshot())
    if op == "commands":
        return ctl.commands
    if op == "motions":
        return ctl.motions
    if op == "dashboard":
        return ctl.dashboard_connections
    if op == "inject":
        ctl.inject(str(request["spec"]))
        return None
    if op == "set_remote_control":
        ctl.set_remote_control(bool(request["enabled"]))
        return None
    if op == "set_part":
        width = request["width_mm"]
        ctl.set_part(None if width is None else float(width))
        return None
    if op == "set_inputs":
        given = request["inputs"]
        if not isinstance(given, dict):
            raise ValueError('set_inputs: expected "inputs": {"BIT": true|false}')
        ctl.set_inputs({int(bit): bool(value) for bit, value in given.items()})
        return None
    raise ValueError(f"unknown request op {op!r}")


def serve_line(ctl: AdminBackend, line: str) -> str:
    """One request line -> one reply line (no newline)."""
    try:
        request = json.loads(line)
    except ValueError as exc:
        return json.dumps({"ok": False, "error": f"not JSON: {exc}"})
    return json.dumps(answer(ctl, request))


class AdminServer:
    """Serves the admin channel on (host, ADMIN_PORT); host must be a loopback address."""

    def __init__(self, host: str, controller: AdminBackend):
        self._ctl = controller
        self.listener = Listener(host, ADMIN_PORT, "admin", self._serve)

    def _serve(self, sock: socket.socket) -> None:
        with sock.makefile("r", encoding="utf-8", newline="\n") as reader:
            for line in reader:
                sock.sendall((serve_line(self._ctl, line) + "\n").encode())


def request(host: str, message: dict[str, Any], timeout_s: float = 5.0) -> Any:
    """Send one request to the controller on `host`; its result, or ValueError with its error.

    OSError when nothing answers on (host, ADMIN_PORT) within timeout_s.
    """
    with socket.create_connection((host, ADMIN_PORT), timeout=timeout_s) as sock:
        sock.sendall((json.dumps(message) + "\n").encode())
        with sock.makefile("r", encoding="utf-8", newline="\n") as reader:
            line = reader.readline()
    if not line:
        raise OSError(f"the simulated controller on {host} closed the admin channel")
    reply = json.loads(line)
    if not reply["ok"]:
        raise ValueError(reply["error"])
    return reply["result"]
