"""What the soaks share: ``handeye-pick run`` driven through its pipe, the dashboard as an operator
uses it, and /proc figures of the run process and its ur_rtde child.

Used by ``soak.py`` and ``chaos.py``. Every read is bounded by a timeout: a soak never hangs.
"""

from __future__ import annotations

import itertools
import json
import os
import select
import socket
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

REPLY_TIMEOUT_S = 60.0
DASHBOARD_PORT = 29999
WORKER = "worker.py"  # the ur_rtde child's script (src/handeye_pick/robot/ur/worker.py)


class RunEnded(Exception):
    """The run process closed its standard output (it exited or was killed)."""


class Pipe:
    """One ``handeye-pick run`` process: a JSON request line in, its reply line out.

    Request ids come from ``ids`` (shared across run processes when a soak restarts ``run``, so
    every id is unique in the audit file); ``sent`` and ``replies`` keep every request and reply.
    """

    def __init__(self, process: subprocess.Popen[bytes], ids: Iterator[int] | None = None) -> None:
        self.process = process
        self._ids = itertools.count(1) if ids is None else ids
        self._buffer = b""
        self.sent: list[str] = []
        self.replies: list[dict[str, Any]] = []

    def send(self, request: dict[str, Any]) -> str:
        """Write one request with the next id; returns the id."""
        assert self.process.stdin is not None
        rid = str(next(self._ids))
        self.process.stdin.write(json.dumps({"id": rid, **request}).encode() + b"\n")
        self.process.stdin.flush()
        self.sent.append(rid)
        return rid

    def reply(self, timeout_s: float = REPLY_TIMEOUT_S) -> dict[str, Any]:
        """The next reply line; ``RunEnded`` at end of output, ``TimeoutError`` after timeout_s."""
        deadline = time.monotonic() + timeout_s
        while b"\n" not in self._buffer:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError(f"run gave no reply within {timeout_s} s")
            assert self.process.stdout is not None
            ready, _, _ = select.select([self.process.stdout], [], [], left)
            if ready:
                chunk = os.read(self.process.stdout.fileno(), 65536)
                if not chunk:
                    raise RunEnded(f"run ended (exit {self.process.poll()})")
                self._buffer += chunk
        line, self._buffer = self._buffer.split(b"\n", 1)
        reply: dict[str, Any] = json.loads(line)
        self.replies.append(reply)
        return reply

    def ask(self, request: dict[str, Any], timeout_s: float = REPLY_TIMEOUT_S) -> dict[str, Any]:
        """Send ``request`` and read its reply; RuntimeError if the reply names another id."""
        rid = self.send(request)
        reply = self.reply(timeout_s)
        if str(reply.get("id")) != rid:
            raise RuntimeError(f"request {rid} answered by a reply for {reply.get('id')}: {reply}")
        return reply


def dashboard(host: str, *commands: str, timeout_s: float = 5.0) -> list[str]:
    """Send dashboard commands as an operator's tool would; the reply line of each."""
    with socket.create_connection((host, DASHBOARD_PORT), timeout=timeout_s) as connection:
        reader = connection.makefile("r")
        reader.readline()  # the greeting
        replies = []
        for command in commands:
            connection.sendall(command.encode() + b"\n")
            replies.append(reader.readline().strip())
        return replies


def process_figures(pid: int) -> dict[str, int]:
    """Resident memory (KiB), open descriptors and threads of one process, from /proc."""
    status = Path(f"/proc/{pid}/status").read_text()
    fields = dict(line.split(":", 1) for line in status.splitlines() if ":" in line)
    return {
        "rss_kib": int(fields["VmRSS"].split()[0]),
        "fds": len(os.listdir(f"/proc/{pid}/fd")),
        "threads": int(fields["Threads"]),
    }


def children(pid: int) -> list[int]:
    path = Path(f"/proc/{pid}/task/{pid}/children")
    return [int(p) for p in path.read_text().split()] if path.exists() else []


def workers(pid: int) -> list[int]:
    """The ur_rtde children of the run process ``pid`` (a child that just exited is left out)."""
    found = []
    for child in children(pid):
        try:
            if WORKER in Path(f"/proc/{child}/cmdline").read_text():
                found.append(child)
        except OSError:
            continue
    return found


def figures(pid: int) -> dict[str, dict[str, int]]:
    """Figures of the run process ``pid`` and of its ur_rtde child, if it has one."""
    result = {"run": process_figures(pid)}
    for child in workers(pid):
        result["ur_rtde child"] = process_figures(child)
    return result


def print_figures(start: dict[str, dict[str, int]], end: dict[str, dict[str, int]]) -> None:
    """One line per process: RSS, descriptors and threads from ``start`` to ``end``."""
    for name, first in start.items():
        last = end.get(name, {})
        print(f"  {name:<14} RSS {first['rss_kib'] / 1024:6.1f} -> "
              f"{last.get('rss_kib', 0) / 1024:6.1f} MiB   fds {first['fds']} -> "
              f"{last.get('fds')}   threads {first['threads']} -> {last.get('threads')}")
