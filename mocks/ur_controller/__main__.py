"""Command line: `python -m mocks.ur_controller [options]` serves a simulated controller;
`python -m mocks.ur_controller inject --host H FAULT` injects a fault into a running one.

Serving prints one line starting with `ready` once the profile's ports listen (RTDE 30004, and
dashboard 29999 and script 30003 where the profile has them, admin channel 30999); stops cleanly
on SIGINT or SIGTERM. Poses are UR vectors (m, rad), joints in rad. With --serve-stdio (used by
SimulatedController) it then answers admin requests (admin.py) on stdin.

Every ending is one line on stderr and an exit status, never a traceback (README.md, "Use"):
0 stopped by SIGINT (Ctrl-C) or SIGTERM, or its standard input or output closed; 1 a defect in
the simulator (`--log-level DEBUG` shows its traceback); 2 bad arguments, or a record file that
cannot be written; 3 a port that cannot be bound. `--record FILE` and `--record-motions FILE`
create FILE's folder when it is missing.
"""

from __future__ import annotations

import argparse
import errno
import logging
import os
import signal
import sys
from pathlib import Path
from types import FrameType
from typing import NoReturn

from mocks.ur_controller import admin, options
from mocks.ur_controller.controller import Controller
from mocks.ur_controller.faults import parse_fault
from mocks.ur_controller.net import CannotListen
from mocks.ur_controller.options import EXIT_CANNOT_LISTEN

EXIT_STOPPED = 0  # SIGINT, SIGTERM, or the standard input (--serve-stdio) or output closed
EXIT_DEFECT = 1  # a bug in the simulator
EXIT_BAD_ARGUMENTS = 2  # a bad option, fault or record file
EXIT_NO_CONTROLLER = 3  # inject: nothing answers on the admin channel
LOG_LEVELS = ("DEBUG", "INFO", "WARNING", "ERROR")

log = logging.getLogger("mocks.ur_controller")


class _Ending(Exception):
    """Ends the command line with one line on stderr and an exit status."""

    def __init__(self, status: int, line: str) -> None:
        super().__init__(line)
        self.status = status
        self.line = line


class _Parser(argparse.ArgumentParser):
    """An argument parser whose refusal is one line (not the usage block), exit status 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_BAD_ARGUMENTS, f"error: {message} (`{self.prog} --help` lists the "
                                      "options)\n")


def _on_signal(signum: int, frame: FrameType | None) -> None:
    _ignore_signals()  # a second Ctrl-C must not cut the stop short
    name = signal.Signals(signum).name
    raise _Ending(EXIT_STOPPED, f"stopped by {name}" + (" (Ctrl-C)" if name == "SIGINT" else ""))


def _ignore_signals() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="python -m mocks.ur_controller",
        description="Simulated UR controller for ur_rtde. `python -m mocks.ur_controller inject "
                    "--help` injects a fault into a running one.")
    options.add_arguments(parser)
    parser.add_argument("--log-level", default="INFO", type=str.upper, choices=LOG_LEVELS,
                        help="logging level on stderr (default INFO)")
    parser.add_argument("--serve-stdio", action="store_true", help=argparse.SUPPRESS)
    return parser


def _serve_stdio(ctl: Controller) -> None:
    """Answer one JSON line per request line until stdin closes."""
    for line in sys.stdin:
        print(admin.serve_line(ctl, line), flush=True)


def inject_main(argv: list[str]) -> int:
    """`inject --host H FAULT`: 0 injected, 2 bad arguments or fault, 3 no controller answers."""
    parser = _Parser(
        prog="python -m mocks.ur_controller inject",
        description="Inject a fault into a running simulated controller (admin channel on "
                    f"port {admin.ADMIN_PORT} of its loopback address).")
    parser.add_argument("--host", default="127.0.0.1", help="the controller's address")
    parser.add_argument("fault", metavar="FAULT[@WHEN]",
                        help="e.g. protective-stop, refuse-move, stall:3, "
                             "protective-stop@move:2:0.5 (see the simulator's README)")
    args = parser.parse_args(argv)
    try:
        parse_fault(args.fault)
        admin.request(args.host, {"op": "inject", "spec": args.fault})
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_BAD_ARGUMENTS
    except OSError as exc:
        print(f"error: no simulated controller answers on {args.host}:{admin.ADMIN_PORT} "
              f"({exc})", file=sys.stderr)
        return EXIT_NO_CONTROLLER
    print(f"injected {args.fault} into {args.host}")
    return 0


def _prepare_record_files(args: argparse.Namespace) -> None:
    """Create the folder of each record file (--record, --record-motions) when it is missing,
    and make sure the file can be appended to, before anything listens."""
    for option, name in (("--record", args.record), ("--record-motions", args.record_motions)):
        if name is None:
            continue
        path = Path(name)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise _Ending(EXIT_BAD_ARGUMENTS,
                          f"error: {option} {name}: cannot create its folder {path.parent} "
                          f"({exc.strerror or exc}): give a file in a folder you can write to"
                          ) from None
        try:
            with path.open("a", encoding="utf-8"):
                pass
        except OSError as exc:
            raise _Ending(EXIT_BAD_ARGUMENTS,
                          f"error: {option} {name}: cannot append to it ({exc.strerror or exc}): "
                          "give a file in a folder you can write to") from None


def _cannot_listen(exc: CannotListen, host: str) -> _Ending:
    """The one line for a port that cannot be bound, with what to do about it."""
    advice = {
        errno.EADDRINUSE: f"is another simulated controller (or URSim) still serving {host}? "
                          "stop it, or give this one another --host 127.0.0.N",
        errno.EADDRNOTAVAIL: f"{host} is not an address of this computer",
    }.get(exc.errno or 0, "give another --host")
    return _Ending(EXIT_CANNOT_LISTEN, f"error: {exc.strerror}: {advice}")


def _stdout_closed() -> _Ending:
    """Whoever read the standard output went away: point it at nothing, so the interpreter's
    own flush at exit has nowhere to fail, and stop."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    os.close(devnull)
    return _Ending(EXIT_STOPPED, "stopped: its standard output closed")


