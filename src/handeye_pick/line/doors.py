"""The line's doors opened for one ``run``: the line state on the runner, the wired handshake
when the cell config has ``line.io``, the OPC UA server when ``--opcua`` is given.

``opened_line`` is a context manager: everything it started ends when the session does, before
the cell closes (so no output is written through a closed session).
"""

from __future__ import annotations

import contextlib
import ipaddress
import logging
from collections.abc import Iterator
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING

from handeye_pick.cell.session import Cell
from handeye_pick.errors import InputError
from handeye_pick.line.counters import AuditCounters
from handeye_pick.line.state import Line
from handeye_pick.progress import Progress
from handeye_pick.runner import Runner

if TYPE_CHECKING:
    from handeye_pick.line.opcua import LineServer

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class OpcUaOptions:
    """``--opcua [HOST:]PORT`` and its security: ``users_file`` (``--opcua-users``), required
    for an address that is not loopback, which also needs ``allow_remote``."""

    host: str
    port: int
    users_file: Path | None
    allow_remote: bool

    def check(self) -> None:
        """InputError (exit 2, before anything connects) for a remote address without
        ``--allow-remote`` and ``--opcua-users``."""
        if ipaddress.ip_address(self.host).is_loopback:
            return
        if not self.allow_remote or self.users_file is None:
            raise InputError(
                f"run --opcua {self.host}:{self.port}: not a loopback address; anyone who "
                "reaches it sees the cell and may stop it: add --allow-remote and "
                "--opcua-users FILE (hashed passwords; docs/line.md) if you mean it"
            )


@contextlib.contextmanager
def opened_line(
    cell: Cell, runner: Runner, opcua: OpcUaOptions | None, progress: Progress
) -> Iterator[Line]:
    """The line state of ``cell`` on ``runner``, with its wired and OPC UA doors open."""
    line = Line(cell, runner, AuditCounters.from_now(cell.config.audit.file))
    runner.line = line
    with contextlib.ExitStack() as stack:
        io = cell.config.line.io
        if io is not None:
            from handeye_pick.line.io import WiredHandshake

            handshake = WiredHandshake(line, io).start()
            stack.callback(handshake.close)
            progress.say(f"line handshake on inputs {io.inputs} and outputs {io.outputs}")
        if opcua is not None:
            server = _opcua_server(line, opcua)
            stack.callback(server.close)
            progress.say(f"OPC UA server on {server.url}")
        try:
            yield line
        finally:
            runner.line = None


def _opcua_server(line: Line, options: OpcUaOptions) -> LineServer:
    from handeye_pick.line.opcua import LineServer  # asyncua loads only here
    from handeye_pick.line.users import read_users

    users = read_users(options.users_file) if options.users_file is not None else None
    config = line.cell.config
    identity = {
        "product": "handeye-pick",
        "version": _version(),
        "robot_host": config.robot.host,
        "robot_model": config.robot.model.name if config.robot.model is not None else "",
        "cell": config.path.stem,
    }
    cert_dir = options.users_file.parent if options.users_file is not None else None
    return LineServer(line, options.host, options.port, users, cert_dir, identity).start()


def _version() -> str:
    try:
        return metadata.version("handeye-pick")
    except metadata.PackageNotFoundError:
        return "unknown"
