"""The one JSON report a ``--json`` run prints on stdout, on every ending (docs/commands.md).

The dispatcher (``cli.main``) makes a ``JsonReport`` before it parses the command line, hands it
to the command as ``args.report`` and prints it once, however the run ends: the command returned,
argparse refused a flag, a typed error (a refusal before connecting, a fault), Ctrl-C or SIGTERM,
a defect. A command only adds what it knows as it goes (``update``) and names the cell session
whose audit records the report points at (``audit_from``); it never prints JSON itself.

Every report has ``command``, ``status`` and ``exit_status``; then the command's own fields;
then either ``pick_id`` (the audit records of the session's latest operation, on disk) or
``audit_record: "none written: <why>"``; a failed run adds ``error`` and ``error_type``. Robot
poses in the fields are UR vectors (m, rad), as everywhere in the command line's output.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from collections.abc import Sequence
from typing import Protocol

from handeye_pick.errors import InputError, PlanRefused, Status, Terminated, ending


class AuditSource(Protocol):
    """What names the audit records of a run: a ``Cell`` (``cell.session``)."""

    @property
    def last_pick_id(self) -> str | None: ...


def add_json_arg(parser: argparse.ArgumentParser, help: str = "") -> None:
    """``--json``: one JSON report on stdout instead of the lines for a person (``help`` says
    what the command adds to it)."""
    parser.add_argument(
        "--json",
        action="store_true",
        help="print one JSON report on stdout whatever the ending; no progress lines"
        + (f". It holds {help}" if help else ""),
    )


def has_json_arg(command_parser: argparse.ArgumentParser) -> bool:
    """Whether a command's parser has ``--json`` (argparse gives a known option's default,
    False here, and None for a name no option has)."""
    return command_parser.get_default("json") is not None


def asks_json(command_parser: argparse.ArgumentParser, tokens: Sequence[str]) -> bool:
    """Whether a command line asks a command that has ``--json`` for it, read from its tokens
    before argparse does (which takes ``--js`` for ``--json`` too)."""
    return has_json_arg(command_parser) and any(
        len(token) > 3 and "--json".startswith(token) for token in tokens
    )


class JsonReport:
    """The report of one run of ``command``: the fields the command added, then its ending."""

    def __init__(self, command: str) -> None:
        self.command = command
        self._fields: dict[str, object] = {}
        self._audit: AuditSource | None = None

    def update(self, **fields: object) -> None:
        """Add (or replace) fields of the report."""
        self._fields.update(fields)

    def audit_from(self, source: AuditSource) -> None:
        """The cell session whose latest audit records the report names (``pick_id``)."""
        self._audit = source

    def ended(self, exit_status: int, failure: BaseException | None) -> dict[str, object]:
        """The report of a run that ended with ``exit_status``, raised by ``failure`` (None:
        the command returned): ``status`` is the command's own, or ``done``, when it returned,
        and the ending's (``errors.ending``) when it raised."""
        fields = dict(self._fields)
        own_status = fields.pop("status", Status.DONE)
        status = own_status if failure is None else ending(failure).outcome
        report: dict[str, object] = {
            "command": self.command,
            "status": status,
            "exit_status": exit_status,
            **fields,
        }
        pick_id = self._audit.last_pick_id if self._audit is not None else None
        if pick_id is not None:
            report["pick_id"] = pick_id
        else:
            report["audit_record"] = f"none written: {self._why_none(status, failure)}"
        if failure is not None:
            report.update(_error_fields(failure))
        return report

    def write(self, exit_status: int, failure: BaseException | None) -> None:
        """Print the report (``ended``) on stdout as one JSON object."""
        print(json.dumps(self.ended(exit_status, failure), indent=2), flush=True)

    def _why_none(self, status: object, failure: BaseException | None) -> str:
        if isinstance(failure, InputError) and _is_audit_error(failure):
            return "the audit file cannot take a record (see error)"
        if failure is not None:
            return f"{self.command} ended {status} before any record reached the audit file"
        return f"{self.command} moves nothing and writes no audit record"


def _is_audit_error(failure: InputError) -> bool:
    # Imported only for an input error: numpy's start-up is not every command's.
    from handeye_pick.audit import AuditError

    return isinstance(failure, AuditError)


def _error_fields(failure: BaseException) -> dict[str, object]:
    """``error`` (one line) and ``error_type``; a pre-flight refusal adds every check."""
    if isinstance(failure, Terminated):
        message = "terminated (SIGTERM)"
    elif isinstance(failure, KeyboardInterrupt):
        message = "interrupted (Ctrl-C)"
    else:
        message = str(failure) or type(failure).__name__
    fields: dict[str, object] = {"error": message, "error_type": type(failure).__name__}
    if isinstance(failure, PlanRefused):
        # Imported only for a refused plan: the checks' module came with the cell anyway.
        from handeye_pick.safety import PreflightRefusal

        if isinstance(failure, PreflightRefusal):
            fields["checks"] = [dataclasses.asdict(check) for check in failure.results]
    return fields
