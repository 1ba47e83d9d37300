"""The audit format's version: every record carries it, docs/audit.schema.json describes every
record kind, and readers refuse a version newer than they know."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from handeye_pick.audit import SCHEMA_VERSION, AuditError, AuditLog, open_audit, read_audit
from tests.audit_schema import invalid_records, record_problems


def _write(path: Path, *records: dict[str, object]) -> None:
    path.write_text("".join(json.dumps(record) + "\n" for record in records))


def test_every_record_carries_the_format_version(tmp_path: Path) -> None:
    log = AuditLog(tmp_path / "free-a.jsonl")
    log.append(
        {
            "event": "outcome",
            "status": "abandoned",
            "dry_run": None,
            "plan_timestamp": None,
            "detail": "test",
        }
    )
    (record,) = read_audit(tmp_path / "free-a.jsonl")
    assert isinstance(record, dict)
    assert record["schema"] == SCHEMA_VERSION == 2
    assert record_problems(record) == []


def test_the_schema_refuses_what_is_not_a_record_kind() -> None:
    good = {
        "schema": 1,
        "timestamp": "2026-12-02T07:00:00+00:00",
        "pick_id": "p",
        "event": "capture",
        "cycle": 1,
        "capture_id": "c1",
        "flange_pose_source": "latched",
        "flange_pose": [0.1, 0, 0.3, 3.14, 0, 0],
    }
    assert record_problems(good) == []
    assert record_problems({**good, "flange_pose": [0.1, 0, 0.3]}) != []  # not a UR vector
    assert record_problems({**good, "event": "pick"}) != []
    assert record_problems({**good, "unknown": 1}) != []
    assert record_problems({**good, "schema": 3}) != []
    assert record_problems({**good, "schema": 1}) == []  # a version 1 file reads alike


def test_the_suite_check_finds_an_invalid_record_and_skips_hand_written_ones(
    tmp_path: Path,
) -> None:
    folder = tmp_path / "check"
    folder.mkdir()
    _write(
        folder / "x.jsonl",
        {"pick_id": "hand", "event": "plan"},  # written by a test by hand: no schema
        {"schema": 1, "timestamp": "t", "pick_id": "p", "event": "outcome", "status": "nope"},
    )
    problems = invalid_records(folder)
    assert problems
    assert all("x.jsonl:2:" in line for line in problems)
    (folder / "x.jsonl").rename(folder / "free-x.jsonl")
    assert invalid_records(folder) == []


@pytest.mark.parametrize("version", [3, "1", True])
def test_readers_refuse_a_version_they_do_not_know(tmp_path: Path, version: object) -> None:
    path = tmp_path / "free-a.jsonl"
    _write(path, {"schema": version, "pick_id": "p", "event": "plan"})
    with pytest.raises(AuditError, match="byte 0") as raised:
        open_audit(path)  # the resume-after-kill scan
    assert "\n" not in str(raised.value)
    with pytest.raises(AuditError, match="byte 0"):
        list(read_audit(path))


def test_records_from_before_versions_are_read(tmp_path: Path) -> None:
    path = tmp_path / "free-a.jsonl"
    _write(path, {"pick_id": "old", "event": "plan", "host": "h", "config": "c"})
    audit, (warning,) = open_audit(path)  # closed as abandoned, as before
    audit.close()
    assert "old planned at" in warning
