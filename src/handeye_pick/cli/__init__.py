"""Command-line entry point: ``handeye-pick <command> ...``.

Each command lives in its own module that adds a sub-parser with ``register(subparsers)`` and
sets ``run=function(args) -> int``. This module turns typed errors into one-line messages and
exit statuses, so no command prints a traceback for a failure it knows about.
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
from collections.abc import Sequence
from types import FrameType

from handeye_pick.errors import (
    HandEyePickError,
    InputError,
    RobotError,
    SafetyRefusal,
    Terminated,
)
from handeye_pick.progress import add_output_args, configure_logging

EXIT_OK = 0
EXIT_INTERNAL = 1
EXIT_BAD_INPUT = 2
EXIT_REFUSED = 3
EXIT_ROBOT_FAULT = 4
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 143

log = logging.getLogger("handeye_pick")


class _Parser(argparse.ArgumentParser):
    """argparse that reports usage errors with our exit status 2 and one line."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise InputError(f"{self.prog}: {message}")


def build_parser() -> argparse.ArgumentParser:
    from handeye_pick.cli import calibrate, cloud, operator, pick, run, transform

    parser = _Parser(
        prog="handeye-pick",
        description="Camera-guided picks on Universal Robots arms. Frames are named T_a_b "
        "(pose of b in a); robot poses are UR vectors in m and rad; camera points are mm.",
    )
    add_output_args(parser)
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for module in (transform, pick, cloud, operator, run, calibrate):
        module.register(sub)
    for command_parser in sub.choices.values():  # --quiet/--log-file also after the command
        add_output_args(command_parser, with_defaults=False)
    return parser


def exit_status(exc: HandEyePickError) -> int:
    """The exit status for a typed error (2 input, 3 refused, 4 robot)."""
    if isinstance(exc, SafetyRefusal):
        return EXIT_REFUSED
    if isinstance(exc, RobotError):
        return EXIT_ROBOT_FAULT
    return EXIT_BAD_INPUT


def _terminate(signum: int, frame: FrameType | None) -> None:
    raise Terminated


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command; return its exit status (never raises for a known failure).

    SIGTERM (a supervisor stopping the cell) is handled like Ctrl-C: the command stops the arm
    and writes its outcome, then exits 143.
    """
    signal.signal(signal.SIGTERM, _terminate)
    try:
        args = build_parser().parse_args(argv)
        configure_logging(args.log_file, quiet=args.quiet)
        status: int = args.run(args)
        return status
    except HandEyePickError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return exit_status(exc)
    except Terminated:
        print("terminated (SIGTERM): the arm was stopped", file=sys.stderr)
        return EXIT_TERMINATED
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as exc:
        # A bug, not a known failure: a defined status and one line, the traceback in the log
        # (stderr shows it too unless --quiet). Robot code has already stopped the arm.
        log.exception("internal error")
        print(
            f"internal error: {type(exc).__name__}: {exc} (a defect in handeye-pick; please "
            "report it with the --log-file output)",
            file=sys.stderr,
        )
        return EXIT_INTERNAL
