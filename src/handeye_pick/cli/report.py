"""``report``: a shift read from the audit file alone (docs/report.md); touches no robot.

``--since`` and ``--until`` are ISO 8601 times; one without an offset is the machine's local
time, as a supervisor reads a clock. Hours are counted and times printed in local time too.
"""

from __future__ import annotations

import argparse
import sys
from datetime import datetime
from pathlib import Path

from handeye_pick.cli.json_report import add_json_arg
from handeye_pick.errors import ExitCode, InputError


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the command to the top-level parser."""
    report = sub.add_parser(
        "report",
        help="a shift from the audit file: cycles, statuses, picks per hour, cycle times, faults",
        description="Read an audit file once, line by line, and report the shift: cycles and "
        "their statuses, picks per hour, cycle time median, p90 and histogram, every fault with "
        "how long the cell stood until resume, and the share of time it stood halted. Torn "
        "lines and unknown record kinds are counted and skipped with one warning on stderr.",
    )
    report.add_argument("audit", type=Path, metavar="AUDIT", help="the audit file (JSON lines)")
    for flag, what in (("--since", "first"), ("--until", "end of the")):
        report.add_argument(
            flag,
            type=_time,
            metavar="TIME",
            help=f"{what} time reported, ISO 8601 (2026-12-02T06:00, local time without an offset)",
        )
    report.add_argument("--plot", type=Path, metavar="FILE.png", help="also draw the shift")
    add_json_arg(report, "the shift's figures as the text shows them")
    report.set_defaults(run=run_report)


def run_report(args: argparse.Namespace) -> int:
    """Print the report (and draw it with ``--plot``); exit 0."""
    from handeye_pick.report.output import report_json, report_text, skipped_warning
    from handeye_pick.report.shift import shift_report

    if args.since is not None and args.until is not None and args.since >= args.until:
        raise InputError("report: --since must be earlier than --until")
    try:
        report = shift_report(args.audit, args.since, args.until)
    except OSError as exc:
        raise InputError(f"report: cannot read {args.audit} ({exc.strerror or exc})") from None
    warning = skipped_warning(report)
    if warning is not None:
        print(warning, file=sys.stderr)
    if args.plot is not None:
        from handeye_pick.report.plot import render_report

        render_report(report, args.plot)
    if args.json:
        args.report.update(**report_json(report))
    else:
        print(report_text(report), flush=True)
        if args.plot is not None:
            print(f"  drawn to {args.plot}", flush=True)
    return ExitCode.OK


def _time(text: str) -> datetime:
    """An ISO 8601 time, aware; without an offset it is the machine's local time."""
    try:
        moment = datetime.fromisoformat(text[:-1] + "+00:00" if text.endswith("Z") else text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"not an ISO 8601 time: {text!r} (e.g. 2026-12-02T06:00 or 2026-12-02T06:00+01:00)"
        ) from None
    return moment if moment.tzinfo is not None else moment.astimezone()
