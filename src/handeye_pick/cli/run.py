"""``handeye-pick run``: a cell session driven by JSON requests, one per line.

On standard input/output by default (progress and logs on stderr), so a vision program in any
language drives the cell through a pipe; with ``--listen HOST:PORT`` over TCP, one client at a
time. The protocol is ``handeye_pick.runner``. Exit status: 0 after ``quit`` or the end of
input, 130 (Ctrl-C) or 143 (SIGTERM) after stopping the arm and answering the request in flight,
2 bad config or arguments, 4 when the robot cannot be reached at start. ``--opcua`` and the cell
config's ``line.io`` open the line's other doors (``handeye_pick.line``, docs/line.md).
"""

from __future__ import annotations

import argparse
import contextlib
import ipaddress
import json
import os
import queue
import select
import socket
import sys
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import IO, TYPE_CHECKING

from handeye_pick.cli.cell import add_config_arg, add_record_arg, publisher_from_args
from handeye_pick.errors import InputError
from handeye_pick.progress import Progress

if TYPE_CHECKING:
    from handeye_pick.line.doors import OpcUaOptions
    from handeye_pick.runner import Runner

MAX_TOKEN_FILE_BYTES = 4096
MAX_WAITING = 8
"""Most requests that wait behind the running one; a further one is answered at once, unrun."""
WAIT_POLL_S = 0.2  # how long a wait for a line or a request lasts before it looks again
READ_CHUNK_BYTES = 65536


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``run`` to the top-level parser."""
    parser = sub.add_parser(
        "run",
        help="run the cell for a shift: JSON requests (capture, pick, place, move, status, "
        "stop, resume, quit) one per line on stdin or a TCP socket",
        description="Connect once and answer one JSON request per line with one JSON reply per "
        "line: capture (latch the flange pose), pick (candidates in the camera frame, mm), "
        "place, move (named pose), status, stop (brake the running request, answered at once), "
        "resume (after a fault or a stop, cleared on the pendant), quit. A fault or a stop "
        "stops the arm and halts the cell until resume. Exit status: 0 after quit "
        "or end of input, 2 bad config, 4 robot unreachable at start, 130 Ctrl-C, 143 SIGTERM.",
    )
    add_config_arg(parser)
    parser.add_argument(
        "--listen",
        metavar="HOST:PORT",
        help="serve the protocol over TCP, one client at a time, instead of stdin/stdout "
        "(loopback addresses only unless --allow-remote)",
    )
    add_record_arg(parser)
    parser.add_argument(
        "--live",
        metavar="[HOST:]PORT",
        help="serve the recording's channels live over WebSocket (Foxglove, Lichtblick) on "
        "PORT of 127.0.0.1, or of HOST (loopback addresses only unless --allow-remote)",
    )
    parser.add_argument(
        "--allow-remote",
        action="store_true",
        help="allow a --listen or --live address that is not loopback; --listen then needs "
        "--token-file",
    )
    parser.add_argument(
        "--token-file",
        type=Path,
        metavar="FILE",
        help='file holding a shared secret that every request must carry as "token" '
        "(never give the secret itself on the command line)",
    )
    parser.add_argument(
        "--opcua",
        metavar="[HOST:]PORT",
        help="serve the line state, counters and the commands CycleStop, Release, Stop and "
        "Resume over OPC UA on PORT of 127.0.0.1, or of HOST (docs/line.md); a remote HOST "
        "needs --allow-remote and --opcua-users",
    )
    parser.add_argument(
        "--opcua-users",
        type=Path,
        metavar="FILE",
        help="OPC UA users with scrypt-hashed passwords (python -m handeye_pick.line.users "
        "FILE NAME adds one): Basic256Sha256 only, anonymous clients read but never call",
    )
    parser.add_argument(
        "--no-check-ahead",
        action="store_true",
        help="plan and check each pick only in its turn, never while the place before it moves "
        "(docs/motion.md); for comparisons",
    )
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from handeye_pick.cell.session import Cell
    from handeye_pick.config.load import load_config
    from handeye_pick.line.doors import opened_line
    from handeye_pick.runner import Runner

    address = _listen_address(args.listen, args.allow_remote) if args.listen else None
    live = _live_address(args.live, args.allow_remote) if args.live else None
    opcua = _opcua_options(args) if args.opcua else None
    token = _read_token(args.token_file) if args.token_file is not None else None
    if address is not None and not ipaddress.ip_address(address[0]).is_loopback and not token:
        raise InputError("run --allow-remote needs --token-file FILE with a shared secret")
    progress = Progress(None if args.quiet else sys.stderr)
    config = load_config(args.config)
    progress.say(f"audit records go to {config.audit.file}")
    with contextlib.ExitStack() as stack:
        publisher = publisher_from_args(args, config, live)
        if publisher is not None:  # closed after the cell: its last records are recorded
            stack.enter_context(publisher)
            if publisher.files is not None:
                progress.say(publisher.files.describe())
            if publisher.live_port is not None and live is not None:
                progress.say(f"live view on ws://{live[0]}:{publisher.live_port}")
        with Cell(config, progress=progress, observer=publisher) as cell:
            runner = Runner(cell, token)
            runner.check_ahead = not args.no_check_ahead
            with opened_line(cell, runner, opcua, progress):
                if address is None:
                    _serve(runner, sys.stdin.fileno(), sys.stdout)
                else:
                    _serve_tcp(runner, address, progress)
    return 0


def _serve(runner: Runner, fd: int, out: IO[str]) -> None:
    """Answer every line read from the file descriptor ``fd`` until quit or its end.

    Requests run one at a time on this, the main thread (ur_rtde's child and the signal holds
    need it), in the order they came; meanwhile a thread of its own reads the next lines and
    answers ``stop``, ``status`` and malformed lines at once (``Runner.answer_now``); at most
    ``MAX_WAITING`` wait their turn. On Ctrl-C/SIGTERM answer the request in flight, then let
    the signal end the command."""
    loop = _Loop(runner, out)
    closing = threading.Event()
    reader = threading.Thread(target=loop.read, args=(_lines(fd, closing),), name="requests")
    runner.events = loop.write
    reader.start()
    try:
        loop.run()
    finally:
        runner.events = None
        closing.set()  # the reader sees it within WAIT_POLL_S
        reader.join()


class _Loop:
    """The requests of one client: a bounded line of waiting requests between the thread that
    reads them and the main thread that runs them; replies and events written one at a time."""

    def __init__(self, runner: Runner, out: IO[str]) -> None:
        self.runner = runner
        self.out = out
        self.waiting: queue.Queue[bytes | None] = queue.Queue(MAX_WAITING)  # None: no more
        self._write_lock = threading.Lock()

    def write(self, reply: dict[str, object]) -> None:
        with self._write_lock:
            _write(self.out, reply)

    def read(self, lines: Iterator[bytes]) -> None:
        """The reading thread: answer what must not wait, queue the rest, then say the end."""
        from handeye_pick.runner import bad_request_reply, queue_full_error

        try:
            for line in lines:
                if not line.strip():
                    continue
                reply = self.runner.answer_now(line, waiting=not self.waiting.empty())
                if reply is not None:
                    self.write(reply)
                    continue
                try:
                    self.waiting.put_nowait(line)
                except queue.Full:
                    self.write(bad_request_reply(line, queue_full_error(MAX_WAITING)))
        except (OSError, ValueError):  # the client left, or its stream was closed under us
            pass
        finally:
            self.waiting.put(None)

    def first_waiting(self) -> bytes | None:
        """The request line first in line (None: none waits), left in the line."""
        with self.waiting.mutex:
            return self.waiting.queue[0] if self.waiting.queue else None

    def run(self) -> None:
        """The main thread: run waiting requests in order until quit or the end of input; a
        pick waiting behind a running place is checked while the place moves."""
        if self.runner.check_ahead:
            self.runner.watch_queue(self.first_waiting)
        while True:
            try:
                line = self.waiting.get(timeout=WAIT_POLL_S)
            except queue.Empty:
                self.runner.idle()  # a resume handed over by the line's other doors
                continue  # wake now and then so Ctrl-C is never held up by the wait
            if line is None:
                return
            try:
                reply = self.runner.handle(line)
            except KeyboardInterrupt as exc:
                self.write(self.runner.interrupted_reply(line, exc))
                raise
            self.write(reply)
            if self.runner.quit:
                return


def _serve_tcp(runner: Runner, address: tuple[str, int], progress: Progress) -> None:
    family = socket.AF_INET6 if ":" in address[0] else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as server:
        server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            server.bind(address)
        except OSError as exc:
            raise InputError(f"run --listen {address[0]}:{address[1]}: {exc.strerror}") from None
        server.listen(1)
        server.settimeout(WAIT_POLL_S)  # between clients the cell's thread still serves the line
        progress.say(f"listening on {address[0]}:{server.getsockname()[1]}")
        while not runner.quit:
            try:
                client, peer = server.accept()
            except TimeoutError:
                runner.idle()
                continue
            client.settimeout(None)
            progress.say(f"client {peer[0]}:{peer[1]} connected")
            # A client that leaves (even mid-reply) ends only its connection, not the session.
            with client, client.makefile("w") as writer, contextlib.suppress(ConnectionError):
                _serve(runner, client.fileno(), writer)
            progress.say(f"client {peer[0]}:{peer[1]} left")


def _lines(fd: int, closing: threading.Event) -> Iterator[bytes]:
    """Lines read from the file descriptor ``fd`` (a pipe, a terminal or a socket) until its
    end or until ``closing`` is set; each at most ``MAX_LINE_BYTES``: a longer one is yielded
    cut (and so refused) and the rest of it skipped, so memory stays bounded whatever a client
    sends. Raw reads behind ``select``: the thread that reads can always be told to stop."""
    from handeye_pick.runner import MAX_LINE_BYTES

    pending = b""
    skipping = False  # inside the rest of an over-long line
    while not closing.is_set():
        ready, _, _ = select.select([fd], [], [], WAIT_POLL_S)
        if not ready:
            continue
        chunk = os.read(fd, READ_CHUNK_BYTES)
        if not chunk:
            if pending and not skipping:
                yield pending
            return
        pending += chunk
        while True:
            end = pending.find(b"\n")
            if end < 0:
                if len(pending) > MAX_LINE_BYTES:
                    if not skipping:
                        yield pending[: MAX_LINE_BYTES + 1]
                    skipping, pending = True, b""
                break
            line, pending = pending[: end + 1], pending[end + 1 :]
            if skipping:
                skipping = False  # the end of the over-long line
            elif len(line) > MAX_LINE_BYTES + 1:
                yield line[: MAX_LINE_BYTES + 1]
            else:
                yield line


def _write(out: IO[str], reply: dict[str, object]) -> None:
    out.write(json.dumps(reply, allow_nan=False) + "\n")
    out.flush()


def _listen_address(
    text: str, allow_remote: bool, option: str = "--listen", exposes: str = "can move the robot"
) -> tuple[str, int]:
    host, _, port_text = text.rpartition(":")
    host = host.strip("[]")
    try:
        port = int(port_text)
        ip = ipaddress.ip_address(host)
    except ValueError:
        raise InputError(
            f"run {option}: expected IP:PORT like 127.0.0.1:8765, got {text!r}"
        ) from None
    if not 0 <= port <= 65535:
        raise InputError(f"run {option}: port {port} outside 0-65535")
    if not ip.is_loopback and not allow_remote:
        advice = (
            "--allow-remote and --token-file FILE" if option == "--listen" else "--allow-remote"
        )
        raise InputError(
            f"run {option} {text}: not a loopback address; anyone who reaches it {exposes}: "
            f"add {advice} if you mean it"
        )
    return str(ip), port


def _live_address(text: str, allow_remote: bool) -> tuple[str, int]:
    """``--live [HOST:]PORT``: 127.0.0.1 when no host is given."""
    with_host = text if ":" in text else f"127.0.0.1:{text}"
    return _listen_address(with_host, allow_remote, "--live", "sees the cell and its audit")


def _opcua_options(args: argparse.Namespace) -> OpcUaOptions:
    """``--opcua [HOST:]PORT``: 127.0.0.1 when no host is given; refused (exit 2) before
    anything connects when remote without --allow-remote and --opcua-users."""
    from handeye_pick.line.doors import OpcUaOptions

    with_host = args.opcua if ":" in args.opcua else f"127.0.0.1:{args.opcua}"
    host, port = _listen_address(with_host, True, "--opcua", "sees the cell and may stop it")
    options = OpcUaOptions(host, port, args.opcua_users, args.allow_remote)
    options.check()
    return options


def _read_token(path: Path) -> str:
    try:
        with path.open("rb") as file:
            data = file.read(MAX_TOKEN_FILE_BYTES + 1)
    except OSError as exc:
        raise InputError(f"--token-file {path}: cannot read ({exc.strerror or exc})") from None
    token = data.decode("utf-8", errors="replace").strip()
    if len(data) > MAX_TOKEN_FILE_BYTES or len(token) < 16 or "\n" in token:
        raise InputError(
            f"--token-file {path}: expected one line with a secret of 16 to "
            f"{MAX_TOKEN_FILE_BYTES} characters"
        )
    return token