def serve(args: argparse.Namespace) -> int:
    """Serve until a signal or the end of stdin (--serve-stdio); the exit status."""
    ctl: Controller | None = None
    try:
        signal.signal(signal.SIGINT, _on_signal)
        signal.signal(signal.SIGTERM, _on_signal)
        _prepare_record_files(args)
        try:
            ctl = Controller(options.from_args(args))
        except ValueError as exc:
            raise _Ending(EXIT_BAD_ARGUMENTS, f"error: {exc}") from None
        try:
            ctl.start()
        except CannotListen as exc:
            raise _cannot_listen(exc, args.host) from None
        ports = " ".join(f"{name}={port}" for name, port in ctl.ports.items())
        print(f"ready host={ctl.host} profile={ctl.profile.name} "
              f"version={ctl.profile.version_text} model={ctl.model_name} {ports}", flush=True)
        if args.serve_stdio:
            _serve_stdio(ctl)
            raise _Ending(EXIT_STOPPED, "stopped: its standard input closed")
        while True:
            signal.pause()
    except _Ending as ending:
        result = ending
    except BrokenPipeError:
        result = _stdout_closed()
    except Exception as exc:
        result = _defect(exc)
    _ignore_signals()
    if ctl is not None:
        try:
            ctl.stop()
        except Exception as exc:
            result = _defect(exc)
    line = result.line
    if result.status == EXIT_STOPPED:
        line += f": the simulated controller on {args.host} has closed its ports"
    print(line, file=sys.stderr, flush=True)
    return result.status


def _defect(exc: Exception) -> _Ending:
    """A bug in the simulator: one line; its traceback in the log at DEBUG."""
    log.debug("the simulated controller failed", exc_info=exc)
    return _Ending(EXIT_DEFECT, f"error: the simulated controller failed: {type(exc).__name__}: "
                                f"{exc} (--log-level DEBUG shows where)")


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["inject"]:
        return inject_main(argv[1:])
    args = build_parser().parse_args(argv)
    logging.basicConfig(level=args.log_level, stream=sys.stderr,
                        format="%(asctime)s ur-sim %(levelname)s %(message)s")
    return serve(args)


if __name__ == "__main__":
    sys.exit(main())
