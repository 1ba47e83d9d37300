"""SimulatedController: the simulated UR controller in a child process, driven from Python.

ur_rtde 1.6.5's constructors hold the GIL while they wait for the controller's replies, so a
server thread in the test's own process could never answer them. The controller therefore runs
as `python -m mocks.ur_controller --serve-stdio` in a child process; this class starts it, waits
for its `ready` line and forwards inject/snapshot/commands requests as JSON lines on its stdin.
"""

from __future__ import annotations

import contextlib
import json
import os
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any

from mocks.ur_controller.options import EXIT_CANNOT_LISTEN, ControllerOptions, to_argv
from mocks.ur_controller.snapshot import ControllerSnapshot

# The folder holding the `mocks` package (the repository, or site-packages once installed).
_IMPORT_ROOT = Path(__file__).resolve().parents[2]
_START_TIMEOUT_S = 30.0


class SimulatedController:
    """A simulated UR controller on `host`; a context manager (start on enter, stop on exit).

    Keyword arguments are ControllerOptions' fields, those of the command line (see README.md):
    poses are UR vectors (m, rad), joints in rad, `tcp_offset` is T_flange_tcp, `inject` holds
    `FAULT@WHEN` specs, `profile` is a name in profiles.py (default e-series), `tracking` adds
    tracking lag and measurement noise, `part_width_mm` puts a part at the gripper,
    `feedback_input` is (output bit, input bit). An unknown name is a TypeError here; options
    that do not fit together are refused by the child, at start(). `log_path`: the child's log
    (its stderr) is appended to this file instead of going to this process's stderr.

    The child runs in a session of its own: a Ctrl-C at the terminal reaches the client, never
    the controller, as with a real robot; stop() ends it, and so does this process's end (its
    stdin closes).
    """

    def __init__(self, host: str = "127.0.0.1", log_path: str | Path | None = None,
                 **options: Any):
        controller_options = ControllerOptions(host=host, **options)
        self.host = host
        self.profile = controller_options.profile
        self._argv = to_argv(controller_options)
        self._log_path = log_path
        self._why = "its stderr says why" if log_path is None else f"{log_path} says why"
        self._process: subprocess.Popen[str] | None = None
        self._lock = threading.Lock()

    # --- lifetime ---------------------------------------------------------------------------

    def start(self) -> SimulatedController:
        """Start the child process; returns once 30004, 29999 and 30003 listen.

        Raises OSError when a port cannot be bound (taken, or the address is not local) and
        RuntimeError for anything else that keeps the controller from starting.
        """
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(_IMPORT_ROOT),
                                                          env.get("PYTHONPATH")]))
        with (contextlib.nullcontext() if self._log_path is None  # the child keeps a copy
              else Path(self._log_path).open("a", encoding="utf-8")) as log:
            process = subprocess.Popen(
                [sys.executable, "-m", "mocks.ur_controller", "--serve-stdio", *self._argv],
                stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=log, text=True, env=env,
                start_new_session=True,
            )
        self._process = process
        first_line = self._read_line(_START_TIMEOUT_S)
        if not first_line.startswith("ready"):
            code = process.wait(timeout=5.0)
            self._process = None
            if code == EXIT_CANNOT_LISTEN:
                raise OSError(f"simulated controller cannot listen on {self.host} "
                              f"({self._why})")
            raise RuntimeError(f"simulated controller on {self.host} did not start: exit code "
                               f"{code}, output {first_line!r} ({self._why})")
        return self

    def stop(self) -> None:
        """Stop the child process (SIGTERM, then SIGKILL after 5 s)."""
        process, self._process = self._process, None
        if process is None:
            return
        process.terminate()
        try:
            process.wait(timeout=5.0)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
        for stream in (process.stdin, process.stdout):
            if stream is not None:
                stream.close()

    def __enter__(self) -> SimulatedController:
        return self.start()

    def __exit__(self, *exc_info: object) -> None:
        self.stop()


    # --- requests ---------------------------------------------------------------------------

    def inject(self, spec: str) -> None:
        """Inject a fault `FAULT@WHEN` (`@now` implied); ValueError for a bad spec."""
        self._request({"op": "inject", "spec": spec})

    @property
    def commands(self) -> list[dict[str, Any]]:
        """Copy of the command record: one dict per motion, stop or payload command, in order."""
        result: list[dict[str, Any]] = self._request({"op": "commands"})
        return result

    @property
    def motions(self) -> list[dict[str, Any]]:
        """Copy of the motion record: one dict per ended motion (controller time moving)."""
        result: list[dict[str, Any]] = self._request({"op": "motions"})
        return result

    def snapshot(self) -> ControllerSnapshot:
        """The controller's state now (see ControllerSnapshot for fields and units)."""
        fields: dict[str, Any] = {
            key: tuple(value) if isinstance(value, list) else value
            for key, value in self._request({"op": "snapshot"}).items()
        }
        return ControllerSnapshot(**fields)

    def set_part(self, width_mm: float | None) -> None:
        """Script the part at the gripper: present with this width (mm), or absent (None).
        A part slipping out at a given moment: inject `gripper-drop@move:K:FRACTION`."""
        self._request({"op": "set_part", "width_mm": width_mm})

    def set_inputs(self, inputs: dict[int, bool]) -> None:
        """Drive standard digital inputs 0-7 as a PLC wired to the control box would; what the
        cell shows the PLC is ``snapshot().standard_digital_out``."""
        self._request({"op": "set_inputs", "inputs": {str(b): v for b, v in inputs.items()}})

    def set_remote_control(self, enabled: bool) -> None:
        """Switch remote/local control as on the pendant (e-series profile only)."""
        self._request({"op": "set_remote_control", "enabled": enabled})

    def _request(self, request: dict[str, Any]) -> Any:
        with self._lock:
            process = self._process
            if process is None or process.stdin is None:
                raise RuntimeError(f"simulated controller on {self.host} is not running")
            process.stdin.write(json.dumps(request) + "\n")
            process.stdin.flush()
            reply = json.loads(self._read_line(10.0))
        if not reply["ok"]:
            raise ValueError(reply["error"])
        return reply["result"]

    def _read_line(self, timeout_s: float) -> str:
        """One line of the child's stdout; RuntimeError if none comes within timeout_s."""
        process = self._process
        stdout = None if process is None else process.stdout
        if stdout is None:
            raise RuntimeError(f"simulated controller on {self.host} is not running")
        lines: list[str] = []
        reader = threading.Thread(target=lambda: lines.append(stdout.readline()), daemon=True)
        reader.start()
        reader.join(timeout_s)
        if not lines:
            raise RuntimeError(f"simulated controller on {self.host}: no answer within "
                               f"{timeout_s} s")
        return lines[0]

