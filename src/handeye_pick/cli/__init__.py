"""Command-line entry point: ``handeye-pick <command> ...``.

Each command lives in a module of this package that adds its sub-parser with
``register(subparsers)`` and sets ``run=function(args) -> int``; ``COMMANDS`` below names the
module of every command and the one line the top-level ``--help`` shows for it. This module turns
typed errors into one-line messages and exit statuses, so no command prints a traceback for a
failure it knows about.

Start-up: only the module of the command being run is imported (none for the top-level
``--help``), so ``point`` or ``convert`` never pays for what ``pick`` imports; the other commands
are listed from ``COMMANDS``. A new command is a module with ``register`` and a ``COMMANDS`` line
whose summary is the ``help=`` of its sub-parser (tests/unit/test_light_imports.py compares
them). Below that, the package keeps the imports light at the roots: ``import handeye_pick`` loads
nothing else, ``geometry`` needs no scipy, ``plot`` imports matplotlib and ``cloud`` imports
numba inside the functions that use them. The one rule left for a command module: anything new
and heavy it brings (scipy, matplotlib, numba, cv2, open3d) is imported inside the function that
needs it, so that the command's ``--help`` stays light; the test checks every command's ``--help``.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import signal
import sys
from collections.abc import Collection, Sequence
from types import FrameType
from typing import TYPE_CHECKING

from handeye_pick.errors import ExitCode, HandEyePickError, InputError, Terminated, ending
from handeye_pick.progress import add_output_args, configure_logging

if TYPE_CHECKING:  # loaded once a command is known: the top-level --help loads no cli module
    from handeye_pick.cli.json_report import JsonReport

COMMANDS: dict[str, tuple[str, str]] = {
    # command: (module in handeye_pick.cli that registers it, summary for the top-level --help)
    "point": ("point", "transform one camera-frame point (mm) into the robot base frame (mm)"),
    "convert": (
        "convert",
        "convert a pose between UR vector, 4x4 matrix, quaternion and Euler/RPY",
    ),
    "pick": (
        "pick",
        "pick one detected object: flange pose at capture, hand-eye chain, checked moveL",
    ),
    "cloud": (
        "cloud",
        "transform a point cloud file from the camera frame into the robot base frame",
    ),
    "plan": ("plan", "plan a pick and draw every frame to a PNG; moves nothing"),
    "status": (
        "status",
        "is the cell ready to pick? exit 0 ready, 3 not ready (with the reasons), 4 no answer",
    ),
    "touch-test": (
        "touch_test",
        "move the TCP slowly to a stand-off above a point the camera sees, then back",
    ),
    "run": (
        "run",
        "run the cell for a shift: JSON requests (capture, pick, place, move, status, stop, "
        "resume, quit) one per line on stdin or a TCP socket",
    ),
    "poses": ("poses", "propose reachable poses for a hand-eye dataset; moves nothing"),
    "collect": ("collect", "move through a pose list and capture a hand-eye dataset"),
    "calibrate": (
        "calibrate",
        "solve a hand-eye calibration from robot_pose_N.yaml / object_pose_N.yaml pairs",
    ),
    "report": (
        "report",
        "a shift from the audit file: cycles, statuses, picks per hour, cycle times, faults",
    ),
}
MODULES = tuple(dict.fromkeys(module for module, _ in COMMANDS.values()))
"""Every command module, in the order of ``COMMANDS``."""

log = logging.getLogger("handeye_pick")


class _Parser(argparse.ArgumentParser):
    """argparse that reports usage errors with our exit status 2 and one line; the top-level
    parser keeps each command's own parser in ``commands``."""

    commands: dict[str, argparse.ArgumentParser]

    def error(self, message: str) -> None:  # type: ignore[override]
        raise InputError(f"{self.prog}: {message}")


def parser_with(modules: Collection[str] = MODULES) -> _Parser:
    """The parser with the commands of ``modules`` complete (every module by default).

    The other commands are listed with their ``COMMANDS`` summary only: their modules are not
    imported, and their options are not known to this parser.
    """
    parser = _Parser(
        prog="handeye-pick",
        description="Camera-guided picks on Universal Robots arms. Frames are named T_a_b "
        "(pose of b in a); robot poses are UR vectors in m and rad; camera points are mm.",
    )
    add_output_args(parser)
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name, (module, summary) in COMMANDS.items():
        if module in modules:
            importlib.import_module(f"handeye_pick.cli.{module}").register(sub)
        else:
            sub.add_parser(name, help=summary, add_help=False)
    for command_parser in sub.choices.values():  # --quiet/--log-file also after the command
        add_output_args(command_parser, with_defaults=False)
    parser.commands = dict(sub.choices)
    return parser


def build_parser(argv: Sequence[str]) -> tuple[str, _Parser]:
    """The command of the command line ``argv`` and its parser.

    The command is found by the top-level parser alone; then only that command's module is
    imported. The top-level ``--help`` and a missing or unknown command end in the first step.
    """
    command: str = parser_with(()).parse_known_args(argv)[0].command
    return command, parser_with({COMMANDS[command][0]})


def _terminate(signum: int, frame: FrameType | None) -> None:
    raise Terminated


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command; return its exit status (never raises for a known failure).

    SIGTERM (a supervisor stopping the cell) is handled like Ctrl-C: the command stops the arm
    and writes its outcome, then exits 143. A command line that asks a command with ``--json``
    for it gets one JSON report on stdout on every ending (``cli.json_report``), a command
    line argparse refuses included.
    """
    signal.signal(signal.SIGTERM, _terminate)
    tokens = list(sys.argv[1:] if argv is None else argv)
    report: JsonReport | None = None  # printed when --json was asked of a command that has it
    json_asked = False
    failure: BaseException | None = None
    try:
        command, parser = build_parser(tokens)
        from handeye_pick.cli.json_report import JsonReport, asks_json

        report = JsonReport(command)
        # From the tokens first, so a command line argparse refuses is reported too; then
        # argparse's own reading.
        json_asked = asks_json(parser.commands[command], tokens)
        args = parser.parse_args(tokens)
        json_asked = bool(getattr(args, "json", False))
        configure_logging(args.log_file, quiet=args.quiet)
        args.report = report
        status: int = args.run(args)
    except HandEyePickError as exc:
        print(f"error: {exc}", file=sys.stderr)
        status, failure = ending(exc).exit_code, exc
    except KeyboardInterrupt as exc:
        terminated = isinstance(exc, Terminated)
        print(
            "terminated (SIGTERM): the arm was stopped" if terminated else "interrupted",
            file=sys.stderr,
        )
        status, failure = ending(exc).exit_code, exc
    except Exception as exc:
        # A bug, not a known failure: a defined status and one line, the traceback in the log
        # (stderr shows it too unless --quiet). Robot code has already stopped the arm.
        log.exception("internal error")
        print(
            f"internal error: {type(exc).__name__}: {exc} (a defect in handeye-pick; please "
            "report it with the --log-file output)",
            file=sys.stderr,
        )
        status, failure = ExitCode.INTERNAL, exc
    try:
        if report is not None and json_asked:
            report.write(status, failure)
        sys.stdout.flush()
    except BrokenPipeError:
        # The reader closed its end (``| head``): what it wanted it has; the status stands.
        # Standard output now points at nothing, so the interpreter's own flush at exit is quiet.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return status
