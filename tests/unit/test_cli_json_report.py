"""``cli.json_report``: every command that has ``--json`` prints one report even when argparse
refuses its command line, and a report never names a pick id whose records are not on disk.
The endings against a controller: tests/integration/test_json_endings.py."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from handeye_pick import cli
from handeye_pick.audit import AuditError, AuditLog
from handeye_pick.cli.json_report import JsonReport, has_json_arg
from handeye_pick.errors import RobotFault

JSON_COMMANDS = sorted(
    name for name, parser in cli.parser_with().commands.items() if has_json_arg(parser)
)


def test_the_commands_with_json_are_the_documented_ones() -> None:
    assert sorted(
        ["point", "convert", "pick", "plan", "status", "touch-test", "poses", "collect",
         "calibrate", "report"]
    ) == JSON_COMMANDS


@pytest.mark.parametrize("command", JSON_COMMANDS)
def test_a_refused_command_line_still_gets_one_report(
    command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert cli.main([command, "--json", "--no-such-flag"]) == 2
    out, err = capsys.readouterr()
    report = json.loads(out)  # one JSON object and nothing else
    assert (report["command"], report["status"], report["exit_status"]) == (
        command,
        "bad-input",
        2,
    )
    assert report["error_type"] == "InputError"
    assert report["audit_record"].startswith("none written: ")
    assert len(err.strip().splitlines()) == 1  # the line for a person stays


def test_a_command_without_json_prints_no_report(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["run", "--config", "cell.yaml", "--json"]) == 2
    assert capsys.readouterr().out == ""


class _Session:
    """What a Cell gives a report: the pick id of its latest records on disk."""

    def __init__(self, audit: AuditLog) -> None:
        self.audit = audit

    @property
    def last_pick_id(self) -> str | None:
        return self.audit.pick_id if self.audit.records_written else None


def test_a_record_that_failed_to_write_is_never_named(tmp_path: Path) -> None:
    audit = AuditLog(tmp_path / "gone" / "free-picks.jsonl")  # its folder does not exist
    report = JsonReport("pick")
    report.audit_from(_Session(audit))
    with pytest.raises(AuditError) as failed:
        audit.append({"event": "plan"})
    assert audit.records_written == 0
    ended = report.ended(2, failed.value)
    assert "pick_id" not in ended
    assert ended["audit_record"] == "none written: the audit file cannot take a record (see error)"


def test_a_record_on_disk_is_named_whatever_the_ending(tmp_path: Path) -> None:
    audit = AuditLog(tmp_path / "free-picks.jsonl")  # free-: a record of any shape
    audit.append({"event": "plan"})
    assert audit.records_written == 1
    report = JsonReport("pick")
    report.audit_from(_Session(audit))
    report.update(status="picked", host="127.0.0.9")
    assert report.ended(0, None) == {
        "command": "pick",
        "status": "picked",
        "exit_status": 0,
        "host": "127.0.0.9",
        "pick_id": audit.pick_id,
    }
    failed = report.ended(4, RobotFault("protective stop"))
    assert (failed["status"], failed["error"], failed["pick_id"]) == (
        "fault",
        "protective stop",
        audit.pick_id,
    )


def test_json_abbreviated_as_argparse_allows_still_prints_the_report(
    capsys: pytest.CaptureFixture[str],
) -> None:
    argv = ["convert", "--from", "ur", "--to", "ur", "--js", "0.1", "0", "0", "0", "0", "0"]
    assert cli.main(argv) == 0
    report = json.loads(capsys.readouterr().out)
    assert (report["command"], report["status"], report["values"]) == (
        "convert",
        "done",
        [0.1, 0, 0, 0, 0, 0],
    )
