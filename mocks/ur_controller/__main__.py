"""Command line: `python -m mocks.ur_controller [options]` serves a simulated controller;
`python -m mocks.ur_controller inject --host H FAULT` injects a fault into a running one.

Serving prints one line starting with `ready` once the profile's ports listen (RTDE 30004, and
dashboard 29999 and script 30003 where the profile has them, admin channel 30999); stops cleanly
on SIGINT or SIGTERM. Poses are UR vectors (m, rad), joints in rad. With --serve-stdio (used by
SimulatedController) it then answers admin requests (admin.py) on stdin.
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
from types import FrameType

from mocks.ur_controller import admin, options
from mocks.ur_controller.controller import Controller
from mocks.ur_controller.faults import parse_fault
from mocks.ur_controller.options import EXIT_CANNOT_LISTEN

EXIT_NO_CONTROLLER = 3  # inject: nothing answers on the admin channel


class _Shutdown(Exception):
    """Raised in the main thread by SIGINT/SIGTERM."""


def _on_signal(signum: int, frame: FrameType | None) -> None:
    raise _Shutdown(signal.Signals(signum).name)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m mocks.ur_controller",
        description="Simulated UR controller for ur_rtde. `python -m mocks.ur_controller inject "
                    "--help` injects a fault into a running one.")
    options.add_arguments(parser)
    parser.add_argument("--log-level", default="INFO", help="logging level on stderr")
    parser.add_argument("--serve-stdio", action="store_true", help=argparse.SUPPRESS)
    return parser


def _serve_stdio(ctl: Controller) -> None:
    """Answer one JSON line per request line until stdin closes."""
    for line in sys.stdin:
        print(admin.serve_line(ctl, line), flush=True)


def inject_main(argv: list[str]) -> int:
    """`inject --host H FAULT`: 0 injected, 2 bad arguments or fault, 3 no controller answers."""
    parser = argparse.ArgumentParser(
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
        return 2
    except OSError as exc:
        print(f"error: no simulated controller answers on {args.host}:{admin.ADMIN_PORT} "
              f"({exc})", file=sys.stderr)
        return EXIT_NO_CONTROLLER
    print(f"injected {args.fault} into {args.host}")
    return 0


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["inject"]:
        return inject_main(argv[1:])
    args = build_parser().parse_args(argv)
    logging.basicConfig(level=args.log_level.upper(), stream=sys.stderr,
                        format="%(asctime)s ur-sim %(levelname)s %(message)s")
    try:
        ctl = Controller(options.from_args(args))
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    signal.signal(signal.SIGINT, _on_signal)
    signal.signal(signal.SIGTERM, _on_signal)
    try:
        ctl.start()
        ports = " ".join(f"{name}={port}" for name, port in ctl.ports.items())
        print(f"ready host={ctl.host} profile={ctl.profile.name} "
              f"version={ctl.profile.version_text} model={ctl.model_name} {ports}", flush=True)
        if args.serve_stdio:
            _serve_stdio(ctl)
        else:
            while True:
                signal.pause()
    except _Shutdown as exc:
        logging.getLogger("mocks.ur_controller").info("stopping on %s", exc)
    except OSError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_CANNOT_LISTEN
    finally:
        ctl.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())
