"""Command line: `python -m mocks.ur_controller [options]`, run from the repository root.

Prints one line starting with `ready` once RTDE (30004), dashboard (29999) and script (30003)
listen; stops cleanly on SIGINT or SIGTERM. Poses are UR vectors (m, rad), joints in rad.
With --serve-stdio (used by SimulatedController) it then answers JSON requests on stdin.
"""

from __future__ import annotations

import argparse
import json
import logging
import signal
import sys
from dataclasses import asdict
from types import FrameType
from typing import Any

from mocks.ur_controller.controller import EXIT_CANNOT_LISTEN, Controller


class _Shutdown(Exception):
    """Raised in the main thread by SIGINT/SIGTERM."""


def _on_signal(signum: int, frame: FrameType | None) -> None:
    raise _Shutdown(signal.Signals(signum).name)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python -m mocks.ur_controller",
                                     description="Simulated UR e-Series controller for ur_rtde.")
    parser.add_argument("--host", default="127.0.0.1", help="loopback address to serve on")
    parser.add_argument("--model", default="ur5e", choices=("ur3e", "ur5e", "ur10e", "ur16e"))
    start = parser.add_mutually_exclusive_group()
    start.add_argument("--initial-q", nargs=6, type=float, metavar="Q", help="joints (rad)")
    start.add_argument("--initial-flange-pose", nargs=6, type=float, metavar="V",
                       help="flange pose in base, UR vector (m, rad)")
    parser.add_argument("--tcp-offset", nargs=6, type=float, metavar="V",
                        default=[0.0] * 6, help="active TCP offset T_flange_tcp (m, rad)")
    speed = parser.add_mutually_exclusive_group()
    speed.add_argument("--speed-factor", type=float, default=1.0,
                       help="run motions this many times faster than real time")
    speed.add_argument("--instant", action="store_true", help="motions end within two cycles")
    parser.add_argument("--record", metavar="FILE", help="append commands as JSON lines")
    parser.add_argument("--inject", action="append", default=[], metavar="FAULT@WHEN",
                        help="fault, e.g. protective-stop@move:2:0.5 (repeatable)")
    parser.add_argument("--no-remote-control", action="store_true",
                        help="start in local control (dashboard says remote control is off)")
    parser.add_argument("--allow-non-loopback", action="store_true",
                        help="allow a host address that is not loopback")
    parser.add_argument("--log-level", default="INFO", help="logging level on stderr")
    parser.add_argument("--serve-stdio", action="store_true", help=argparse.SUPPRESS)
    return parser


def _controller(args: argparse.Namespace) -> Controller:
    return Controller(
        host=args.host, model=args.model, initial_q=args.initial_q,
        initial_flange_pose=args.initial_flange_pose, tcp_offset=args.tcp_offset,
        speed_factor=args.speed_factor, instant=args.instant, record_path=args.record,
        inject=args.inject, remote_control=not args.no_remote_control,
        allow_non_loopback=args.allow_non_loopback,
    )


def _answer(ctl: Controller, request: dict[str, Any]) -> Any:
    op = request.get("op")
    if op == "snapshot":
        return asdict(ctl.snapshot())
    if op == "commands":
        return ctl.commands
    if op == "inject":
        ctl.inject(str(request["spec"]))
        return None
    if op == "set_remote_control":
        ctl.set_remote_control(bool(request["enabled"]))
        return None
    raise ValueError(f"unknown request op {op!r}")


def _serve_stdio(ctl: Controller) -> None:
    """Answer one JSON line per request line until stdin closes."""
    for line in sys.stdin:
        try:
            reply = {"ok": True, "result": _answer(ctl, json.loads(line))}
        except (ValueError, KeyError) as exc:
            reply = {"ok": False, "error": str(exc)}
        print(json.dumps(reply), flush=True)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    logging.basicConfig(level=args.log_level.upper(), stream=sys.stderr,
                        format="%(asctime)s ur-sim %(levelname)s %(message)s")
    try:
        ctl = _controller(args)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    signal.signal(signal.SIGINT, _on_signal)
    signal.signal(signal.SIGTERM, _on_signal)
    try:
        ctl.start()
        print(f"ready host={ctl.host} model={ctl.model_name} rtde=30004 dashboard=29999 "
              f"script=30003", flush=True)
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
