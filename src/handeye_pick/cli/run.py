"""``handeye-pick run``: a cell session driven by JSON requests, one per line.

On standard input/output by default (progress and logs on stderr), so a vision program in any
language drives the cell through a pipe; with ``--listen HOST:PORT`` over TCP, one client at a
time. The protocol is ``handeye_pick.runner``. Exit status: 0 after ``quit`` or the end of
input, 130 (Ctrl-C) or 143 (SIGTERM) after stopping the arm and answering the request in flight,
2 bad config or arguments, 4 when the robot cannot be reached at start.
"""

from __future__ import annotations

import argparse
import contextlib
import ipaddress
import json
import socket
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import IO, TYPE_CHECKING

from handeye_pick.cli.cell import add_config_arg
from handeye_pick.errors import InputError
from handeye_pick.progress import Progress

if TYPE_CHECKING:
    from handeye_pick.runner import Runner

MAX_TOKEN_FILE_BYTES = 4096


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``run`` to the top-level parser."""
    parser = sub.add_parser(
        "run",
        help="run the cell for a shift: JSON requests (capture, pick, place, move, status, "
        "resume, quit) one per line on stdin or a TCP socket",
        description="Connect once and answer one JSON request per line with one JSON reply per "
        "line: capture (latch the flange pose), pick (candidates in the camera frame, mm), "
        "place, move (named pose), status, resume (after a fault, cleared on the pendant), "
        "quit. A fault stops the arm and halts the cell until resume. Exit status: 0 after quit "
        "or end of input, 2 bad config, 4 robot unreachable at start, 130 Ctrl-C, 143 SIGTERM.",
    )
    add_config_arg(parser)
    parser.add_argument(
        "--listen",
        metavar="HOST:PORT",
        help="serve the protocol over TCP, one client at a time, instead of stdin/stdout "
        "(loopback addresses only unless --allow-remote)",
    )
    parser.add_argument(
        "--allow-remote",
        action="store_true",
        help="allow a --listen address that is not loopback; needs --token-file",
    )
    parser.add_argument(
        "--token-file",
        type=Path,
        metavar="FILE",
        help='file holding a shared secret that every request must carry as "token" '
        "(never give the secret itself on the command line)",
    )
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from handeye_pick.cell.session import Cell
    from handeye_pick.runner import Runner

    address = _listen_address(args.listen, args.allow_remote) if args.listen else None
    token = _read_token(args.token_file) if args.token_file is not None else None
    if args.allow_remote and token is None:
        raise InputError("run --allow-remote needs --token-file FILE with a shared secret")
    progress = Progress(None if args.quiet else sys.stderr)
    with Cell(args.config, progress=progress) as cell:
        runner = Runner(cell, token)
        if address is None:
            _serve(runner, _lines(sys.stdin.buffer), sys.stdout)
        else:
            _serve_tcp(runner, address, progress)
    return 0


def _serve(runner: Runner, lines: Iterator[bytes], out: IO[str]) -> None:
    """Answer every line until quit or the end of ``lines``; on Ctrl-C/SIGTERM answer the
    request in flight, then let the signal end the command."""
    for line in lines:
        if not line.strip():
            continue
        try:
            reply = runner.handle(line)
        except KeyboardInterrupt as exc:
            _write(out, runner.interrupted_reply(line, exc))
            raise
        _write(out, reply)
        if runner.quit:
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
        progress.say(f"listening on {address[0]}:{server.getsockname()[1]}")
        while not runner.quit:
            client, peer = server.accept()
            progress.say(f"client {peer[0]}:{peer[1]} connected")
            # A client that leaves (even mid-reply) ends only its connection, not the session.
            with (
                client,
                client.makefile("rb") as reader,
                client.makefile("w") as writer,
                contextlib.suppress(ConnectionError),
            ):
                _serve(runner, _lines(reader), writer)
            progress.say(f"client {peer[0]}:{peer[1]} left")


def _lines(stream: IO[bytes]) -> Iterator[bytes]:
    """Lines of at most ``MAX_LINE_BYTES``; a longer one is yielded cut (and so refused) and
    the rest of it skipped, so memory stays bounded whatever a client sends."""
    from handeye_pick.runner import MAX_LINE_BYTES

    while True:
        line = stream.readline(MAX_LINE_BYTES + 1)
        if not line:
            return
        if len(line) > MAX_LINE_BYTES and not line.endswith(b"\n"):
            while True:  # drop the rest of the over-long line
                rest = stream.readline(MAX_LINE_BYTES)
                if not rest or rest.endswith(b"\n"):
                    break
        yield line


def _write(out: IO[str], reply: dict[str, object]) -> None:
    out.write(json.dumps(reply, allow_nan=False) + "\n")
    out.flush()


def _listen_address(text: str, allow_remote: bool) -> tuple[str, int]:
    host, _, port_text = text.rpartition(":")
    host = host.strip("[]")
    try:
        port = int(port_text)
        ip = ipaddress.ip_address(host)
    except ValueError:
        raise InputError(
            f"run --listen: expected IP:PORT like 127.0.0.1:8765, got {text!r}"
        ) from None
    if not 0 <= port <= 65535:
        raise InputError(f"run --listen: port {port} outside 0-65535")
    if not ip.is_loopback and not allow_remote:
        raise InputError(
            f"run --listen {text}: not a loopback address; anyone who reaches it can move the "
            "robot: add --allow-remote and --token-file FILE if you mean it"
        )
    return str(ip), port


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
