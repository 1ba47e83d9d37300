"""Script port (30003): a write-only sink for URScript programs.

ur_rtde writes `def rtde_control():` + body + `end\n` in one burst and never reads this socket.
A program is complete when a top-level `end` line arrives (no idle timeout: that would add its
length to every start).
"""

from __future__ import annotations

import logging
import socket
from collections.abc import Callable

from mocks.ur_controller.net import Listener

log = logging.getLogger("mocks.ur_controller")

SCRIPT_PORT = 30003


def complete_program(buffer: str) -> tuple[str, str] | None:
    """Split off the first complete top-level program: (program, rest), or None if incomplete.

    A program runs from a line starting `def ` or `sec ` to the first following line that is
    exactly `end` (URScript indents everything nested inside it).
    """
    lines = buffer.splitlines(keepends=True)
    consumed = 0
    start: int | None = None
    for i, line in enumerate(lines):
        if not line.endswith("\n"):
            return None  # a partial last line: wait for more text
        if start is None and line.startswith(("def ", "sec ")):
            start = i
        elif start is not None and line.rstrip("\r\n") == "end":
            program = "".join(lines[start : i + 1])
            rest = buffer[consumed + len(line) :]
            return program, rest
        consumed += len(line)
    return None


def register_offsets(program: str) -> int:
    """The int register offset ur_rtde injected after `# int register offset` (0 or 24)."""
    marker = "# int register offset\n"
    at = program.find(marker)
    if at < 0:
        return 0
    token = program[at + len(marker) :].split(maxsplit=1)
    return int(token[0]) if token and token[0].isdigit() else 0


class ScriptPort:
    """Accepts programs on (host, 30003) and hands each complete one to `run_program`."""

    def __init__(self, host: str, run_program: Callable[[str], None]):
        self._run_program = run_program
        self.listener = Listener(host, SCRIPT_PORT, "script", self._serve)

    def _serve(self, sock: socket.socket) -> None:
        buffer = ""
        while True:
            chunk = sock.recv(65536)
            if not chunk:
                return
            buffer += chunk.decode("utf-8", errors="replace")
            while (split := complete_program(buffer)) is not None:
                program, buffer = split
                self._run_program(program)
